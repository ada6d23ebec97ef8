"""A wavefront's hits and shading terms -> the render passes of its pixels, written where they go.

trace() hands a PassRecorder what it computes anyway (the first hits' points, normals, objects and materials; the
ambient, diffuse and highlight sums of each bounce; what mirror rays and misses add). Each pass goes into its own
planar (channels, height, width) array (plane_shape, plane_dtype): the image's, or the workers' shared memory where
the image goes. At 1 sample per pixel a camera ray is its pixel, so every value is written once, straight into its
pixel of the plane; with more samples each pass keeps its camera rays' values (channels, rays) until combine() turns
each pixel's samples into the pass's value (tracer/scene/passes.py). Nothing here runs for a render without passes."""

from __future__ import annotations

import numpy as np

from ..geometry import transforms as tf
from ..scene import passes as ps
from ..scene import scene as sc

# What a pixel holds where nothing writes: a camera ray that meets nothing (Cycles' far depth, full mist; every other
# pass 0, and a Cryptomatte pass no rank)
_EMPTY = {"depth": ps.FAR, "mist": 1.0}


def plane_dtype(name: str, dtype: np.dtype | str) -> np.dtype:
    """The dtype a pass is kept in: the image's (dtype), Cryptomatte's float32 (its IDs are float32 bit patterns and
    its coverages k / samples, exact in float32 as in the file)."""
    return np.dtype(np.float32 if ps.PASSES[name].combine == "ranks" else dtype)


def plane_shape(name: str, height: int, width: int, levels: int) -> tuple[int, int, int]:
    """A pass's planar array: (channels, height, width), each channel a contiguous (height, width) plane; levels:
    the render's Cryptomatte levels (a Cryptomatte pass's channels)."""
    return (ps.width(name, levels), height, width)


