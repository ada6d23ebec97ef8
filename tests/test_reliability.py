"""Faults a render must survive: workers killed, Ctrl-C and SIGTERM, the parent killed, memory and disk limits."""

from __future__ import annotations

import errno
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from tracer import cli, default_scene
from tracer.scene import scene as sc
from tracer.tracing.images import write_image
from tracer.tracing.wavefront import TracedScene
from tracer.workers import resources as rs
from tracer.workers.parallel import Renderer, bands, render
from tracer.workers.pool import MAX_ATTEMPTS, TaskFailedError, WorkerLostError, WorkerPool
from tracer.workers.resources import band_samples

ROOT = Path(__file__).resolve().parents[1]


def children(pid: int) -> list[int]:
    try:
        text = Path(f"/proc/{pid}/task/{pid}/children").read_text()
    except OSError:
        return []
    return [int(child) for child in text.split()]


def alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except OSError:
        return False
    return state != "Z"


def wait_for(condition, seconds: float) -> bool:
    deadline = time.monotonic() + seconds
    while time.monotonic() < deadline:
        if condition():
            return True
        time.sleep(0.02)
    return condition()


# ---- the pool ----------------------------------------------------------------------------------------------------


def test_a_worker_killed_mid_frame_has_its_bands_traced_again_and_the_image_is_the_same_bytes() -> None:
    scene = default_scene().with_render(width=160, height=192, samples=36)
    assert len(bands(scene.render)) >= 6  # bands left after the first finishes, some in the killed worker's hands
    expected = render(scene, workers=1).image
    with Renderer(2) as renderer:
        killed: list[int] = []

        def kill_one(done: int, _total: int) -> None:
            if done == 1:
                killed.append(renderer._pool.pids()[0])
                os.kill(killed[0], signal.SIGKILL)

        image = renderer.render(scene, kill_one).image
        assert renderer._pool.restarts >= 1
        assert killed[0] not in renderer._pool.pids()
        assert np.array_equal(image, expected)
        assert np.array_equal(renderer.render(scene).image, expected)  # the pool goes on with a fresh worker


def _kill_myself() -> None:
    os.kill(os.getpid(), signal.SIGKILL)


def _fail() -> None:
    raise ZeroDivisionError("a bug")


def _square(value: int) -> int:
    return value * value


def test_a_task_that_kills_every_worker_stops_after_bounded_attempts_and_the_pool_stays_usable() -> None:
    pool = WorkerPool(2)
    try:
        deadly = pool.submit(_kill_myself, ())
        with pytest.raises(WorkerLostError, match=r"died 3 times .*killed by signal 9.*fewer workers"):
            list(pool.as_completed([deadly]))
        assert deadly.attempts == MAX_ATTEMPTS
        assert [task.result for task in pool.as_completed([pool.submit(_square, (7,))])] == [49]
    finally:
        pool.close()


def _echo_doubled(values: np.ndarray) -> np.ndarray:
    return values * 2


LARGE_MESSAGES_SCRIPT = """
import numpy as np
from tracer.workers.pool import WorkerPool
pool = WorkerPool(2)
values = np.arange(1_000_000, dtype=np.float64)  # 8 MB each way: far more than a pipe holds
from tests.test_reliability import _echo_doubled
tasks = [pool.submit(_echo_doubled, (values + k,)) for k in range(8)]
assert len(list(pool.as_completed(tasks))) == 8
assert all(np.array_equal(task.result, (values + k) * 2) for k, task in enumerate(tasks))
pool.close()
print("ok")
"""


