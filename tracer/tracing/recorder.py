"""A wavefront's hits and shading terms -> the render passes of its camera rays, then of its pixels.

trace() hands a PassRecorder what it computes anyway (the first hits' points, normals, objects and materials; the
ambient, diffuse and highlight sums of each bounce; what mirror rays and misses add), and the recorder keeps the
passes asked for in one (channels, rays) array; combine() then turns each pixel's samples into its pass values
(tracer/scene/passes.py). Nothing here runs for a render without passes."""

from __future__ import annotations

import numpy as np

from ..geometry import transforms as tf
from ..scene import passes as ps
from ..scene import scene as sc


class PassRecorder:
    """The passes of N camera rays: one row per channel, a Cryptomatte pass one row of ids (rays hitting nothing
    -1) until combine() ranks them.

    prepared: the PreparedScene (its materials' arrays, each placed object's and material row's names and pass
    indices)."""

    def __init__(self, prepared, count: int) -> None:
        self.prepared = prepared
        self.names = prepared.scene.render.passes
        self.rows: dict[str, slice] = {}
        start = 0
        for name in self.names:
            size = 1 if ps.PASSES[name].combine == "ranks" else ps.width(name)
            self.rows[name] = slice(start, start + size)
            start += size
        self.values = np.zeros((start, count), dtype=prepared.dtype)
        for name, value in (("depth", ps.FAR), ("mist", 1.0), ("cryptomatte_object", -1.0)):
            if name in self.rows:
                self.values[self.rows[name]] = value
        if "cryptomatte_material" in self.rows:
            self.values[self.rows["cryptomatte_material"]] = -1.0
        self.shading = any(name in self.rows for name in ps.SHADING)

    def _put(self, name: str, pixel: np.ndarray, value: np.ndarray | float, add: bool = False) -> None:
        if name not in self.rows:
            return
        rows = self.values[self.rows[name]]
        if add:
            rows[:, pixel] += value  # a camera ray's pixel comes once in a bounce
        else:
            rows[:, pixel] = value

    def first_hit(self, pixel: np.ndarray, P: np.ndarray, S: np.ndarray, obj: np.ndarray, material: np.ndarray) -> None:
        """The camera rays pixel (n,) met obj (n,) at P (3, n) with shading normals S (3, n) and material rows."""
        prepared = self.prepared
        if "depth" in self.rows or "mist" in self.rows:
            offset = P - prepared.origin
            if "depth" in self.rows:
                self._put("depth", pixel, (offset * prepared.view_axis).sum(axis=0))
            if "mist" in self.rows:  # Cycles' camera distance: along the view axis for an orthographic camera
                if prepared.scene.camera.type == "ORTHO":
                    distance = np.abs((offset * prepared.view_axis).sum(axis=0))
                else:
                    distance = np.sqrt((offset * offset).sum(axis=0))
                self._put("mist", pixel, _mist(distance, prepared.scene.render))
        if "normal" in self.rows:
            self._put("normal", pixel, S / np.sqrt((S * S).sum(axis=0)))
        self._put("position", pixel, P)
        if "object_index" in self.rows:
            self._put("object_index", pixel, prepared.object_pass_index.take(obj))
        if "material_index" in self.rows:
            self._put("material_index", pixel, prepared.material_pass_index.take(material))
        self._put("cryptomatte_object", pixel, obj)
        self._put("cryptomatte_material", pixel, material)

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
        if prepared.colored:
            self._put("ambient", pixel, split["ambient"] * colors * keep)
            self._put("diffuse", pixel, split["diffuse"] * colors * keep)
            self._put("specular", pixel, split["specular"] * specular_colors * keep)
        else:
            self._put("ambient", pixel, (split["ambient"] * keep) * colors)
            self._put("diffuse", pixel, (split["diffuse"] * keep) * colors)
            self._put("specular", pixel, (split["specular"] * keep) * colors)
        if prepared.emissive:
            self._put("emission", pixel, emission)
        self._put("shadow", pixel, split["shadow"])

    def reflection(self, pixel: np.ndarray, value: np.ndarray) -> None:
        """What a mirror ray's surface adds to its camera ray's pixel (already weighted)."""
        if "reflection" in self.rows:
            self._put("reflection", pixel, value, add=True)

    def environment(self, pixel: np.ndarray, value: np.ndarray) -> None:
        """The background a camera ray or (weighted) a mirror ray sees."""
        if "environment" in self.rows:
            self._put("environment", pixel, value, add=True)

    def add(self, name: str, pixel: np.ndarray, value: np.ndarray) -> None:
        """value (channels, n) added into a pass at camera rays pixel (n,) that may repeat (a see-through
        wavefront holds several rays of one camera ray: np.add.at); nothing where the pass is not asked for."""
        if name not in self.rows:
            return
        for row, add in zip(self.values[self.rows[name]], value, strict=True):
            np.add.at(row, pixel, add)

    def holdout(self, pixel: np.ndarray) -> None:
        """Camera rays that met a holdout first: nothing of them shows in any pass (depth and mist keep the
        background's values, as Cycles writes no data pass there)."""
        for name, rows in self.rows.items():
            if ps.PASSES[name].combine == "ranks" or name in ("depth", "mist"):
                continue
            self.values[rows, pixel] = 0.0

    def combine(self, samples: int) -> np.ndarray:
        """(channels, pixels) of the passes in passes.layout's order: each pixel's samples combined as its pass says
        (mean, the first sample's, or Cryptomatte's ranked ids and coverages)."""
        out = []
        for name in self.names:
            rows = self.values[self.rows[name]]
            combine = ps.PASSES[name].combine
            per_sample = rows.reshape(rows.shape[0], -1, samples)
            if combine == "ranks":
                out.append(self._ranks(name, per_sample[0]))
            elif combine == "first" or samples == 1:
                out.append(per_sample[..., 0])
            else:
                out.append(per_sample.sum(axis=2) / samples)
        return np.concatenate(out, axis=0)

    def _ranks(self, name: str, ids: np.ndarray) -> np.ndarray:
        """(P, samples) object or material rows, -1 for nothing -> (2 * ranks, P) Cryptomatte id/coverage pairs."""
        from .cryptomatte import ranks

        # rows -> distinct names (material rows may be objects: one material of two objects is one id)
        hashes, distinct = self.prepared.cryptomatte_hashes(name)
        rows = ids.astype(np.int64)
        ranked = ranks(np.where(rows >= 0, distinct.take(np.maximum(rows, 0)), -1), hashes, levels=ps.CRYPTOMATTE_RANKS)
        return ranked.T.astype(self.values.dtype)


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