class PassRecorder:
    """The passes of N camera rays, in pieces of whole rows or of a row's columns.

    prepared: the PreparedScene (its materials' arrays, each placed object's and material row's names and pass
    indices). planes: pass name -> (channels, height, width) arrays (plane_shape, plane_dtype) that the pixels' values
    go into: the rays' pixels (N / samples, row by row) are rows (R,) of those arrays at columns (a slice); None: the
    recorder's own arrays of one row (combine() returns them)."""

    def __init__(
        self,
        prepared,
        count: int,
        planes: dict[str, np.ndarray] | None = None,
        rows: np.ndarray | None = None,
        columns: slice = slice(None),
    ) -> None:
        self.prepared = prepared
        self.names = prepared.scene.render.passes
        self.samples = prepared.scene.render.samples
        self.levels = prepared.scene.render.cryptomatte_levels
        pixels = count // self.samples
        if planes is None:
            planes = {
                name: np.empty(plane_shape(name, 1, pixels, self.levels), plane_dtype(name, prepared.dtype))
                for name in self.names
            }
            rows = np.zeros(1, dtype=np.int64)
        self.planes, self.at = planes, (np.asarray(rows), columns)
        # pass name -> where trace()'s values go: at 1 sample the planes themselves, flattened to (channels, pixels of
        # the image), each ray at its pixel's place (self.where); with more samples (channels, rays) of its own, a
        # Cryptomatte pass (1, rays) of object or material rows (-1: nothing) until combine() ranks them
        self.rows: dict[str, np.ndarray] = {}
        self.where: np.ndarray | None = None
        # at 1 sample, the passes (their channels) still to be filled with _EMPTY: around the rays of their first
        # values, so that each pixel is written once (combine() fills those that get none)
        self.pending: dict[str, slice] = {}
        if self.samples == 1:
            for name in self.names:
                plane = planes[name]
                self.rows[name] = plane.reshape(plane.shape[0], -1)
                if ps.PASSES[name].combine == "ranks":  # the first rank at the hits; no other rank
                    plane[2:, rows, columns] = 0.0
                    self.pending[name] = slice(0, 2)
                else:
                    self.pending[name] = slice(None)
            width = next(iter(planes.values())).shape[2]
            first, stop, _ = columns.indices(width)
            self.where = (np.asarray(rows, dtype=np.int64)[:, None] * width + np.arange(first, stop)).ravel()
        else:
            for name in self.names:
                if ps.PASSES[name].combine == "ranks":
                    self.rows[name] = np.full((1, count), -1, dtype=np.int64)
                else:
                    self.rows[name] = np.full((ps.width(name), count), _EMPTY.get(name, 0.0), dtype=prepared.dtype)
        self.shading = any(name in self.rows for name in ps.SHADING)
        # the last few sets of camera rays written and where they go: the camera rays that miss, those that meet
        # something, and the rest of either (first_hit and terms write at the same rays, a miss's rest is the hits)
        self._known: list[tuple[np.ndarray, _Places]] = []
        self._rest: tuple[np.ndarray, _Places] | None = None  # the last rays' rest and where it goes

    def _place(self, pixel: np.ndarray) -> _Places:
        """Camera rays (n,) -> where they go in self.rows' arrays."""
        for known, places in self._known:
            if known is pixel:
                return places
        for known, places in self._known:
            if known.size == pixel.size and np.array_equal(known, pixel):
                return places
        places = _Places(pixel if self.where is None else self.where.take(pixel, mode="wrap"))
        self._known = [(pixel, places), *self._known[:3]]
        return places

    def _written(self, name: str, pixel: np.ndarray) -> bool:
        """Before the pass's values at pixel (n,): if it is still to be filled, its other pixels get _EMPTY and True
        is returned (pixel's own hold nothing yet)."""
        channels = self.pending.pop(name, None)
        if channels is None:
            return False
        places = self._place(pixel)
        if places.runs is None:  # scattered values, and so their other pixels: all at memory speed first
            self._fill(name, channels)
            return False
        if self._rest is None or self._rest[0] is not pixel:
            others = np.ones(self.where.size, dtype=bool)
            others[pixel] = False
            self._rest = (pixel, self._place(np.flatnonzero(others)))
        rest = self._rest[1]
        if rest.runs is None:  # scattered: every pixel at memory speed, then the values over them
            self._fill(name, channels)
            return False
        rest.put(self.rows[name][channels], _EMPTY.get(name, 0.0))
        return True

    def _fill(self, name: str, channels: slice) -> None:
        """Every pixel of the piece gets _EMPTY in those channels of the pass."""
        rows, columns = self.at
        self.planes[name][channels][:, rows, columns] = _EMPTY.get(name, 0.0)

    def _put(self, name: str, pixel: np.ndarray, value: np.ndarray | float, add: bool = False) -> None:
        """The camera rays pixel (n,) get value ((channels, n), (n,) for one channel, or one number); add: added to
        what they hold (a camera ray's pixel comes once in a bounce)."""
        rows = self.rows.get(name)
        if rows is None:
            return
        if self._written(name, pixel) and add:  # added to _EMPTY, as to a filled pixel
            add, value = False, _EMPTY.get(name, 0.0) + np.asarray(value)
        self._place(pixel).put(rows, value, add)

    def first_hit(self, pixel: np.ndarray, P: np.ndarray, S: np.ndarray, obj: np.ndarray, material: np.ndarray) -> None:
        """The camera rays pixel (n,) met obj (n,) at P (3, n) with shading normals S (3, n) and material rows."""
        prepared = self.prepared
        rows = self.rows
        if "depth" in rows or "mist" in rows:
            offset = P - prepared.origin
            axis = prepared.view_axis
            # the sums over the 3 coordinates in order, as (offset * axis).sum(axis=0) adds them
            along = None
            if "depth" in rows or prepared.scene.camera.type == "ORTHO":
                along = offset[0] * axis[0] + offset[1] * axis[1] + offset[2] * axis[2]
                self._put("depth", pixel, along)
            if "mist" in rows:  # Cycles' camera distance: along the view axis for an orthographic camera
                if prepared.scene.camera.type == "ORTHO":
                    distance = np.abs(along)
                else:
                    distance = np.sqrt(offset[0] * offset[0] + offset[1] * offset[1] + offset[2] * offset[2])
                self._put("mist", pixel, _mist(distance, prepared.scene.render))
        if "normal" in rows:
            self._put("normal", pixel, S / np.sqrt(S[0] * S[0] + S[1] * S[1] + S[2] * S[2]))
        self._put("position", pixel, P)
        if "object_index" in rows:
            self._put("object_index", pixel, prepared.object_pass_index.take(obj))
        if "material_index" in rows:
            self._put("material_index", pixel, prepared.material_pass_index.take(material))
        for name, of in (("cryptomatte_object", obj), ("cryptomatte_material", material)):
            if name not in rows:
                continue
            self._written(name, pixel)
            places = self._place(pixel)
            if self.where is None:  # the rows, ranked in combine()
                places.put(rows[name], of)
            else:  # one sample: the one rank of the pixel's ID, all of its coverage
                places.put(rows[name][0:1], _ids(prepared, name).take(of))
                places.put(rows[name][1:2], 1.0)

    def terms(
        self,
        pixel: np.ndarray,
        split: dict[str, np.ndarray],
        material: np.ndarray,
        reflective: np.ndarray,
        surface: tuple[np.ndarray, np.ndarray | None, np.ndarray | None] | None = None,
    ) -> None:
        """A first hit's shading split term by term (find_intensity's split: ambient, diffuse, specular sums and
        the lights reached), each times the material's colour and (1 - reflectivity) as the image's local term.
        surface: the hits' colours, specular colours and emission as the image used them (PreparedScene.
        surface_colors: a texture's samples); None: the material rows'."""
        if not self.shading:
            return
        prepared = self.prepared
        keep = 1.0 - reflective
        if surface is None:
            colors = prepared.colors.take(material, axis=1)
            specular_colors = prepared.specular_colors.take(material, axis=1) if prepared.colored else None
            emission = prepared.emission.take(material, axis=1) if prepared.emissive else None
        else:
            colors, specular_colors, emission = surface
        for name in ("ambient", "diffuse", "specular"):  # each product in the order of the image's local term
            if name not in self.rows:
                continue
            if prepared.colored:  # term (3, n) x colour x (1 - r); a glossy lobe's light is a highlight too
                value = split[name] * (specular_colors if name == "specular" else colors) * keep
                if name == "specular" and "glossy" in split:
                    value = value + split["glossy"]
                self._put(name, pixel, value)
            else:  # (term x (1 - r)) x colour
                self._put(name, pixel, (split[name] * keep) * colors)
        if prepared.emissive:
            self._put("emission", pixel, emission)
        self._put("shadow", pixel, split["shadow"])

    def first_seen(
        self, pixel: np.ndarray, pending: np.ndarray, alpha: np.ndarray, P: np.ndarray, S: np.ndarray, obj, material
    ) -> None:
        """first_hit() for the hits (n,) of a see-through wavefront whose camera rays' data passes are still
        pending (n,) and whose surface's alpha (n,) reaches sc.PASS_ALPHA_THRESHOLD: the first such surface a camera
        ray meets straight on."""
        shown = pending & (alpha >= sc.PASS_ALPHA_THRESHOLD)
        if shown.all():
            self.first_hit(pixel, P, S, obj, material)
        elif shown.any():
            rows = shown.nonzero()[0]
            self.first_hit(
                pixel.take(rows), P.take(rows, axis=1), S.take(rows, axis=1), obj.take(rows), material.take(rows)
            )

    def camera_misses(self, obj: np.ndarray, color: np.ndarray) -> None:
        """The Environment pass of the camera rays (N,) that hit nothing (obj < 0): the background their pixels
        start with in color (3, N)."""
        missed = (obj < 0).nonzero()[0]
        self.environment(missed, color.take(missed, axis=1))

    def tagged(self, name: str, tag: np.ndarray, rows: np.ndarray, pixel: np.ndarray, value: np.ndarray) -> None:
        """What rays rows (n,) of a see-through wavefront add (3, n) at camera rays pixel (n,) into their passes, by
        the wavefront's tags (N,): under a refracted or straight ray (tag 2) the Transmission pass, else name
        (reflection for surfaces, environment for misses)."""
        mine = tag.take(rows) == 2
        if mine.any():
            self.add("transmission", pixel[mine], value[:, mine])
        if not mine.all():
            self.add(name, pixel[~mine], value[:, ~mine])

    def reflection(self, pixel: np.ndarray, value: np.ndarray) -> None:
        """What a mirror ray's surface adds to its camera ray's pixel (already weighted)."""
        self._put("reflection", pixel, value, add=True)

    def environment(self, pixel: np.ndarray, value: np.ndarray) -> None:
        """The background a camera ray or (weighted) a mirror ray sees."""
        self._put("environment", pixel, value, add=True)

    def add(self, name: str, pixel: np.ndarray, value: np.ndarray) -> None:
        """value (channels, n) added into a pass at camera rays pixel (n,) that may repeat (a see-through
        wavefront holds several rays of one camera ray: np.add.at); nothing where the pass is not asked for."""
        rows = self.rows.get(name)
        if rows is None:
            return
        channels = self.pending.pop(name, None)
        if channels is not None:
            self._fill(name, channels)
        target = pixel if self.where is None else self.where.take(pixel, mode="wrap")
        for row, add in zip(rows, value, strict=True):
            np.add.at(row, target, add)

    def holdout(self, pixel: np.ndarray) -> None:
        """Camera rays that met a holdout first: nothing of them shows in any pass (depth and mist keep the
        background's values, as Cycles writes no data pass there)."""
        if not pixel.size:
            return
        places = self._place(pixel)
        for name, rows in self.rows.items():
            if ps.PASSES[name].combine != "ranks" and name not in ("depth", "mist"):
                places.put(rows, 0.0)

    def combine(self, samples: int) -> dict[str, np.ndarray]:
        """Each pixel's samples combined as its pass says (mean, the centre sample's, or Cryptomatte's ranked ids and
        coverages) into the planes; at 1 sample they are there already (a pass nothing wrote: _EMPTY). Returns the
        planes."""
        for name, channels in self.pending.items():
            self._fill(name, channels)
        self.pending = {}
        if samples > 1:
            rows, columns = self.at
            for name in self.names:
                values = self.rows[name]
                plane = self.planes[name]
                combine = ps.PASSES[name].combine
                if combine == "ranks":
                    out = self._ranks(name, values.reshape(-1, samples)).T
                elif combine == "centre":
                    out = values[:, ps.centre_sample(samples) :: samples]
                else:
                    out = _sample_sum(values, samples) / samples
                plane[:, rows, columns] = out.reshape(plane.shape[0], len(rows), -1)
        return self.planes

    def _ranks(self, name: str, ids: np.ndarray) -> np.ndarray:
        """(P, samples) object or material rows, -1 for nothing -> (P, 2 * ranks) Cryptomatte id/coverage pairs."""
        from .cryptomatte import ranks

        hashes, distinct = _hashes(self.prepared, name)
        return ranks(np.where(ids >= 0, distinct.take(np.maximum(ids, 0)), -1), hashes, levels=self.levels)