def test_large_tasks_and_results_both_ways_do_not_deadlock_the_pipes() -> None:
    # the parent sending a task while a worker sends a result used to leave both blocked on full pipes forever
    result = subprocess.run(
        [sys.executable, "-c", LARGE_MESSAGES_SCRIPT],
        cwd=Path(__file__).resolve().parents[1],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stderr


def test_an_exception_in_a_worker_comes_back_as_one_line_with_the_workers_traceback_kept() -> None:
    pool = WorkerPool(1)
    try:
        with pytest.raises(TaskFailedError, match=r"^a worker failed: ZeroDivisionError: a bug$") as raised:
            list(pool.as_completed([pool.submit(_fail, ())]))
        assert "Traceback" in raised.value.details
        assert [task.result for task in pool.as_completed([pool.submit(_square, (3,))])] == [9]
    finally:
        pool.close()


def test_a_cancelled_frame_leaves_the_pool_ready_for_the_next() -> None:
    scene = default_scene().with_render(width=96, height=96, samples=16)
    expected = render(scene, workers=1).image

    class CancelledError(Exception):
        pass

    def cancel(_done: int, _total: int) -> None:
        raise CancelledError

    with Renderer(2) as renderer:
        with pytest.raises(CancelledError):
            renderer.render(scene, cancel)
        assert np.array_equal(renderer.render(scene).image, expected)


# ---- the command line under signals ------------------------------------------------------------------------------

SLOW_RENDER = ["--width", "640", "--height", "480", "--samples", "64", "--workers", "2", "--quiet"]


def start_render(tmp_path: Path, *flags: str) -> subprocess.Popen:
    return subprocess.Popen(
        [sys.executable, "-m", "tracer", "render", "-o", str(tmp_path / "out.png"), *flags],
        cwd=ROOT,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,  # its own process group, as a shell gives a foreground job
    )


def workers_of(process: subprocess.Popen, settle: float = 0.5) -> list[int]:
    """The render's worker processes, once both run (and settle seconds later, into the first bands)."""
    assert wait_for(lambda: len(children(process.pid)) >= 2, 30.0), "the workers never started"
    time.sleep(settle)
    return children(process.pid)


def test_ctrl_c_stops_a_multi_worker_render_at_once_with_one_line_and_no_traceback(tmp_path: Path) -> None:
    process = start_render(tmp_path, *SLOW_RENDER)
    workers = workers_of(process)
    sent = time.monotonic()
    os.killpg(process.pid, signal.SIGINT)  # what Ctrl-C in a terminal does: the whole foreground group
    _out, err = process.communicate(timeout=30)
    took = time.monotonic() - sent
    assert process.returncode == cli.EXIT_INTERRUPTED
    assert took < 5.0, f"took {took:.1f} s to stop"
    assert "Traceback" not in err
    assert [line for line in err.splitlines() if line.strip()] == ["interrupted: no image written"]
    assert wait_for(lambda: not any(alive(pid) for pid in workers), 5.0)
    assert list(tmp_path.iterdir()) == []


ANIMATION = ["--width", "640", "--height", "480", "--workers", "2", "--quiet"]  # about 10 frames a second


def test_ctrl_c_stops_a_multi_worker_animation_at_once_keeping_whole_frames(tmp_path: Path) -> None:
    process = subprocess.Popen(
        [sys.executable, "-m", "tracer", "animate", "-o", str(tmp_path), "--frames", "1-400", *ANIMATION],
        cwd=ROOT,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    workers = workers_of(process)
    # once frames are being written (the animation first traces its image without the vane and each heading's
    # pixels, a second or more before its first frame on a loaded machine)
    assert wait_for(lambda: any(path.suffix == ".png" for path in tmp_path.iterdir()), 60.0), "no frame written"
    os.killpg(process.pid, signal.SIGINT)
    _out, err = process.communicate(timeout=30)
    assert process.returncode == cli.EXIT_INTERRUPTED
    assert "Traceback" not in err and [line for line in err.splitlines() if line.strip()] == [
        "interrupted: finished frames stay"
    ]
    assert wait_for(lambda: not any(alive(pid) for pid in workers), 5.0)
    names = sorted(path.name for path in tmp_path.iterdir())
    assert all(name.startswith("frame_") and name.endswith(".png") for name in names), names  # no temporaries
    assert 0 < len(names) < 400


def test_sigterm_stops_a_render_like_ctrl_c(tmp_path: Path) -> None:
    process = start_render(tmp_path, *SLOW_RENDER)
    workers = workers_of(process)
    process.terminate()
    _out, err = process.communicate(timeout=30)
    assert process.returncode == cli.EXIT_TERMINATED
    assert "Traceback" not in err and err.strip() == "terminated: no image written"
    assert wait_for(lambda: not any(alive(pid) for pid in workers), 5.0)
    assert list(tmp_path.iterdir()) == []


def test_workers_leave_quietly_when_the_parent_is_killed_and_no_file_is_left(tmp_path: Path) -> None:
    shared_before = set(os.listdir("/dev/shm")) if os.path.isdir("/dev/shm") else set()
    process = start_render(tmp_path, *SLOW_RENDER)
    workers = workers_of(process)
    process.kill()
    _out, err = process.communicate(timeout=30)
    assert wait_for(lambda: not any(alive(pid) for pid in workers), 10.0), "workers outlived their parent"
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []
    if os.path.isdir("/dev/shm"):
        assert {name for name in set(os.listdir("/dev/shm")) - shared_before if "weathervane" in name} == set()


def test_a_worker_killed_under_the_command_line_changes_nothing(tmp_path: Path) -> None:
    flags = ["--width", "480", "--height", "360", "--samples", "36", "--workers", "2", "--quiet"]
    process = start_render(tmp_path, *flags)
    os.kill(workers_of(process, settle=0.1)[0], signal.SIGKILL)
    _out, err = process.communicate(timeout=120)
    assert process.returncode == 0, err
    expected = tmp_path / "expected.png"
    assert cli.main(["render", "-o", str(expected), *flags[:-3], "--workers", "1", "--quiet"]) == 0
    assert (tmp_path / "out.png").read_bytes() == expected.read_bytes()


# ---- memory and disk ---------------------------------------------------------------------------------------------


def test_every_piece_traced_stays_within_the_band_budget_at_any_sample_count(monkeypatch) -> None:
    """Rows of many samples are traced in pieces of at most band_samples(): whole rows, or a row's columns when one
    row is too many. The budget is made small here so that the test's frame stays cheap; the pixels are the same
    bytes as one piece gives."""
    scene = default_scene().with_render(width=64, height=4, samples=256, depth=1)
    traced: list[int] = []
    original = TracedScene.trace

    def recording(self, D, counts, *rest):
        traced.append(D.shape[1])
        return original(self, D, counts, *rest)

    monkeypatch.setattr(TracedScene, "trace", recording)
    monkeypatch.setattr("tracer.workers.resources.BAND_BYTES", 4096 * 8)
    image = render(scene, workers=1).image
    assert band_samples(scene.render) == 4096 < 64 * 256  # less than one row
    assert max(traced) <= 4096 and sum(traced) >= 64 * 4 * 256
    monkeypatch.setattr("tracer.workers.resources.BAND_BYTES", 1 << 24)
    traced.clear()
    assert np.array_equal(render(scene, workers=1).image, image)
    assert max(traced) == 64 * 4 * 256


def test_a_render_that_cannot_fit_in_memory_is_refused_before_it_starts(monkeypatch, tmp_path: Path, capsys) -> None:
    monkeypatch.setattr(rs, "available_memory", lambda: 2 * 10**9)
    target = tmp_path / "huge.png"
    code = cli.main(["render", "--width", "16384", "--height", "16384", "--dtype", "float64", "-o", str(target)])
    err = capsys.readouterr().err
    assert code == cli.EXIT_FAILED
    assert "16384x16384 float64" in err and "2.0 GB is available" in err and "--dtype float32" in err
    assert "Traceback" not in err and not target.exists()
    needed = rs.memory_needed(default_scene().with_render(width=16384, height=16384).render, 2, output=".png")
    assert needed > 16384 * 16384 * 3 * 8  # at least the image itself


def test_a_scene_whose_meshes_cannot_fit_is_refused_naming_them(monkeypatch, tmp_path: Path, capsys) -> None:
    """The scene's own share (distinct triangles, instances) counts beside the image's: a 64x48 frame of a mesh of
    50,000 triangles instanced 1,000 times, with 100 MB free."""
    import json

    from tracer.scene.loader import default_scene_dict

    grid = 50
    vertices = [[x, y, 0.0] for y in range(grid + 1) for x in range(grid + 1)]
    quads = [
        (y * (grid + 1) + x, y * (grid + 1) + x + 1, (y + 1) * (grid + 1) + x) for y in range(grid) for x in range(grid)
    ]
    document = default_scene_dict()
    material = next(iter(document["materials"]))
    document["meshes"] = {
        "sheet": {"vertices": vertices, "triangles": [list(q) for q in quads] * 20, "material": material}
    }
    document["objects"].append(
        {
            "name": "sheets",
            "type": "instances",
            "mesh": "sheet",
            "matrices": [[1, 0, 0, i, 0, 1, 0, 0, 0, 0, 1, 0] for i in range(1000)],
        }
    )
    scene_file = tmp_path / "sheets.json"
    scene_file.write_text(json.dumps(document))
    monkeypatch.setattr(rs, "available_memory", lambda: 100 * 10**6)
    target = tmp_path / "sheets.png"
    code = cli.main(["render", str(scene_file), "--width", "64", "--height", "48", "-o", str(target)])
    err = capsys.readouterr().err
    assert code == cli.EXIT_FAILED and not target.exists() and "Traceback" not in err
    assert "of 50,000 triangles and 1,000 instances needs about" in err, err
    assert "100.0 MB is available; the largest: sheet (50,000 triangles); try fewer triangles" in err, err
    assert rs.scene_bytes(50_000, 1000) == 50_000 * rs.BYTES_PER_TRIANGLE + 1000 * rs.BYTES_PER_INSTANCE


def test_a_refusal_names_what_needs_the_memory_and_the_margin_it_keeps() -> None:
    """A huge image of a small scene is refused for its image (no triangle counts, no "fewer triangles"), and one
    that fits the memory but not the margin kept beside it says the margin, not a need below what is free."""
    huge = sc.RenderSettings(width=30000, height=30000)
    needed = rs.memory_needed(huge, 2) + rs.scene_bytes(8, 0)
    line = rs.refusal(huge, 2, needed, int(needed * 1.05), 8, 0, (("Ground", 8),), blender=True)
    assert line == (
        f"a 30000x30000 float64 render with 2 workers needs about {rs._size(round(needed * rs.HEADROOM))} of memory "
        f"({rs._size(needed)} and a 10% margin) and {rs._size(int(needed * 1.05))} is available; try Precision "
        "32-bit, fewer Processes, a lower Resolution %"
    )
    small = sc.RenderSettings(width=64, height=48)
    needed = rs.memory_needed(small, 2) + rs.scene_bytes(50_000, 0)
    line = rs.refusal(small, 2, needed, needed // 2, 50_000, 0, (("sheet", 50_000),))
    assert "of 50,000 triangles needs about" in line and "the largest: sheet (50,000 triangles); try fewer" in line


def test_an_output_larger_than_the_free_disk_is_refused(monkeypatch, tmp_path: Path) -> None:
    monkeypatch.setattr(rs.shutil, "disk_usage", lambda _path: _Usage())
    settings = default_scene().render  # 640x480: a .npy of 3.7 MB
    with pytest.raises(rs.ResourceError, match=r"out\.npy: needs up to 3\.7 MB on disk and .* has 1\.0 KB free"):
        rs.check_disk(tmp_path / "sub" / "out.npy", rs.output_bytes(settings, ".npy"))
    rs.check_disk(tmp_path / "out.png", 900)


class _Usage:
    free = 1000


def test_a_full_disk_says_so_for_the_users_path() -> None:
    image = np.zeros((4, 4, 3))
    with pytest.raises(OSError) as raised:
        from tracer.tracing.images import _write_npy

        _write_npy(image, Path("/dev/full"))
    assert raised.value.errno == errno.ENOSPC
    assert cli._write_problem(Path("out/a.npy"), raised.value) == "error: no space left on the device for out/a.npy"


# ---- output names ------------------------------------------------------------------------------------------------


def test_the_longest_file_name_the_system_allows_can_be_written(tmp_path: Path) -> None:
    name = "x" * (255 - len(".png")) + ".png"
    write_image(np.zeros((2, 2, 3)), tmp_path / name)
    assert [path.name for path in tmp_path.iterdir()] == [name]


def test_output_through_a_symbolic_link_replaces_what_it_points_to_and_keeps_the_link(tmp_path: Path) -> None:
    real = tmp_path / "real.png"
    real.write_bytes(b"old")
    link = tmp_path / "link.png"
    link.symlink_to(real)
    write_image(np.ones((2, 2, 3)), link)
    assert link.is_symlink() and link.resolve() == real
    assert real.read_bytes().startswith(b"\x89PNG")
    assert sorted(path.name for path in tmp_path.iterdir()) == ["link.png", "real.png"]


def test_a_renderer_closed_for_good_from_another_thread_stops_its_render_and_starts_no_worker_again() -> None:
    """Blender quitting during F12: the add-on closes its pools on the main thread while the render's thread waits
    on them. The render ends with PoolClosedError, the workers it ended are not replaced, and nothing starts more."""
    import threading

    from tracer.workers.pool import PoolClosedError

    renderer = Renderer(2, start_method="spawn")
    # 30 bands: when the first is done, most are still queued (320x240 made 2, and on a quiet machine the second
    # was back before the close, so the render ended whole)
    scene = default_scene().with_render(width=640, height=480, samples=16)
    renderer.render(scene.with_render(width=8, height=8, samples=1))  # the pool is up
    pool = renderer._pool
    failures: list = []

    def closing(done: int, _total: int) -> None:
        if done == 1:
            threading.Thread(target=renderer.close, kwargs={"final": True}).start()
            time.sleep(0.5)

    try:
        renderer.render(scene, progress=closing)
    except PoolClosedError as error:
        failures.append(error)
    assert failures and pool.restarts == 0 and pool.pids() == []
    with pytest.raises(PoolClosedError):
        renderer.render(scene)
    assert renderer._pool is None


def test_a_frame_of_two_bands_goes_to_both_of_two_workers() -> None:
    """Tasks are dealt to the least busy worker: two tasks on two workers run in two processes (filling one
    worker's TASKS_AHEAD first gave both bands of the default frame to one worker)."""
    from tracer.workers.pool import WorkerPool

    pool = WorkerPool(2)
    try:
        tasks = [pool.submit(os.getpid, ()) for _ in range(2)]
        pids = {task.result for task in pool.as_completed(tasks)}
        assert pids == set(pool.pids())
    finally:
        pool.close()


def test_a_pools_workers_run_at_the_niceness_asked_for() -> None:
    """A Renderer made for a program that draws its images (the 3D View's ProgressiveRender) starts its workers that
    much nicer than itself; the default leaves them at the parent's priority."""
    from tracer.workers.parallel import Renderer

    base = os.nice(0)
    for niceness in (0, 5):
        with Renderer(2, niceness=niceness) as renderer:
            assert renderer.map(os.nice, [(0,), (0,)]) == [min(19, base + niceness)] * 2
