"""Render settings -> the memory and disk a render needs, checked before it starts (a clear refusal, not a crash).

A 16384 x 16384 image in float64 is 6.4 GB before anything is traced; started on a machine without the room, it
ends in the OOM killer or an OSError halfway. The estimate is deliberately simple and errs on the large side:
every image held at once, each worker's band arrays (BAND_PEAK_COORDINATES per sample), and the output buffers.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from ..scene import passes as ps
from ..scene import scene as sc

# A band's arrays peak at about 35 coordinates per camera sample (measured: docs/performance.md); the worker's
# interpreter, NumPy and prepared scene add about WORKER_BASE_BYTES.
BAND_PEAK_COORDINATES = 40
WORKER_BASE_BYTES = 60 << 20
# One coordinate of every camera sample of a band, in bytes. A band's arrays peak at about 35 such coordinates per
# sample. Small frames go in few large bands (each band costs fixed NumPy overhead); a large image leaves less room
# beside it, so its bands are smaller (both measured in docs/measurements.md#the-tracers-constants).
BAND_BYTES = 1_280_000  # 160,000 samples in float64, 320,000 in float32
LARGE_IMAGE_BYTES = 16 << 20
LARGE_IMAGE_BAND_BYTES = 480_000  # 60,000 samples in float64, 120,000 in float32
# Beyond the tracer's own estimate, room left for everything else on the machine.
HEADROOM = 1.1
# A scene's own share: the growth of Blender's process and its 2 workers over a first F12 (Blender's arrays read, the
# scene file's lists, the loader's arrays, each worker's hierarchy), at most 1.9 KB a triangle and 2.9 KB an instance
# as measured (docs/measurements.md#the-tracers-constants), rounded up.
BYTES_PER_TRIANGLE = 2048
BYTES_PER_INSTANCE = 4096


def band_samples(settings: sc.RenderSettings) -> int:
    """The most camera samples traced at once: about BAND_BYTES / itemsize (LARGE_IMAGE_BAND_BYTES for an image of
    more than LARGE_IMAGE_BYTES). A band of more samples (a block of rows at many samples per pixel) is traced in
    pieces of this size, so memory stays bounded at any sample count."""
    itemsize = np.dtype(settings.dtype).itemsize
    large = settings.height * settings.width * 3 * itemsize > LARGE_IMAGE_BYTES
    return (LARGE_IMAGE_BAND_BYTES if large else BAND_BYTES) // itemsize


class ResourceError(RuntimeError):
    """Not enough memory or disk for a render; the message says what is needed and how to need less."""


def image_bytes(settings: sc.RenderSettings) -> int:
    """A frame's image and its render passes' planes (each pass its channels in the image's dtype, Cryptomatte's in
    float32: tracer/tracing/recorder.py)."""
    itemsize = np.dtype(settings.dtype).itemsize
    passes = sum(
        ps.width(name, settings.cryptomatte_levels) * (4 if ps.PASSES[name].combine == "ranks" else itemsize)
        for name in settings.passes
    )
    return settings.width * settings.height * (3 * itemsize + passes)


def memory_needed(settings: sc.RenderSettings, workers: int, frames: int = 1, output: str | None = None) -> int:
    """Bytes a render needs at its peak: frames images, each worker's band arrays, and the output's buffers
    (output: '.png' or '.npy', the file's suffix, or None when no file is written)."""
    itemsize = np.dtype(settings.dtype).itemsize
    pixels = settings.width * settings.height
    at_once = min(band_samples(settings), pixels * settings.samples)
    per_worker = WORKER_BASE_BYTES + at_once * BAND_PEAK_COORDINATES * itemsize
    if settings.samples > 1:  # the passes' values of every camera sample until its pixel's are combined
        per_worker += at_once * sum(
            8 if ps.PASSES[name].combine == "ranks" else ps.width(name) * itemsize for name in settings.passes
        )
    writing = {".png": 2 * pixels * 3, ".npy": 0, None: 0}.get(output, 0)  # 8-bit copy and the encoded PNG
    return frames * image_bytes(settings) + max(1, workers) * per_worker + writing


def scene_bytes(triangles: int, instances: int) -> int:
    """Bytes preparing a scene of this many distinct triangles (a mesh placed once counts in full, instances of one
    mesh count its triangles once) and instances takes, beside the render's own (memory_needed)."""
    return triangles * BYTES_PER_TRIANGLE + instances * BYTES_PER_INSTANCE


def scene_counts(scene: sc.Scene, largest: int = 3) -> dict:
    """A loaded scene's distinct triangles (an instanced mesh once), instances and its largest meshes, as
    check_resources takes them (triangles=, instances=, largest=)."""
    meshes: dict[int, tuple[str, int]] = {}
    instances = 0
    for obj in scene.objects:
        if isinstance(obj, sc.MeshInstances):
            instances += len(obj.matrices)
            meshes[id(obj.mesh)] = (obj.mesh_name, len(obj.mesh.triangles))
        elif isinstance(obj, sc.TriangleMesh):
            meshes[id(obj)] = (obj.name, len(obj.triangles))
    biggest = sorted(meshes.values(), key=lambda item: -item[1])[:largest]
    return {
        "triangles": sum(count for _, count in meshes.values()),
        "instances": instances,
        "largest": tuple(item for item in biggest if item[1]),
    }


def available_memory() -> int | None:
    """What can be allocated now, the least of three limits, or None where none is known: the kernel's
    MemAvailable (without swapping), this process's address-space limit (RLIMIT_AS) less what it has mapped, and
    its cgroup's memory.max less memory.current (a container's limit)."""
    limits = [limit for limit in (_meminfo_available(), _address_space_left(), _cgroup_left()) if limit is not None]
    return min(limits) if limits else None


def _meminfo_available() -> int | None:
    try:
        with open("/proc/meminfo", encoding="ascii") as meminfo:
            for line in meminfo:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        return None
    return None


def _address_space_left() -> int | None:
    """RLIMIT_AS (soft) less this process's mapped size (VmSize); None where there is no such limit."""
    try:
        import resource  # POSIX only

        soft, _ = resource.getrlimit(resource.RLIMIT_AS)
        if soft == resource.RLIM_INFINITY:
            return None
        with open("/proc/self/status", encoding="ascii") as status:
            for line in status:
                if line.startswith("VmSize:"):
                    return max(0, soft - int(line.split()[1]) * 1024)
    except (ImportError, OSError, ValueError, IndexError):
        return None
    return None


def _cgroup_left() -> int | None:
    """The cgroup v2 memory.max less memory.current of this process's cgroup; None where unlimited or unknown."""
    try:
        with open("/proc/self/cgroup", encoding="ascii") as cgroup:
            path = next((line.split(":", 2)[2].strip() for line in cgroup if line.startswith("0::")), None)
        if path is None:
            return None
        folder = Path("/sys/fs/cgroup") / path.lstrip("/")
        limit = (folder / "memory.max").read_text(encoding="ascii").strip()
        if limit == "max":
            return None
        return max(0, int(limit) - int((folder / "memory.current").read_text(encoding="ascii").strip()))
    except (OSError, ValueError, IndexError):
        return None


def out_of_memory_message(settings: sc.RenderSettings, workers: int) -> str:
    """The one line for a render that ran out of memory midway (a limit check_resources could not see)."""
    return (
        f"out of memory during a {settings.width}x{settings.height} {settings.dtype} render with {max(1, workers)}"
        f" workers ({_size(memory_needed(settings, workers))} estimated, {_size(available_memory() or 0)} available"
        f" now); try {', '.join(_advice(settings, workers))}"
    )


def _advice(settings: sc.RenderSettings, workers: int, blender: bool = False) -> list[str]:
    """What would need less memory, in the command line's flags or (blender) in the add-on's settings' words."""
    advice = []
    if settings.dtype == "float64":
        advice.append("Precision 32-bit" if blender else "--dtype float32")
    if workers > 1:
        advice.append("fewer Processes" if blender else "fewer --workers")
    advice.append("a lower Resolution %" if blender else "a smaller --width/--height")
    return advice


def _size(count: int) -> str:
    for unit, scale in (("GB", 1e9), ("MB", 1e6), ("KB", 1e3)):
        if count >= scale:
            return f"{count / scale:.1f} {unit}"
    return f"{count} bytes"


def scene_room(
    settings: sc.RenderSettings,
    workers: int,
    available: int,
    frames: int = 1,
    output: str | None = None,
    extra: int = 0,
) -> float:
    """The scene bytes (scene_bytes) that fit beside the render in the memory available: check_resources passes
    while the scene needs less (a bound for callers that count a scene as they find it; the check itself decides
    near it)."""
    return available / HEADROOM - memory_needed(settings, workers, frames, output) - extra


def check_resources(
    settings: sc.RenderSettings,
    workers: int,
    frames: int = 1,
    output: str | None = None,
    *,
    triangles: int = 0,
    instances: int = 0,
    largest: tuple[tuple[str, int], ...] = (),
    available: int | None = None,
    blender: bool = False,
    extra: int = 0,
) -> None:
    """Raise ResourceError when the scene's preparation (triangles, instances: scene_bytes) and the render cannot fit
    in the memory there is now (available: what available_memory() says, where the caller read it already).
    largest: the biggest meshes as (name, triangles), named in the message; blender: its advice in the add-on's
    words; extra: bytes the caller holds beside the render (the Rendered view's kept ray trees)."""
    needed = memory_needed(settings, workers, frames, output) + scene_bytes(triangles, instances) + extra
    available = available_memory() if available is None else available
    if available is None or needed * HEADROOM <= available:
        return
    raise ResourceError(refusal(settings, workers, needed, available, triangles, instances, largest, blender))


def refusal(
    settings: sc.RenderSettings,
    workers: int,
    needed: int,
    available: int,
    triangles: int = 0,
    instances: int = 0,
    largest: tuple[tuple[str, int], ...] = (),
    blender: bool = False,
) -> str:
    """The one line that refuses a render: what it would need, of what, what is free, and what to change. The scene
    (its counts, its largest meshes, fewer triangles as the first advice) is named where it needs at least as much as
    the image (a 30000x30000 render of a few meshes is refused for its image); a render refused by the margin alone
    says the margin."""
    scene_part = scene_bytes(triangles, instances)
    scene_first = scene_part > 0 and scene_part >= image_bytes(settings)
    counts = [f"{triangles:,} triangles"] if triangles else []
    counts += [f"{instances:,} instances"] if instances else []
    scene = f" of {' and '.join(counts)}" if counts and scene_first else ""
    advice = _advice(settings, workers, blender)
    named = ""
    if largest and scene_first:
        advice.insert(0, "fewer triangles (a lower Subdivision level) or instances")
        named = "; the largest: " + ", ".join(f"{name} ({count:,} triangles)" for name, count in largest)
    amount = _size(needed)
    if needed <= available:  # within the memory, not within the margin kept beside it
        amount = f"{_size(round(needed * HEADROOM))} of memory ({amount} and a {round(100 * (HEADROOM - 1))}% margin)"
    else:
        amount += " of memory"
    return (
        f"a {settings.width}x{settings.height} {settings.dtype} render with {max(1, workers)} workers{scene} needs "
        f"about {amount} and {_size(available)} is available{named}; try {', '.join(advice)}"
    )


def output_bytes(settings: sc.RenderSettings, suffix: str, channels: int = 3) -> int:
    """The largest the output file can be: .npy exactly (float32), .png at most the raw 8-bit pixels plus
    filtering bytes and headers (an incompressible image). channels: 4 where the render has an alpha."""
    pixels = settings.width * settings.height
    if suffix == ".npy":
        return pixels * channels * 4 + 128
    if suffix == ".exr":  # float32 channels, ZIP-compressed at best to nothing less: the raw size bounds it
        return pixels * channels * 4 + 65536
    return pixels * channels + settings.height + 4096


def check_disk(target: Path, needed: int) -> None:
    """Raise ResourceError when target's folder has less than needed bytes free."""
    folder = target.parent if str(target.parent) else Path(".")
    while not folder.exists() and folder != folder.parent:
        folder = folder.parent
    try:
        free = shutil.disk_usage(folder).free
    except OSError:
        return
    if needed > free:
        raise ResourceError(
            f"{target}: needs up to {_size(needed)} on disk and {folder} has {_size(free)} free; free some space or "
            "write elsewhere"
        )


__all__ = [
    "ResourceError",
    "available_memory",
    "check_disk",
    "check_resources",
    "memory_needed",
    "out_of_memory_message",
    "output_bytes",
    "refusal",
    "scene_bytes",
    "scene_counts",
]