# Values go into a row by stretches (a slice each) where their places run in stretches of this many on average
# (the camera rays that meet something, row after row of a band): a slice costs about 0.5 us and copies at memory
# speed, an index assignment about 2 ns a value (NumPy 1.26 here; 77,000 values in stretches of 256: the same time,
# of 512: 0.09 ms against 0.14, of 1024: 0.06)
RUN_LENGTH = 512


class _Places:
    """Where n values go in a flat row: their indices (n,), and their stretches of consecutive places where these
    are long (RUN_LENGTH)."""

    def __init__(self, target: np.ndarray) -> None:
        self.target = target
        self.runs: list[tuple[int, int, int, int]] | None = None  # (first place, end, first value, end)
        if target.size >= RUN_LENGTH:
            breaks = np.flatnonzero(np.diff(target) != 1) + 1
            if breaks.size < target.size // RUN_LENGTH:
                starts = np.concatenate(([0], breaks))
                ends = np.concatenate((breaks, [target.size]))
                firsts = target.take(starts)
                self.runs = list(
                    zip(firsts.tolist(), (firsts + ends - starts).tolist(), starts.tolist(), ends.tolist(), strict=True)
                )

    def put(self, rows: np.ndarray, values: np.ndarray | float, add: bool = False) -> None:
        """rows (channels, places)[:, places] = values ((channels, n); (n,) or one number for every channel); add:
        rows[:, places] + values."""
        dimensions = np.ndim(values)
        if self.runs is None:  # a row at a time: NumPy assigns to one dimension's indices fastest
            target = self.target
            for k, row in enumerate(rows):
                value = values[k] if dimensions == 2 else values
                row[target] = row.take(target) + value if add else value
        elif rows.shape[0] == 1:  # one channel: a one-dimensional slice costs half a two-dimensional one's
            self.put_row(rows[0], values[0] if dimensions == 2 else values, add)
        elif dimensions == 0:
            for first, end, _, _ in self.runs:
                if add:
                    rows[:, first:end] += values
                else:
                    rows[:, first:end] = values
        else:
            for first, end, start, stop in self.runs:
                if add:
                    rows[:, first:end] += values[..., start:stop]
                else:
                    rows[:, first:end] = values[..., start:stop]

    def put_row(self, row: np.ndarray, values: np.ndarray | float, add: bool) -> None:
        """put() of one channel by stretches: row (places,)[places] = values ((n,) or one number)."""
        if np.ndim(values) == 0:
            for first, end, _, _ in self.runs:
                if add:
                    row[first:end] += values
                else:
                    row[first:end] = values
        else:
            for first, end, start, stop in self.runs:
                if add:
                    row[first:end] += values[start:stop]
                else:
                    row[first:end] = values[start:stop]


