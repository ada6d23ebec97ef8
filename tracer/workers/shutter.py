"""A scene whose objects or camera move while the shutter is open (their poses) -> its time slices, and their renders
-> one motion-blurred image: accumulation motion blur (Haeberli and Akeley 1990; Blender's EEVEE renders its motion
steps the same way), each slice a whole render of the scene at one time, the image their mean.

Slice k of n puts every moving object and the camera at its k-th pose (the add-on's poses are at the middles of n
equal parts of the shutter); the slices weigh the same. Where n is a perfect square (16), the slices share out a
stratified grid of lcm(samples, n) strata a pixel: each slice traces lcm / n of them, a different set per pixel
(geometry/camera.py's stratum), so that every stratum is traced once, each at a time of its own (Cook, Porter and
Carpenter's time per sample): the blur costs max(samples, n)-ish samples a pixel, not n frames, and a streak is
smooth but for noise. Otherwise (n = 8) every slice traces every sample, jittered by seed + k, and the image costs n
frames: a streak is then n copies of the object. The passes
that average samples (passes.Pass.combine "mean": the Whitted terms, normal, mist, shadow) average the slices too,
and still add up to the image; those that take one sample's value (depth, position, the indices, Cryptomatte) take
the middle slice's, the one nearest the shutter's middle.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from ..scene import scene as sc
from ..scene.passes import PASSES


def steps(scene: sc.Scene) -> int:
    """The scene's time slices: its poses' count where an object or the camera has poses that differ from each
    other, else 1 (the scene renders once, as it would without poses)."""
    posed = [obj.poses for obj in scene.objects if obj.poses]
    if scene.camera.poses:
        posed.append(scene.camera.poses)
    moving = [poses for poses in posed if any(pose != poses[0] for pose in poses)]
    return len(moving[0]) if moving else 1


def time_slice(scene: sc.Scene, index: int) -> sc.Scene:
    """The scene at its index-th time over the shutter: each posed object and the camera at that pose, no poses
    left (a still scene), pixel samples jittered by seed + index."""
    objects = tuple(
        replace(obj, location=obj.poses[index][0], rotation=obj.poses[index][1], poses=()) if obj.poses else obj
        for obj in scene.objects
    )
    camera = scene.camera
    if camera.poses:
        camera = replace(camera, location=camera.poses[index][0], rotation=camera.poses[index][1], poses=())
    render = _slice_settings(scene.render, index, len(posed(scene)))
    return replace(scene, objects=objects, camera=camera, render=render)


def posed(scene: sc.Scene) -> tuple[sc.Pose, ...]:
    """The poses of the scene's first posed object (or camera): one per time slice."""
    return next((obj.poses for obj in scene.objects if obj.poses), ()) or scene.camera.poses


def shared_strata(settings: sc.RenderSettings, slices: int) -> int | None:
    """The strata a pixel's grid has where the slices share them out: lcm(samples, slices) when slices is a perfect
    square (samples always is), each slice then tracing lcm / slices of them, a perfect square too (16 samples over 16
    slices: one each; 64 over 16: four; 1 or 4 over 16: a 4 x 4 grid, one each: the blur antialiases as it goes,
    at the cost of 16 samples, no more than 16 slices of one). None where slices is not a square (8): no share."""
    if math.isqrt(slices) ** 2 != slices:
        return None
    return math.lcm(settings.samples, slices)


def _slice_settings(settings: sc.RenderSettings, index: int, slices: int) -> sc.RenderSettings:
    """Slice index's render settings: where the slices share out a grid of strata (shared_strata), strata / slices of
    each pixel's (camera.stratum: every stratum once over the slices, at a time of its own); else every sample in
    every slice, jittered by seed + index."""
    strata = shared_strata(settings, slices)
    if strata is not None:
        return replace(settings, samples=strata // slices, time_slice=(index, slices))
    return replace(settings, seed=settings.seed + index)


def still(scene: sc.Scene) -> sc.Scene:
    """The scene without its poses where steps(scene) == 1 (each object's poses all alike): every posed object and the
    camera at its one pose, samples as they were: a still scene."""
    return replace(time_slice(scene, 0), render=scene.render)


Progress = Callable[[int, int], None]
BandDone = Callable[[np.ndarray, np.ndarray], None]


def render(
    whole: Callable[[sc.Scene, Progress | None, BandDone | None], object],
    scene: sc.Scene,
    progress: Progress | None = None,
    band_done: BandDone | None = None,
):
    """The scene's motion-blurred RenderResult (steps(scene) > 1): whole(slice, progress, band_done) renders each
    time slice (Renderer.render); their mean is the image, the alpha and the averaging passes, the middle slice
    gives the others. progress(done, total) counts every slice's bands; band_done is shown the mean so far after
    each slice. The same bytes for any number of workers (each slice is)."""
    count = steps(scene)
    middle = (count - 1) // 2
    sums: dict[str, np.ndarray] = {}
    rays, seconds, touched, kept = None, 0.0, None, None
    for index in range(count):
        sliced = None
        if progress is not None:

            def sliced(done: int, bands: int, index: int = index) -> None:
                progress(index * bands + done, count * bands)

        result = whole(time_slice(scene, index), sliced, None)
        _add(sums, result)
        if rays is None:
            rays = result.rays
        else:
            rays.add(result.rays)
        seconds += result.seconds
        if result.touched is not None:
            touched = result.touched.copy() if touched is None else touched | result.touched
        if index == middle:
            kept = result
        if band_done is not None:
            band_done((sums["image"] / (index + 1)).astype(result.image.dtype), np.arange(result.image.shape[0]))
    dtype = kept.image.dtype
    mean = {name: (array / count).astype(dtype) for name, array in sums.items()}
    passes = None
    if kept.passes is not None:
        passes = {name: mean.get(name, plane) for name, plane in kept.passes.items()}
    return replace(
        kept, image=mean["image"], alpha=mean.get("alpha"), passes=passes, rays=rays, seconds=seconds, touched=touched
    )


def _add(sums: dict[str, np.ndarray], result) -> None:
    """Adds one slice's image, alpha and averaging passes to the running sums (float64)."""
    arrays = {"image": result.image, "alpha": result.alpha}
    arrays.update({name: plane for name, plane in (result.passes or {}).items() if PASSES[name].combine == "mean"})
    for name, array in arrays.items():
        if array is None:
            continue
        if name in sums:
            sums[name] += array
        else:
            sums[name] = np.array(array, dtype=np.float64)
