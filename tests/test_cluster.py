"""Animations on a real Dask cluster (a scheduler and two workers on 127.0.0.1): the same bytes as a local run,
a worker killed mid-run changes nothing and no frame is written twice, a lost scheduler stops the run with one line
and a state that resumes, and the flag without Dask installed says how to install it."""

from __future__ import annotations

import subprocess
import sys
from collections import Counter
from pathlib import Path

import pytest

from tracer.frames import cluster
from tracer.frames.animate import animate, frame_path
from tracer.scene.loader import default_scene

pytest.importorskip("distributed", reason="the cluster extra: make test installs dask[distributed]")
from tests.dask_cluster import LocalCluster

ROOT = Path(__file__).resolve().parents[1]
FRAMES = 24


def small_scene():
    return default_scene().with_render(width=160, height=120, workers=1)


@pytest.fixture(scope="module")
def local_frames(tmp_path_factory) -> dict[int, bytes]:
    """The 24 frames as `animate` writes them on this machine."""
    folder = tmp_path_factory.mktemp("local")
    animate(small_scene(), folder, 1, FRAMES, srgb=True)
    return {frame: frame_path(folder, frame).read_bytes() for frame in range(1, FRAMES + 1)}


def written_frames(folder: Path) -> dict[int, bytes]:
    paths = {frame: frame_path(folder, frame) for frame in range(1, FRAMES + 1)}
    return {frame: path.read_bytes() for frame, path in paths.items() if path.exists()}


def test_the_command_line_on_two_workers_writes_the_local_runs_bytes(tmp_path: Path, local_frames) -> None:
    with LocalCluster(workers=2) as dask:
        command = [sys.executable, "-m", "tracer", "animate", "--frames", f"1-{FRAMES}", "--width", "160"]
        command += ["--height", "120", "--srgb", "-o", str(tmp_path), "--scheduler", dask.address, "--chunk", "4"]
        result = subprocess.run(command, capture_output=True, text=True, cwd=ROOT, timeout=300)
        worker_logs = [(dask.folder / f"worker-{index}.log").read_text() for index in range(2)]
    assert result.returncode == 0, result.stderr
    assert f"{FRAMES} rendered" in result.stdout and f"traced on the Dask cluster at {dask.address}" in result.stdout
    assert written_frames(tmp_path) == local_frames
    assert not list(tmp_path.glob(".*"))  # no temporary left
    assert all("Registered to" in log for log in worker_logs)


def test_the_passes_files_come_back_from_the_workers_as_the_local_run_writes_them(tmp_path: Path) -> None:
    pytest.importorskip("OpenEXR", reason="the exr extra: make test installs the OpenEXR bindings")
    scene = small_scene().with_render(passes=("depth", "normal", "diffuse", "cryptomatte_object"))
    local, remote = tmp_path / "local", tmp_path / "remote"
    animate(scene, local, 1, 6, srgb=True)
    with LocalCluster(workers=2) as dask:
        result = cluster.animate_on_cluster(scene, remote, 1, 6, dask.address, srgb=True, chunk_frames=2)
    assert result.rendered == list(range(1, 7))
    names = sorted(path.name for path in local.iterdir())
    assert names == [f"frame_{frame:04d}.{kind}" for frame in range(1, 7) for kind in ("exr", "png")]
    assert sorted(path.name for path in remote.iterdir()) == names  # nothing else, no temporary left
    differing = [name for name in names if (remote / name).read_bytes() != (local / name).read_bytes()]
    assert not differing, differing
    assert animate(scene, remote, 1, 6).skipped == list(range(1, 7))  # the files resume as a local run's do


def test_a_worker_killed_mid_run_changes_nothing_and_no_frame_is_written_twice(
    tmp_path: Path, local_frames, monkeypatch
) -> None:
    writes: Counter[str] = Counter()
    atomic_path = cluster.atomic_path

    def counted(target: Path):
        writes[target.name] += 1
        return atomic_path(target)

    monkeypatch.setattr(cluster, "atomic_path", counted)
    with LocalCluster(workers=2) as dask:

        def progress(done: int, _total: int) -> None:
            if done == 1:  # the first frame is back: both workers are tracing their next runs
                dask.kill_worker(0)

        result = cluster.animate_on_cluster(
            small_scene(), tmp_path, 1, FRAMES, dask.address, srgb=True, progress=progress, chunk_frames=4
        )
        assert dask.worker_processes[0].wait(10) == -9  # it was killed, and the run finished without it
    assert result.rendered == list(range(1, FRAMES + 1))
    assert written_frames(tmp_path) == local_frames
    assert len(writes) == FRAMES and set(writes.values()) == {1}


def test_a_lost_scheduler_stops_with_one_line_and_the_run_resumes(tmp_path: Path, local_frames) -> None:
    with LocalCluster(workers=1) as dask:

        def progress(done: int, _total: int) -> None:
            if done == 4:  # the first run of frames is written
                dask.kill_scheduler()

        with pytest.raises(cluster.ClusterError) as stopped:
            cluster.animate_on_cluster(
                small_scene(), tmp_path, 1, FRAMES, dask.address, srgb=True, progress=progress, chunk_frames=4
            )
    message = str(stopped.value)
    assert message.startswith(f"lost the Dask scheduler at {dask.address}") and "\n" not in message
    assert "frames are written; run the same command again to render the rest" in message
    kept = written_frames(tmp_path)
    assert 4 <= len(kept) < FRAMES and all(local_frames[frame] == png for frame, png in kept.items())
    assert not list(tmp_path.glob(".*"))
    # the same run again (here on this machine) renders only the rest
    resumed = animate(small_scene(), tmp_path, 1, FRAMES, srgb=True)
    assert resumed.skipped == sorted(kept) and written_frames(tmp_path) == local_frames


def test_an_unreachable_scheduler_is_one_line_and_exit_1(tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setattr(cluster, "CONNECT_SECONDS", 1.0)
    from tracer.cli import main

    code = main(["animate", "--frames", "1-2", "--width", "8", "--height", "6", "-o", str(tmp_path), "--quiet",
                 "--scheduler", "tcp://127.0.0.1:9"])  # fmt: skip
    assert code == 1
    assert not list(tmp_path.iterdir())


def test_without_dask_the_flag_says_how_to_install_it(tmp_path: Path) -> None:
    script = (
        "import sys; sys.modules['distributed'] = None\n"
        "from tracer.cli import main\n"
        f"sys.exit(main(['animate', '--frames', '1-2', '-o', {str(tmp_path)!r}, '--scheduler', 'tcp://127.0.0.1:9']))"
    )
    result = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert result.returncode == 1
    assert result.stderr.strip().splitlines() == [
        f"error: --scheduler needs Dask's distributed scheduler, which is not installed: {cluster.INSTALL_HINT}"
    ]
    assert not list(tmp_path.iterdir())


def test_chunk_without_a_scheduler_is_refused(tmp_path: Path) -> None:
    from tracer.cli import main

    assert main(["animate", "--frames", "1-2", "-o", str(tmp_path), "--chunk", "4", "--quiet"]) == 2
    assert not list(tmp_path.iterdir())
