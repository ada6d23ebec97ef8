"""A prepared scene -> the documented tracer over arrays: every ray of a bounce at once (listings 3.1 and 3.2,
vectorized), and the bands' scheduling (pieces of rows, pixels, frames).

TraceRay's recursion becomes a loop over bounces: each bounce finds the closest hit of all live rays, adds the
background for misses and weight * local color for hits, and the rays that hit reflective surfaces continue with
their weight multiplied by r. The local colour is shading.py's (FindIntensity over all hit points, shadow rays in
shadows.py), a surface's normals and colours surfaces.py's; a scene with glass or transparency goes through
see_through.py's wavefront instead.
"""

from __future__ import annotations

import numpy as np

from ..geometry import camera as cam
from ..geometry.footprint import Footprint, Volume
from ..geometry.kernels import indices, quiet
from ..geometry.meshpicture import View
from ..geometry.rayframes import RayFrames
from . import mirrored, see_through, surfaces, whitted
from .batch import RayBatch
from .prepared import PreparedScene
from .rays import CAMERA_T_MIN, REFLECTION_T_MIN, RayCounts, tally
from .raystore import RayStore
from .recorder import NO_PASSES, NoPasses, PassRecorder

# a scene with glass or transparency traces pieces of 1 / this of the camera samples a band may hold: its wavefronts
# hold several rays per camera sample. The default scene with every material glass of alpha 0.7, 640x480 in one
# process: peak 262 MB in whole pieces, 152 MB in halves, 83 MB in quarters (the default scene: 73 MB); with a glass
# ball, CPU per band 120, 114 and 144 ms (quarters' overhead shows)
SEE_THROUGH_PIECE = 2