def _sample_sum(values: np.ndarray, samples: int) -> np.ndarray:
    """(channels, pixels * samples) -> each pixel's samples summed (channels, pixels), the same bits as NumPy's sum
    over them: below 8 samples NumPy adds them in order (its pairwise sum starts at 8), which the column by column
    adds here do without its slow reduction over a short axis (at 4 samples a band's 31 ms -> a few); from 8 on,
    NumPy's own sum."""
    if samples >= 8:
        return values.reshape(values.shape[0], -1, samples).sum(axis=2)
    total = values[:, 0::samples] + values[:, 1::samples]
    for sample in range(2, samples):
        total += values[:, sample::samples]
    return total


def _hashes(prepared, name: str) -> tuple[np.ndarray, np.ndarray]:
    """prepared.cryptomatte_hashes(name), kept on the prepared scene: the distinct names' float32 IDs (K,) and each
    object's or material row's index into them."""
    kept = prepared.__dict__.setdefault("_cryptomatte", {})
    if name not in kept:
        kept[name] = prepared.cryptomatte_hashes(name)
    return kept[name]


def _ids(prepared, name: str) -> np.ndarray:
    """Each object's or material row's Cryptomatte ID (float32)."""
    hashes, distinct = _hashes(prepared, name)
    return hashes.take(distinct)


