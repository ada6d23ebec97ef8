"""Temporary files that killed writers leave are swept by the next command writing into the folder; a live writer's
temporary file, in any process, is never touched (tracer/tracing/images.py: the writer holds a lock on it)."""

from __future__ import annotations

import os
import random
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from tracer.tracing.images import sweep_stale_temporaries

ROOT = Path(__file__).resolve().parents[1]

# A writer that takes its temporary file and then waits (to be killed, or to be released by a line on stdin).
WRITER = """
import sys
from pathlib import Path
from tracer.tracing.images import atomic_path
with atomic_path(Path(sys.argv[1])) as temporary:
    temporary.write_bytes(b"half a frame")
    print("WRITING", temporary.name, flush=True)
    sys.stdin.readline()
"""


def start_writer(target: Path) -> tuple[subprocess.Popen, Path]:
    """A process inside atomic_path for target; returns it and its temporary file."""
    process = subprocess.Popen(
        [sys.executable, "-c", WRITER, str(target)],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    line = process.stdout.readline()
    assert line.startswith("WRITING "), line
    return process, target.parent / line.split()[1]


def temporaries(folder: Path) -> list[Path]:
    return sorted(folder.glob(".*.partial"))


def test_a_killed_writers_file_is_swept_and_a_live_writers_file_is_kept(tmp_path: Path) -> None:
    killed, killed_file = start_writer(tmp_path / "frame_0001.png")
    live, live_file = start_writer(tmp_path / "frame_0002.png")
    try:
        killed.kill()  # kill -9: no handler runs, the file stays
        killed.wait(timeout=30)
        assert temporaries(tmp_path) == sorted([killed_file, live_file])
        assert sweep_stale_temporaries(tmp_path) == 1
        assert temporaries(tmp_path) == [live_file]
        assert sweep_stale_temporaries(tmp_path) == 0  # swept again: the live writer's file stays
        live.communicate("go on\n", timeout=30)
        assert live.returncode == 0
        assert (tmp_path / "frame_0002.png").read_bytes() == b"half a frame"
        assert temporaries(tmp_path) == []
    finally:
        for process in (killed, live):
            if process.poll() is None:
                process.kill()


def test_only_the_writers_own_temporary_names_are_swept(tmp_path: Path) -> None:
    """Another program's hidden ".partial" files are the user's; an unlocked file of ours is swept when its process
    is gone, or when it is old (its process id taken since by another process)."""
    foreign = [tmp_path / ".download.partial", tmp_path / ".frame_0001.png.abcdefgh.partial"]
    for path in foreign:
        path.write_bytes(b"not ours")
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    gone = tmp_path / f".frame_0003.png.weathervane-{int(dead.stdout)}-abcd_123.partial"
    # pid 1 is alive: a file of that id is being created this instant unless it is old
    fresh = tmp_path / ".frame_0004.png.weathervane-1-abcd_123.partial"
    old = tmp_path / ".frame_0005.png.weathervane-1-efgh_456.partial"
    for path in (gone, fresh, old):
        path.write_bytes(b"ours")
    os.utime(old, (time.time() - 3600, time.time() - 3600))
    assert sweep_stale_temporaries(tmp_path) == 2
    assert sorted(tmp_path.iterdir()) == sorted([*foreign, fresh])


def test_a_render_sweeps_its_folder_and_says_so(tmp_path: Path) -> None:
    process, left = start_writer(tmp_path / "image.png")
    process.kill()
    process.wait(timeout=30)
    command = [sys.executable, "-m", "tracer", "render", "-o", str(tmp_path / "image.png"), "--width", "32"]
    result = subprocess.run([*command, "--height", "24"], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert result.returncode == 0, result.stderr
    assert "removed 1 temporary file a killed run had left" in result.stdout
    assert not left.exists() and temporaries(tmp_path) == []


def animate_command(folder: Path, frames: int) -> list[str]:
    """About 12 ms a frame on 2 cores: each killed run gets through a few dozen frames."""
    size = ["--width", "160", "--height", "120", "--samples", "16", "--workers", "2"]
    return [sys.executable, "-m", "tracer", "animate", "-o", str(folder), "--frames", f"1-{frames}", *size]


def kill_and_resume(folder: Path, frames: int, kills: int, seed: int) -> tuple[int, str]:
    """Starts the animation kills times, each killed (its whole process group, kill -9) at a random moment, leaves
    one more temporary file of a killed writer, then runs the animation to the end; returns how many temporary
    files were there before the last run, and its summary line."""
    generator = random.Random(seed)
    folder.mkdir()
    for _ in range(kills):
        written = len(list(folder.glob("frame_*.png")))
        process = subprocess.Popen(
            animate_command(folder, frames), cwd=ROOT, start_new_session=True, stdout=subprocess.DEVNULL
        )
        deadline = time.monotonic() + 60
        while len(list(folder.glob("frame_*.png"))) == written and time.monotonic() < deadline:
            if process.poll() is not None:  # it had nothing left to write
                break
            time.sleep(0.01)  # until this run writes frames: its start (about 1 s) is no use to kill
        time.sleep(generator.uniform(0.0, 0.4))
        os.killpg(process.pid, signal.SIGKILL)
        process.wait(timeout=30)
    writer, _ = start_writer(folder / f"frame_{frames:04d}.png")  # at least one, whatever the kills' timing
    writer.kill()
    writer.wait(timeout=30)
    left = len(temporaries(folder))
    command = animate_command(folder, frames)
    result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert result.returncode == 0, result.stderr
    return left, result.stdout


def check_kill_stress(tmp_path: Path, kills: int) -> None:
    # more frames than the kills' random moments reach (a kill comes within 0.4 s of a run's first frame)
    frames = max(25 * kills, 200)
    whole = tmp_path / "whole"
    result = subprocess.run(animate_command(whole, frames), capture_output=True, text=True, cwd=ROOT, timeout=600)
    assert result.returncode == 0, result.stderr
    resumed = tmp_path / "resumed"
    left, summary = kill_and_resume(resumed, frames, kills, seed=kills)
    print(f"{kills} kills and one killed writer left {left} temporary files; the resumed run: {summary}")
    assert f"removed {left} temporary file" in summary
    assert temporaries(resumed) == []
    names = sorted(path.name for path in whole.iterdir())
    assert len(names) == frames and sorted(path.name for path in resumed.iterdir()) == names
    for name in names:
        assert (resumed / name).read_bytes() == (whole / name).read_bytes(), name


def test_an_animation_killed_at_random_moments_then_resumed_leaves_no_temporary_file(tmp_path: Path) -> None:
    check_kill_stress(tmp_path, kills=2)  # 200 in make test-slow


@pytest.mark.slow
def test_two_hundred_kills_then_a_resume_leave_no_temporary_file(tmp_path: Path) -> None:
    check_kill_stress(tmp_path, kills=200)