class TracedScene(PreparedScene):
    """A prepared scene that traces: TraceRay's bounces over arrays and the bands' scheduling."""

    # ---- TraceRay as a wavefront -------------------------------------------------------------------------------

    def trace(
        self,
        D: np.ndarray,
        counts: RayCounts,
        rows: np.ndarray | None = None,
        origins: np.ndarray | None = None,
        far: np.ndarray | None = None,
        footprint: Footprint | RayStore | None = None,
        alpha: np.ndarray | None = None,
        pixels: np.ndarray | None = None,
        frames: np.ndarray | None = None,
        recorder: PassRecorder | NoPasses = NO_PASSES,
    ) -> np.ndarray:
        """Camera rays (3, N) -> linear colors (3, N), unclamped; alpha (N,), where given (ones), is set to 0 for
        the rays that meet a holdout first, or nothing with a transparent film.

        One loop over wavefronts: each finds the closest hit of its rays (intersect), adds the background for the
        misses, shades the hits (shading.local_colors) and sends on the rays they continue with: mirror rays, and
        in a scene with glass or transparency refracted and straight ones (see_through.continuing), whose samples
        may then repeat in a wavefront (their colours added with np.add.at, in ray order).

        frames: for a scene prepared with headings, where each frame's camera rays start (K + 1,): the rays come
        frame by frame, and counts is then a list of each frame's RayCounts (K,).

        rows: the image rows (R,) that the rays are, ordered as camera.band_directions gives them, if they are;
        else pixels: the flat pixels (P,) whose samples they are, pixel by pixel, where known (either lets the
        screen rectangles cull the camera rays and their first mirror rays; in a scene with rough glass either gives
        the camera samples' global indices, which turn the glass's sample pairs: camera.glass_rotations; without
        them, the rays' order here).
        origins (3, N): where each ray starts (None: all at the camera); far (N,): where each stops (None: never),
        as camera.band_starts gives them for a clipped or orthographic camera. footprint: records which of the N
        camera rays' trees meet its volume. recorder: keeps the render passes of the N camera rays (NO_PASSES: none).

        The reason for 10 parameters: every kind of piece the tracer traces (rows of a band, flat pixels, frames of
        an animation at once, a clipped camera's starts, an edit's ray store) comes through this one loop."""
        settings = self.scene.render
        total = D.shape[1]
        glass = self.see_through
        tally(counts, "camera", total, None if frames is None else RayFrames(frames[None]))
        # without glass a camera ray that meets nothing shows the background (0 under a transparent film): every
        # pixel starts with it and the camera rays' hits overwrite theirs (no list of the misses to make); with
        # glass a sample's rays add up from 0
        if glass or settings.film_transparent:
            color = np.zeros((3, total), dtype=self.dtype)
        else:
            color = np.empty((3, total), dtype=self.dtype)
            color[...] = surfaces.background(self, D, None)
        origin = self.origin if origins is None else origins
        batch = RayBatch(np.arange(total), origin, D, left=settings.depth, reach=far)
        if glass:
            glossy, lamps = self.traced_glossy or self.rough_glass, bool(self.seen_lights or self.seen_suns)
            batch = see_through.camera_batch(batch, self.dtype, glossy, bool(self.diffuse_bounces), lamps)
            if self.rough_glass:  # each camera sample's global index: its rough glass hits' pair rotations
                known = pixels if rows is None else cam.band_pixels(settings, rows)
                batch.serial = np.arange(total) if known is None else cam.sample_serials(settings, known)
        image_pixel = None  # each camera sample's flat pixel: its world light's turn, its lights' patterns
        if (self.world_lit and not settings.adaptive_flags) or self.patterned:
            known = pixels if rows is None else cam.band_pixels(settings, rows)
            if known is None:
                raise ValueError("a scene with a world light or a light of a size traces rows or pixels it knows")
            image_pixel = np.repeat(np.asarray(known, dtype=np.int64), settings.samples)
        culling = _Culling(self, rows, pixels, frames, total)
        first = True
        while batch.size:
            t_min = CAMERA_T_MIN if first else 0.0 if self.robust else REFLECTION_T_MIN
            t, obj, part = self._intersect(batch, t_min, first, culling, frames)
            if batch.reach is not None:  # beyond the camera's clip_end: the nearest hit is, so all are
                obj[t >= batch.reach] = -1
            if self.seen_lights and not first:  # mirror rays that meet a light's front before any surface end there
                batch, t, obj, part = mirrored.meet_lights(self, color, batch, t, obj, part, t_min, recorder, footprint)
            if self.seen_suns and not first:  # mirror rays that meet nothing see the suns' discs they point into
                mirrored.see_suns(self, color, batch, obj, recorder)
            if footprint is not None:  # each ray up to its hit; a miss to its end
                end = np.where(obj >= 0, t, np.inf if batch.reach is None else batch.reach)
                footprint.record(batch.pixel, batch.origin, batch.direction, t_min, end, hit=obj)
            if glass:
                see_through.add_misses(self, color, batch, obj, first, alpha, recorder)
                hit = see_through.hold_out(self, batch, obj, first, alpha, recorder)
            else:
                whitted.add_misses(self, color, batch, obj, first, alpha, recorder)
                hit = whitted.hold_out(self, color, batch, obj, first, alpha, recorder)
            if not hit.size:
                break
            batch, t, obj, part = batch.take(hit), t.take(hit), obj.take(hit), part.take(hit)
            P, V = batch.origin + batch.direction * t, -batch.direction
            # memory: a band's peak comes in the shading below (glass keeps the directions it refracts)
            if glass:  # a straight continuation goes on from the hit: what is left of its reach
                batch = batch.with_rays(origin=None, reach=None if batch.reach is None else batch.reach - t)
            else:
                batch = batch.with_rays(origin=None, direction=None)
            hits = surfaces.hits(self, P, V, obj, part)
            if image_pixel is not None:
                hits.image_pixel = image_pixel.take(batch.pixel)
            if glass:
                see_through.add_local(self, color, hits, batch, counts, footprint, frames, recorder, first)
                rough = None  # the rough glass hits and their glass: its lights here, its rays in continuing
                if self.rough_glass:
                    rough = see_through.add_glass_light(
                        self, color, hits, batch, counts, footprint, frames, recorder, first
                    )
                batch = see_through.continuing(self, hits, batch, rough)
            else:
                reflective = whitted.add_local(self, color, hits, batch, counts, footprint, frames, recorder, first)
                batch = whitted.mirror_rays(self, hits, batch, reflective)
                if first and batch is not None and culling.culls and self.mirrors:  # some may come off a culled plane
                    culling.came_from = hits.obj.take(indices(reflective > 0.0))
            first = False
            if batch is None:
                break
            tally(counts, "reflection", batch.size, None if frames is None else RayFrames.of(batch.pixel, frames))
        return color

    def _intersect(
        self, batch: RayBatch, t_min: float, first: bool, culling: _Culling, frames: np.ndarray | None
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """The closest hit (t, object, part) (n,) of each ray of the batch among the objects its kind of ray sees:
        camera rays (and their straight continuations) those the camera sees, the others those mirror rays see;
        the camera rays and the first mirror rays culled by their screen rectangles where culling has them."""
        query = None if frames is None else RayFrames(frames[None]) if first else RayFrames.of(batch.pixel, frames)
        views = self._camera_views(batch) if first else None
        if batch.camera is not None:
            return see_through.closest_by_kind(
                self, batch, t_min, culling.camera_sets() if first else None, query, frames, views
            )
        sets = walk = None
        if first:
            sets = culling.camera_sets()
        elif culling.came_from is not None:
            sets, walk = culling.mirror_sets(batch.pixel)
            culling.came_from = None
        hierarchy = self.camera_hierarchy if first else self.mirror_hierarchy
        return hierarchy.closest(batch.origin, batch.direction, t_min, sets, walk, query, views)

    def _camera_views(self, batch: RayBatch) -> tuple[list[View], np.ndarray] | None:
        """The camera's location as the point that each camera ray (n,) of batch lies on a line through, for the
        meshes' pictures from there: a pinhole camera's rays start at its near clip plane (Blender's cameras
        always have one), not at the point, so the rays alone do not show it. None for a lens of an aperture, an
        orthographic camera, or rays that start at the point (a shared origin names it already)."""
        camera = self.scene.camera
        if camera.type not in ("PERSP", "PANO") or camera.aperture != 0.0 or batch.origin.shape[1] == 1:
            return None
        point = View("point", tuple(float(x) for x in camera.location))
        return [point], np.zeros(batch.size, dtype=np.int64)

    # ---- the bands' scheduling: pieces of camera samples, rows, pixels ------------------------------------------

    def _piece_samples(self, max_samples: int | None) -> int | None:
        """The camera samples a piece may hold: max_samples, or 1 / SEE_THROUGH_PIECE of it where the scene has
        glass or transparency (a see-through wavefront holds a mirror, a refracted and a straight ray per hit)."""
        if max_samples is None or not self.see_through:
            return max_samples
        return max(1, max_samples // SEE_THROUGH_PIECE)

    def render_rows(
        self,
        rows: np.ndarray,
        max_samples: int | None = None,
        volume: Volume | None = None,
        touched: np.ndarray | None = None,
        passes: dict[str, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, RayCounts]:
        """Image rows (R,) -> (R, width, 3) linear image in the scene's dtype (4 channels with alpha), and the ray
        counts.

        max_samples: trace at most this many camera samples at once (memory); a larger band goes in pieces of whole
        rows, or of a row's columns where one row is too many. Every ray is traced by the same elementwise
        operations whatever else is in its piece, so the pixels are the same bytes either way. volume, touched
        (R, width) bool: marks each pixel some of whose rays' trees meet the volume (footprint.py). passes: the
        scene's render passes' planar arrays of the whole image (recorder.plane_shape, plane_dtype), whose rows go
        in; None: no pass is traced."""
        settings = self.scene.render
        per_row = settings.width * settings.samples
        rows = np.asarray(rows)
        max_samples = self._piece_samples(max_samples)
        if not settings.passes:
            passes = None
        if settings.border is not None:
            return self._render_border_rows(rows, max_samples, volume, touched, passes)
        if max_samples is None or len(rows) * per_row <= max_samples:
            return self._render_piece(rows, None, volume, touched, passes)
        counts = RayCounts()
        image = np.empty((len(rows), settings.width, self.channels), dtype=self.dtype)
        rows_at_once = max_samples // per_row
        if rows_at_once >= 1:
            for first in range(0, len(rows), rows_at_once):
                part = slice(first, first + rows_at_once)
                piece_touched = None if touched is None else touched[part]
                image[part], piece_counts = self._render_piece(rows[part], None, volume, piece_touched, passes)
                counts.add(piece_counts)
            return image, counts
        columns_at_once = max(1, max_samples // settings.samples)
        for index, row in enumerate(rows):
            for first in range(0, settings.width, columns_at_once):
                columns = np.arange(first, min(first + columns_at_once, settings.width))
                piece_touched = None if touched is None else touched[index : index + 1, first : first + len(columns)]
                piece, piece_counts = self._render_piece(np.asarray([row]), columns, volume, piece_touched, passes)
                image[index, columns] = piece[0]
                counts.add(piece_counts)
        return image, counts

    def _render_border_rows(
        self,
        rows: np.ndarray,
        max_samples: int | None,
        volume: Volume | None,
        touched: np.ndarray | None,
        passes: dict[str, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, RayCounts]:
        """render_rows() with a render border: only the pixels inside it are traced (in pieces of whole rows of the
        border), the others are 0 (alpha 0, and every pass)."""
        settings = self.scene.render
        x0, x1, y0, y1 = cam.border_window(settings)
        image = np.zeros((len(rows), settings.width, self.channels), dtype=self.dtype)
        for plane in (passes or {}).values():
            plane[:, rows] = 0.0
        counts = RayCounts()
        inside = indices((rows >= y0) & (rows < y1))
        columns = np.arange(x0, x1)
        at_once = inside.size if max_samples is None else max(1, max_samples // (len(columns) * settings.samples))
        for first in range(0, inside.size, max(1, at_once)):
            part = inside[first : first + at_once]
            piece_touched = None if touched is None else np.zeros((len(part), len(columns)), dtype=bool)
            piece, piece_counts = self._render_piece(rows.take(part), columns, volume, piece_touched, passes)
            image[part, x0:x1] = piece
            if touched is not None:
                touched[part, x0:x1] = piece_touched
            counts.add(piece_counts)
        return image, counts

    def _render_piece(
        self,
        rows: np.ndarray,
        columns: np.ndarray | None,
        volume: Volume | None,
        touched: np.ndarray | None,
        passes: dict[str, np.ndarray] | None = None,
    ) -> tuple[np.ndarray, RayCounts]:
        """Rows (R,) and columns (C,) of the image (every column when None; else consecutive) -> (R, C, 3) and the
        ray counts; touched (R, C) is filled where a volume is given, and the passes' planes (render_rows) at those
        rows and columns."""
        settings = self.scene.render
        camera = self.scene.camera
        with quiet():  # the directions are not kept here: trace() lets them go after the first bounce
            if columns is None:
                directions = cam.cached_band_directions(camera, settings, rows, self.dtype)
            else:
                directions = cam.band_directions(camera, settings, rows, columns).astype(self.dtype)
        pixels = None
        # trace() needs them: a camera's own starts, rough glass's rotations, the world light's turns and the lights'
        # patterns
        keyed = self.rough_glass or self.world_lit or self.patterned
        if not cam.shares_origin(camera) or (columns is not None and keyed):
            pixels = cam.band_pixels(settings, rows, columns)
        # whole rows: the screen rectangles cull them
        at = (
            None
            if passes is None
            else (passes, rows, slice(None) if columns is None else slice(columns[0], columns[-1] + 1))
        )
        colors, counts, hit = self._trace_pixels(
            directions, pixels, rows if columns is None else None, volume, passes=at
        )
        width = settings.width if columns is None else len(columns)
        if touched is not None:
            touched[...] = hit.reshape(len(rows), width)
        return colors.reshape(len(rows), width, self.channels), counts

    def render_pixels(
        self, pixels: np.ndarray, max_samples: int | None = None, store: RayStore | None = None
    ) -> tuple[np.ndarray, RayCounts]:
        """Flat pixel indices j * W + i (P,) -> their linear colours (P, 3; P, 4 with alpha) in the scene's dtype,
        and the ray counts: the same bytes as those pixels of a whole image (the incremental frames' re-trace).
        store: keeps every segment of their ray trees (edits.py)."""
        settings = self.scene.render
        max_samples = self._piece_samples(max_samples)
        at_once = len(pixels) if max_samples is None else max(1, max_samples // settings.samples)
        colors = np.empty((len(pixels), self.channels), dtype=self.dtype)
        counts = RayCounts()
        for first in range(0, len(pixels), at_once):
            piece = np.asarray(pixels[first : first + at_once])
            with quiet():
                directions = cam.pixel_directions(self.scene.camera, settings, piece).astype(self.dtype)
            if store is not None:
                store.begin(piece, settings.samples)
            traced = self._trace_pixels(directions, piece, None, None, store)
            colors[first : first + at_once], piece_counts, _ = traced
            counts.add(piece_counts)
        return colors, counts

    def render_frame_pixels(
        self, frame_pixels: list[np.ndarray], max_samples: int | None = None
    ) -> list[tuple[np.ndarray, RayCounts]]:
        """For a scene prepared with headings (K,): each frame's flat pixels (P_k,), ascending -> their linear
        colours (P_k, channels) and ray counts, the same bytes as render_pixels() of the scene at that heading. The
        frames share one trace: every NumPy call of a bounce serves them all, and the still objects are prepared
        once."""
        if self.headings is None or len(frame_pixels) != len(self.headings):
            raise ValueError("render_frame_pixels needs one list of pixels per heading the scene was prepared with")
        if any(np.any(np.diff(pixels) < 0) for pixels in frame_pixels):
            raise ValueError("render_frame_pixels needs each frame's pixels in ascending order")
        settings = self.scene.render
        sizes = [len(pixels) for pixels in frame_pixels]
        pixels = np.concatenate([np.asarray(pixels, dtype=np.int64) for pixels in frame_pixels])
        starts = np.concatenate(([0], np.cumsum(sizes)))  # (K + 1,): where each frame's pixels start
        max_samples = self._piece_samples(max_samples)
        at_once = max(1, len(pixels)) if max_samples is None else max(1, max_samples // settings.samples)
        colors = np.empty((len(pixels), self.channels), dtype=self.dtype)
        counts = [RayCounts() for _ in sizes]
        for first in range(0, len(pixels), at_once):
            piece = pixels[first : first + at_once]
            with quiet():
                directions = cam.pixel_directions(self.scene.camera, settings, piece).astype(self.dtype)
            frames = np.clip(starts - first, 0, piece.size) * settings.samples
            traced = self._trace_pixels(directions, piece, None, None, None, frames, counts)
            colors[first : first + at_once] = traced[0]
        ends = starts.tolist()
        return [
            (colors[start:end], ray_counts) for start, end, ray_counts in zip(ends[:-1], ends[1:], counts, strict=True)
        ]

    def _trace_pixels(
        self,
        directions: np.ndarray,
        pixels: np.ndarray | None,
        rows: np.ndarray | None,
        volume: Volume | None,
        store: RayStore | None = None,
        frames: np.ndarray | None = None,
        frame_counts: list[RayCounts] | None = None,
        passes: tuple[dict[str, np.ndarray], np.ndarray, slice] | None = None,
    ) -> tuple[np.ndarray, RayCounts, np.ndarray | None]:
        """Camera rays (3, P * samples) of the flat pixels (P,; needed only for a camera whose rays do not all
        start at its location) -> colours (P, 3) box-filtered over each pixel's samples (P, 4 with the alpha, the
        share of samples that met a visible object, where the scene has one), the ray counts, and where a volume is
        given which pixels' trees met it (P,). frames, frame_counts: as trace() takes them (the counts returned are
        then empty). passes: (planes, rows, columns) where the pixels' render passes go (PassRecorder); None: none is
        traced."""
        settings = self.scene.render
        camera = self.scene.camera
        counts = RayCounts()
        footprint = store if store is not None else None if volume is None else Footprint(volume, directions.shape[1])
        with quiet():
            origins = far = None
            if not cam.shares_origin(camera):
                origins, far = cam.pixel_starts(camera, settings, pixels, directions)
                origins = origins.astype(self.dtype)
            alpha = np.ones(directions.shape[1], dtype=self.dtype) if self.has_alpha else None
            recorder = NO_PASSES if passes is None else PassRecorder(self, directions.shape[1], *passes)
            color = self.trace(
                directions,
                counts if frames is None else frame_counts,
                rows,
                origins,
                far,
                footprint,
                alpha,
                None if rows is not None else pixels,
                frames,
                recorder,
            )
            if far is not None:  # a panoramic camera's rays outside its lens see nothing, as Cycles' (t_max 0)
                outside = indices(far <= 0.0)
                if outside.size:
                    color[:, outside] = 0.0
                    if alpha is not None:
                        alpha[outside] = 0.0
                    recorder.holdout(outside)
        if alpha is not None:
            color = np.concatenate((color, alpha[None]))
        samples = color.reshape(color.shape[0], -1, settings.samples)
        image = samples.sum(axis=2) / settings.samples if settings.samples > 1 else samples[..., 0]
        recorder.combine(settings.samples)
        hit = None if volume is None else footprint.touched.reshape(-1, settings.samples).any(axis=1)
        return np.ascontiguousarray(image.T), counts, hit


class _Culling:
    """Which kernels the camera rays of a piece and their first mirror rays can meet, from the screen rectangles
    (the scene's, and each reflective plane's mirrored ones), where the piece is whole rows (R,) or known flat
    pixels (P,); came_from: the first mirror rays' objects, set where some come off a culled plane."""

    def __init__(
        self,
        scene: TracedScene,
        rows: np.ndarray | None,
        pixels: np.ndarray | None,
        frames: np.ndarray | None,
        total: int,
    ) -> None:
        self.scene, self.rows, self.pixels, self.total = scene, rows, pixels, total
        self.culls = rows is not None or pixels is not None
        self.runs = None if frames is None else (frames // scene.scene.render.samples).tolist()  # each frame's pixels
        self.came_from: np.ndarray | None = None

    def camera_sets(self) -> list | None:
        """The camera rays' sets for Hierarchy.closest (None: walk the hierarchy)."""
        screen = self.scene.screen
        if screen is None or not self.culls:
            return None
        if self.rows is not None:
            return screen.rays(self.rows)
        return screen.pixel_rays(self.pixels, self.runs, self.scene.camera_hierarchy.frame_of)

    def mirror_sets(self, pixel: np.ndarray) -> tuple[list | None, np.ndarray | None]:
        """The first mirror rays' sets for Hierarchy.closest: rays (n,) of camera rays pixel (n,) off objects
        came_from (n,), of the piece's camera rays -> (kernel, rays) for every kernel that the rays off a culled
        plane can meet (from the scene's mirrors), and the other rays (walked), or (None, None) where no ray comes
        off such a plane."""
        came_from, sets, culled = self.came_from, [], []
        position = None  # each camera ray's mirror ray, where it has one off the plane at hand
        for plane, rectangles in self.scene.mirrors.items():
            off_plane = indices(came_from == plane)
            if off_plane.size == 0:
                continue
            culled.append(plane)
            if position is None:
                position = np.full(self.total, -1, dtype=np.intp)
            camera_ray = pixel.take(off_plane)
            position[camera_ray] = off_plane
            if self.rows is not None:
                found = rectangles.rays(self.rows)
            else:
                found = rectangles.pixel_rays(self.pixels, self.runs, self.scene.mirror_hierarchy.frame_of)
            for kernel, camera_rays in found:
                if camera_rays is None:
                    sets.append((kernel, off_plane))
                    continue
                rays = position.take(camera_rays)
                rays = rays.take(indices(rays >= 0))
                if rays.size:
                    sets.append((kernel, rays))
            position[camera_ray] = -1
        if not culled:
            return None, None
        other = came_from != culled[0]
        for plane in culled[1:]:
            other &= came_from != plane
        return sets, indices(other)