def _mist(distance: np.ndarray, settings: sc.RenderSettings) -> np.ndarray:
    """Blender's mist: 0 at mist_start, 1 at mist_start + mist_depth, shaped by the falloff."""
    depth = settings.mist_depth if settings.mist_depth > 0.0 else 1e-9
    mist = np.clip((distance - settings.mist_start) / depth, 0.0, 1.0)
    if settings.mist_falloff == "QUADRATIC":
        return mist * mist
    if settings.mist_falloff == "INVERSE_QUADRATIC":
        return np.sqrt(mist)
    return mist


def view_axis(camera: sc.Camera, dtype: np.dtype) -> np.ndarray:
    """The camera's unit view direction (its local -Z in world space) (3, 1)."""
    r = tf.euler_xyz_matrix(camera.rotation)
    return np.asarray([[-r[0][2]], [-r[1][2]], [-r[2][2]]], dtype=dtype)


class NoPasses:
    """The recorder of a trace that keeps no pass (PassRecorder's calls, each doing nothing): the stages call it
    as they call a PassRecorder, with no guard at each call, and what only a pass reads is computed inside
    PassRecorder's methods."""

    shading = False  # no shading pass: find_intensity is not asked to split its terms

    def first_hit(self, *_: object) -> None:
        pass

    def first_seen(self, *_: object) -> None:
        pass

    def camera_misses(self, *_: object) -> None:
        pass

    def tagged(self, *_: object) -> None:
        pass

    def terms(self, *_: object) -> None:
        pass

    def reflection(self, *_: object) -> None:
        pass

    def environment(self, *_: object) -> None:
        pass

    def add(self, *_: object) -> None:
        pass

    def holdout(self, *_: object) -> None:
        pass

    def combine(self, samples: int) -> dict[str, np.ndarray]:
        return {}


NO_PASSES = NoPasses()
