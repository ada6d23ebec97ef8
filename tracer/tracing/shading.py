"""A prepared scene's hit points -> their intensity by the documented model: listing 3.2's FindIntensity over arrays
(ambient, diffuse and highlight terms per light, lights of a size by their samples, spots, falloff, coloured
surfaces), split term by term for the render passes where asked. The beauty image and the passes both read these
terms (one place); which lights reach a point is shadows.py's."""

from __future__ import annotations

from dataclasses import replace
from typing import NamedTuple

import numpy as np

from ..geometry import camera as cam
from ..geometry import lightsamples
from ..geometry.footprint import Footprint
from ..geometry.kernels import dot, indices, take
from . import glossy, shadows, surfaces
from .batch import Hits
from .lights import DirectedLight, LightTerm, WorldSample, directed
from .prepared import PreparedScene
from .rays import RayCounts


def local_colors(
    scene: PreparedScene,
    hits: Hits,
    pixel: np.ndarray,
    counts: RayCounts,
    footprint: Footprint | None,
    frames: np.ndarray | None,
    split: dict[str, np.ndarray] | None,
) -> tuple[np.ndarray, np.ndarray]:
    """Listing 3.1's local colour of the hits (n,) of camera samples pixel (n,): (1 - r) times the lit colour (the
    intensity times the colour; coloured, diffuse times the colour plus highlight times the specular colour), plus
    emission -> the colours (3, n) and the reflectivities r (n,). frames, counts, footprint, split: as
    find_intensity takes them (frames: where each frame's samples start)."""
    specular = scene.specular.take(hits.material)
    points = None if frames is None else np.searchsorted(pixel, frames)  # where each frame's points start
    lobes = glossy.lobes_at(scene, hits) if scene.any_glossy else None
    intensity = find_intensity(scene, hits, specular, pixel, counts, footprint, points, split, lobes)
    reflective = scene.reflective.take(hits.material)
    if scene.colored:
        diffuse, highlight = intensity
        local = (diffuse * hits.colors + highlight * hits.specular_colors) * (1.0 - reflective)
    else:
        local = (intensity * (1.0 - reflective)) * hits.colors
    if scene.emissive:
        local = local + hits.emission
    if lobes is not None:  # the lights through the glossy lobes, beside the documented local colour
        shine = np.zeros_like(local)
        shine[:, lobes.rows] = lobes.light
        local = local + shine
        if split is not None:
            split["glossy"] = shine
    return local, reflective


def find_intensity(
    scene: PreparedScene,
    hits: Hits,
    specular: np.ndarray,
    samples: np.ndarray,
    counts: RayCounts,
    footprint: Footprint | None = None,
    frames: np.ndarray | None = None,
    split: dict[str, np.ndarray] | None = None,
    lobes: glossy.Lobes | None = None,
) -> np.ndarray | tuple[np.ndarray, np.ndarray]:
    """Listing 3.2 for every hit at once (its points P, shading normals S and V (3, n)), specular exponents (n,) ->
    intensity (n,); where lights or materials have colours (scene.colored) the (ambient + diffuse, specular)
    intensities (3, n) each instead. The shadow rays start off the surfaces' own normals (robust numerics).

    samples: the camera samples (n,) the points belong to, whose shadow rays the footprint records. frames: where
    each frame's points start (K + 1,), for a scene prepared with headings (counts is then a list of each frame's).

    The shadow rays of all lights go through the hierarchy in one batch; the terms are then added light by light in
    the listing's order.

    split: a dict to fill with the same sums term by term for the passes: "ambient", "diffuse", "specular" ((n,)
    each, (3, n) where coloured) and "shadow" (n,), the share of the lights (not ambient) that reach each point
    (face it and are not blocked); the intensity returned is the same bytes either way.

    lobes: the glossy hits' lobes (glossy.lobes_at), whose light (3, k) is set to what the lights (not ambient, not
    the world's directions) add through them, shadowed as the diffuse terms are (the scene is then coloured).
    The reason for 9 parameters: the hits, the bookkeeping every stage carries (samples, counts, footprint, frames), and
    the three things a caller may ask for beside the intensity (the exponents, the split, the glossy lobes)."""
    P, N = hits.P, hits.S
    count = P.shape[1]
    length_n = np.sqrt(dot(N, N))
    glass = isinstance(lobes, GlassLights)
    terms = _light_terms(scene, hits, specular, length_n, samples, both_sides=glass)
    own = [term for term in terms if term is not None]
    normals = N if hits.geometric is None else hits.geometric
    lit = shadows.reached(scene, own, P, normals, hits.surface, counts, footprint, samples, frames)
    throughs = None  # each light's share that passes partly transparent surfaces (alpha < 1)
    if scene.shadow_alpha:
        throughs = shadows.passing(scene, own, lit, P, normals, counts, hits.surface, frames)
        lit = [through > 0.0 for through in throughs]
    if split is not None:
        split["shadow"] = _shadow_share(scene, own, lit, throughs, count)
    settings = scene.scene.render
    exponent = specular * settings.coef if settings.model == "blinn-phong" else specular
    lights = scene.lights
    if scene.patterned:
        lights, terms, lit, throughs = _merged(lights, terms, lit, throughs)
    if glass:
        lobes.reflected, lobes.transmitted = _glass_light(scene, lights, terms, lit, throughs, lobes.glass)
    elif lobes is not None:
        lobes.light = _glossy_light(scene, lights, terms, lit, throughs, lobes, samples)
    if scene.colored:
        return _colored(scene, lights, terms, lit, length_n, exponent, split, throughs)
    return _plain(scene, lights, terms, lit, length_n, exponent, split, throughs)


def _light_terms(
    scene: PreparedScene,
    hits: Hits,
    specular: np.ndarray,
    length_n: np.ndarray,
    samples: np.ndarray,
    both_sides: bool = False,
) -> list[LightTerm | None]:
    """Each light's LightTerm at the hits' points P with shading normals S and V (3, n), in the scene's order (None:
    ambient). samples: the camera samples (n,) the points belong to: a world direction or a sample of a light of a
    size shared out among a pixel's samples (lightsamples.world_share) counts at the points of its samples alone, g
    times (N.L g, or its attenuation factor times g), and a light of a size's sample at the pixels of its pattern
    alone (lightsamples.pixel_pattern), patterns times; a world direction is turned by its point's pixel's turn
    (camera.world_turns). both_sides: rough glass's points, which the lights reach from either side of the surface
    (through its microfacets) and the world's directions not at all (its rays see the background): each light's
    diffuse gate is N.L != 0, the world's none."""
    P, N, V = hits.P, hits.S, hits.V
    settings = scene.scene.render
    keys: dict[int, np.ndarray] = {}  # each share's key mod g at the points
    points = _Points(P, N, V, specular > 0.0, length_n, np.sqrt(dot(V, V)), [])
    terms: list[LightTerm | None] = []
    shared: dict[int, tuple] = {}  # what the samples of one light share at each point (a disk's, a hemisphere's axes)
    factors: dict[int, tuple] = {}  # a world light's weight in each point's frame, and its irradiance over their mean
    groups: dict[tuple[int, int], LightTerm] = {}  # a light of a size's patterns' term at each place (_pattern_term)
    for light in scene.lights:
        if light.ambient:
            terms.append(None)
            continue
        if not light.highlight:  # the world's light, a direction turned by each point's pixel: a diffuse term only
            share = lightsamples.world_share(settings, light.count)
            if light.source not in shared:
                turn = None
                if not settings.adaptive_flags:
                    turn = cam.world_turns(settings, hits.image_pixel, samples % settings.samples, share)
                shared[light.source] = light.basis(N, turn)
            L = light.vector_at(P, N, shared)
            NL = dot(N, L)
            length_l = np.sqrt(dot(L, L))
            diffuse_gate = NL > 0.0 if not both_sides else np.zeros(NL.shape, dtype=bool)
            if share > 1:
                diffuse_gate &= _taken(keys, settings, samples, share, light)
                NL = NL * share
            needed = indices(diffuse_gate)
            color = _world_color(scene, light, L, needed, shared, factors) if light.world else light.color
            terms.append(LightTerm(L, NL, length_l, diffuse_gate, np.zeros_like(diffuse_gate), NL, needed, None, color))
            continue
        share = lightsamples.world_share(settings, light.count // light.patterns)
        if light.patterns > 1 and light.disk is None:
            # the samples of the patterns' same place (one a pixel): one term, toward each point's pattern's sample
            group = (light.source, light.index // light.patterns)
            if group not in groups:
                groups[group] = _pattern_term(scene, light, points, shared, keys, hits.image_pixel)
            term = groups[group]
        else:
            term = _highlight_term(scene, light, points, shared)
        if both_sides:  # off the glass (Blender's Glossy visibility of the light) or through it (Transmission)
            through_glass = light.adds_glossy or light.adds_transmission
            term = term._replace(diffuse_gate=(term.NL != 0.0) & through_glass, gate=term.gate & through_glass)
        if share > 1 or light.patterns > 1:
            # a sample of a light of a size, taken by the pixels of its pattern and shared out among their samples as
            # the world's directions are: patterns times g times its terms
            taken = _taken(keys, settings, samples, share, light, hits.image_pixel)
            boost = _boost(settings, light)
            term = term._replace(
                diffuse_gate=term.diffuse_gate & taken,
                gate=term.gate & taken,
                factor=boost if term.factor is None else term.factor * boost,
            )
        diffuse_gate, gate, factor = term.diffuse_gate, term.gate, term.factor
        reaches = diffuse_gate | gate
        if not both_sides and not (light.adds_diffuse and light.adds_glossy):  # the light's ray visibility: a term off
            if not light.adds_glossy:  # no highlight, nothing through the glossy lobes
                gate = np.zeros_like(gate)
                reaches = diffuse_gate
            if not light.adds_diffuse:  # no diffuse term (the lobes' light still wants the shadow ray where N.L > 0)
                diffuse_gate = np.zeros_like(diffuse_gate)
                reaches = reaches if light.adds_glossy else gate
        needed = indices(reaches & (factor > 0.0) if light.attenuated else reaches)
        terms.append(term._replace(diffuse_gate=diffuse_gate, gate=gate, needed=needed))
    return terms


class _Points(NamedTuple):
    """The shaded points' numbers every light's term reads: P, N, V (3, n), whether each is shiny, |N| and |V| (n,),
    and V / |V| (made once, by the first light that asks)."""

    P: np.ndarray
    N: np.ndarray
    V: np.ndarray
    shiny: np.ndarray
    length_n: np.ndarray
    length_v: np.ndarray
    toward_eye: list  # [V / |V|] once a light's half vector has asked for it, [] before


def _highlight_term(scene: PreparedScene, light: DirectedLight, points: _Points, shared: dict[int, tuple]) -> LightTerm:
    """A light with a highlight (not the world's) at points: L toward it, N.L, |L|, where its diffuse term and its
    highlight may count, the highlight's cosine (listing 3.2, Phong's or Blinn-Phong's) and its attenuation; no
    shadow ray yet (needed empty)."""
    settings = scene.scene.render
    P, N, V = points.P, points.N, points.V
    L = light.vector_at(P, N, shared)  # a directional L broadcasts
    NL = dot(N, L)
    length_l = np.sqrt(dot(L, L))
    gate = points.shiny.copy()
    if settings.gate_specular:
        gate &= NL > 0.0
    if settings.model == "phong":
        k = 2.0 * dot(N, L)
        R = N * k - L
        RV = dot(R, V)
        gate &= RV > 0.0
        cosine = RV / (np.sqrt(dot(R, R)) * points.length_v)
    else:
        if not points.toward_eye:
            points.toward_eye.append(V / points.length_v)
        H = L / length_l + points.toward_eye[0]
        HN = dot(H, N)
        gate &= HN > 0.0
        cosine = HN / (np.sqrt(dot(H, H)) * points.length_n)
    # a shadow ray only where this light could add something: the result is the listing's, with fewer rays
    factor = light.attenuation(L, length_l)
    return LightTerm(L, NL, length_l, NL > 0.0, gate, cosine, np.zeros(0, dtype=np.int64), factor, light.color)


def _pattern_term(
    scene: PreparedScene,
    light: DirectedLight,
    points: _Points,
    shared: dict[int, tuple],
    keys: dict[int, np.ndarray],
    pixels: np.ndarray,
) -> LightTerm:
    """The term of a light of a size's samples at one place of its patterns (lightsamples.patterned_grid: entries
    j PATTERNS + r, r = 0..3), each point toward its own pixel's pattern's sample: a pixel takes one pattern, so the
    four samples' terms are this one's at their pixels (the same operations on the same numbers), worked out once."""
    toward = take(light.places, _pixel_patterns(keys, scene.scene.render, pixels))
    return _highlight_term(scene, replace(light, vector=toward), points, shared)


def _merged(
    lights: list, terms: list[LightTerm | None], lit: list[np.ndarray], throughs: list[np.ndarray] | None
) -> tuple[list, list[LightTerm | None], list[np.ndarray], list[np.ndarray] | None]:
    """The lights, their terms, where their shadow rays reached and what passed, with a light of a size's samples
    at one place of its patterns as one (their terms share _pattern_term's numbers; each pixel takes one of them):
    their gates, reached points and passing shares together. The sums then add each point's sample where the
    listing's order has it, once instead of once a pattern."""
    out_lights: list = []
    out_terms: list[LightTerm | None] = []
    out_lit: list[np.ndarray] = []
    out_throughs: list = []
    reached = iter(lit)
    passing = None if throughs is None else iter(throughs)
    previous = None
    for light, term in zip(lights, terms, strict=True):
        if term is None:
            out_lights.append(light)
            out_terms.append(None)
            previous = None
            continue
        light_lit, through = next(reached), None if passing is None else next(passing)
        if previous is not None and term.NL is previous.NL:  # the same place of the next pattern
            last = out_terms[-1]
            out_terms[-1] = last._replace(
                diffuse_gate=last.diffuse_gate | term.diffuse_gate, gate=last.gate | term.gate
            )
            out_lit[-1] = out_lit[-1] | light_lit
            if through is not None:
                out_throughs[-1] = out_throughs[-1] + through  # 0 where the pattern is another's
        else:
            out_lights.append(light)
            out_terms.append(term)
            out_lit.append(light_lit)
            out_throughs.append(through)
        previous = term
    return out_lights, out_terms, out_lit, None if throughs is None else out_throughs


def _taken(
    keys: dict[int, np.ndarray],
    settings,
    samples: np.ndarray,
    share: int,
    light: DirectedLight,
    pixels: np.ndarray | None = None,
) -> np.ndarray:
    """Whether each point's camera sample (samples (n,)) takes this sample of its light, shared out among a pixel's
    samples g = share at a time (lightsamples.world_share): its sharing key mod g is the sample's index (within its
    pattern) mod g; and for a light of patterns, whether the point's pixel (pixels (n,)) takes the sample's pattern
    (lightsamples.pixel_pattern). The keys mod g (and the pixels' patterns, under -1) are kept in keys for the other
    lights."""
    taken = None
    if share > 1:
        if share not in keys:
            keys[share] = lightsamples.sharing_key(settings, samples % settings.samples) % share
        taken = keys[share] == (light.index // light.patterns) % share
    if light.patterns > 1:
        mine = _pixel_patterns(keys, settings, pixels) == light.index % light.patterns
        taken = mine if taken is None else taken & mine
    return taken


def _pixel_patterns(keys: dict[int, np.ndarray], settings, pixels: np.ndarray) -> np.ndarray:
    """The pattern (n,) each point's pixel takes of a light of a size (lightsamples.pixel_pattern), kept in keys
    under -1 for the other lights."""
    if -1 not in keys:
        keys[-1] = lightsamples.pixel_pattern(settings.width, pixels)
    return keys[-1]


def _boost(settings, light: DirectedLight) -> int:
    """How many times a sample of a light of a size (or a world direction) counts where it is taken: its
    pattern's share among the pixel's samples (lightsamples.world_share g) times the light's patterns."""
    return lightsamples.world_share(settings, light.count // light.patterns) * light.patterns


def _world_color(
    scene: PreparedScene,
    light: WorldSample,
    L: np.ndarray,
    needed: np.ndarray,
    shared: dict[int, tuple],
    factors: dict[int, tuple],
) -> np.ndarray:
    """A world direction's colour (3, n) at the points needed (k,) (0 elsewhere: its term counts nowhere else): the
    background's radiance along L (3, n), or under an image background _world_radiance, times the light's colour."""
    color = np.zeros((3, L.shape[1]), dtype=scene.dtype)
    if needed.size:
        if scene.world_lighting is None:
            radiance = surfaces.background(scene, L, needed)
        else:  # under a picture: the irradiance, shared out by a smooth weight over the directions
            radiance = _world_radiance(scene, light, shared, factors, needed)
        color[:, needed] = radiance * light.color
    return color


def _world_radiance(
    scene: PreparedScene, light: WorldSample, shared: dict[int, tuple], factors: dict[int, tuple], needed: np.ndarray
) -> np.ndarray:
    """A world light's radiance (3, k) float64 along its direction at the points needed under an image background
    (world_light.lighting): its weight there times the irradiance at the point's normal over 2 / count times the
    sum of z weight over all the light's directions (0 where that is 0). The weight is a quadratic in the direction,
    c + beta . x + x^T B x in the point's turned frame (x the direction's local coordinates), so that sum is a few
    products with the directions' moments; kept in factors for the light's other directions. Its directions that
    reach a point then add up to the irradiance there, exactly in the open; those an object hides take their weight's
    share of it (the reference's world_light_sample sums the same polynomial direction by direction)."""
    lighting = scene.world_lighting
    if light.source not in factors:
        frame = shared[light.source]
        along = [sum(lighting.quadratic[:, :, r, None] * u[r] for r in range(3)) for u in frame]  # A u: (3, 3, n)
        bilinear = {(p, q): (frame[p][None] * along[q]).sum(axis=1) for p in range(3) for q in range(p, 3)}
        linear = [(lighting.linear[:, :, None] * u[None]).sum(axis=1) for u in frame]  # b . u: (3, n)
        directions = lightsamples.hemisphere_directions(light.count)
        weights = [2.0 / len(directions) * local[2] for local in directions]
        mean = lighting.constant[:, None] * sum(weights)
        for p in range(3):
            mean = mean + linear[p] * sum(w * local[p] for w, local in zip(weights, directions, strict=True))
            for q in range(p, 3):
                moment = sum(w * local[p] * local[q] for w, local in zip(weights, directions, strict=True))
                mean = mean + bilinear[p, q] * (moment if p == q else 2.0 * moment)
        at_normal = surfaces.environment(lighting.irradiance, frame[2])
        factor = np.divide(at_normal, mean, out=np.zeros_like(at_normal), where=mean > 0.0)
        factors[light.source] = (bilinear, linear, factor)
    bilinear, linear, factor = factors[light.source]
    x = light.local
    weight = lighting.constant[:, None] + sum(take(linear[p], needed) * x[p] for p in range(3))
    for (p, q), value in bilinear.items():
        weight = weight + take(value, needed) * (x[p] * x[q] if p == q else 2.0 * x[p] * x[q])
    return weight * take(factor, needed)


def _glossy_light(
    scene: PreparedScene,
    lights: list,
    terms: list[LightTerm | None],
    lit: list[np.ndarray],
    throughs: list[np.ndarray] | None,
    lobes: glossy.Lobes,
    samples: np.ndarray,
) -> np.ndarray:
    """The lights' sum through the traced glossy lobes (3, k): each light's intensity, attenuation, colour and share
    that passes (glossy.light_factor per unit of intensity), where its shadow ray reached the point; the background
    through the lobes of the world alone (glossy.environment, its pairs shared out among a pixel's camera samples:
    samples (n,), each point's)."""
    rows = lobes.rows
    total = np.zeros((3, rows.size), dtype=np.float64)
    traced = lobes.traced
    if not traced.all():  # lobes of the world alone: the background along their samples
        world = indices(~traced)
        settings = scene.scene.render
        keys = lightsamples.sharing_key(settings, samples.take(rows.take(world)) % settings.samples)
        total[:, world] = glossy.environment(scene, lobes.take(world), np.asarray(keys, dtype=np.int64))
    for light, term, light_lit, through in _glossy_lights(lights, terms, lit, throughs):
        light_lit = light_lit.take(rows)
        through = None if through is None else through.take(rows)
        L = term.L if term.L.shape[1] == 1 else take(term.L, rows)
        value = light.intensity * glossy.light_factor(lobes, L)
        if term.factor is not None:
            value = value * (term.factor if np.ndim(term.factor) == 0 else _columns(term.factor, rows))
        if through is not None:
            value = value * through
        color = term.color if term.color.shape[-1] == 1 else take(term.color, rows)
        total = np.where(light_lit & traced, total + value * color, total)
    return total.astype(scene.dtype, copy=False)


class GlassLights:
    """Rough glass hits as find_intensity takes them in place of glossy lobes: the glass (glossy.glass_at), and what
    the lights add through its microfacets, reflected and refracted (3, k) each (find_intensity sets them)."""

    def __init__(self, glass: glossy.Glass) -> None:
        self.glass = glass
        self.reflected: np.ndarray | None = None
        self.transmitted: np.ndarray | None = None


def glass_light(
    scene: PreparedScene,
    hits: Hits,
    glass: glossy.Glass,
    samples: np.ndarray,
    counts: RayCounts,
    footprint: Footprint | None,
    frames: np.ndarray | None,
) -> tuple[np.ndarray, np.ndarray]:
    """What the lights (not ambient, not the world's directions) add through rough glass hits (n,), glass their
    glass (glossy.glass_at): reflected and refracted (3, n) each, per unit of glass share, the refracted not yet
    tinted; shadowed as the diffuse terms are, from either side of the surface. The glass's own rays do not see the
    lights (its light is counted here). samples, counts, footprint, frames: as find_intensity takes them."""
    lights = GlassLights(glass)
    specular = np.zeros(hits.P.shape[1], dtype=scene.dtype)
    find_intensity(scene, hits, specular, samples, counts, footprint, frames, None, lights)
    return lights.reflected, lights.transmitted


def _glass_light(
    scene: PreparedScene,
    lights: list,
    terms: list[LightTerm | None],
    lit: list[np.ndarray],
    throughs: list[np.ndarray] | None,
    glass: glossy.Glass,
) -> tuple[np.ndarray, np.ndarray]:
    """The lights' sums through rough glass (3, k) each, reflected and refracted: each light's intensity,
    attenuation, colour and share that passes (glossy.glass_light_factor per unit of intensity), where its shadow ray
    reached the point (_glossy_light's sums, both sides of the surface)."""
    count = glass.eta.size
    reflected = np.zeros((3, count), dtype=np.float64)
    transmitted = np.zeros((3, count), dtype=np.float64)
    for light, term, light_lit, through in _glossy_lights(lights, terms, lit, throughs, glass=True):
        value_r, value_t = glossy.glass_light_factor(glass, term.L)
        value_r, value_t = (value_r if light.adds_glossy else 0.0), (value_t if light.adds_transmission else 0.0)
        scale = light.intensity
        if term.factor is not None:
            scale = scale * term.factor
        if through is not None:
            scale = scale * through
        reflected = np.where(light_lit, reflected + (value_r * scale) * term.color, reflected)
        transmitted = np.where(light_lit, transmitted + (value_t * scale) * term.color, transmitted)
    return reflected.astype(scene.dtype, copy=False), transmitted.astype(scene.dtype, copy=False)


def _glossy_lights(
    lights: list, terms: list[LightTerm | None], lit: list[np.ndarray], throughs: list | None, glass: bool = False
):
    """The lights that add through glossy lobes (a highlight, Glossy ray visibility on) or, glass, through rough
    glass (Glossy or Transmission visibility on), each with its term, where its shadow rays reached (n,) and the
    share that passed (n,; None: all)."""
    shadow_rays = iter(lit)
    passing = None if throughs is None else iter(throughs)
    for light, term in zip(lights, terms, strict=True):
        if term is None:
            continue
        light_lit = next(shadow_rays)
        through = None if passing is None else next(passing)
        if light.highlight and (light.adds_glossy or (glass and light.adds_transmission)):
            yield light, term, light_lit, through


def _columns(values: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """values (n,) or (1,) at rows: a shared one stays."""
    return values if values.size == 1 else values.take(rows)


def _shadow_share(
    scene: PreparedScene,
    terms: list[LightTerm],
    lit: list[np.ndarray],
    throughs: list[np.ndarray] | None,
    count: int,
) -> np.ndarray:
    """The Shadow pass (n,): the share of the lights (not ambient) that reach each point, a light of a size once
    (each of its samples by its share)."""
    reached = [light_lit & (term.diffuse_gate | term.gate) for light_lit, term in zip(lit, terms, strict=True)]
    if throughs is not None:
        reached = [light_reached * through for light_reached, through in zip(reached, throughs, strict=True)]
    share = np.zeros(count, dtype=scene.dtype)
    settings = scene.scene.render
    lights = directed(scene.lights)
    if all(light.weight == 1.0 for light in lights):
        for light_reached in reached:
            share += light_reached
        return share / len(reached) if reached else np.ones(count, dtype=scene.dtype)
    # a sample shared out among a pixel's samples (and taken by one pattern's pixels) reaches its points for g times
    # the patterns of its light's samples; its light's samples still weigh 1 together at every point (the
    # reference's sum of the samples it takes)
    for light_reached, light in zip(reached, lights, strict=True):
        share += light_reached * (light.weight * _boost(settings, light))
    return share / sum(light.weight for light in lights)


def _plain(
    scene: PreparedScene,
    lights: list,
    terms: list[LightTerm | None],
    lit: list[np.ndarray],
    length_n: np.ndarray,
    exponent: np.ndarray,
    split: dict[str, np.ndarray] | None = None,
    throughs: list[np.ndarray] | None = None,
) -> np.ndarray:
    """The light-by-light sum of find_intensity in the documented arithmetic (one intensity per point, (n,));
    split: also the ambient, diffuse and specular sums apart (find_intensity)."""
    count = length_n.shape[0]
    intensity = np.zeros(count, dtype=scene.dtype)
    if split is not None:
        ambient, diffuse_sum, specular_sum = (np.zeros(count, dtype=scene.dtype) for _ in range(3))
    shadow_rays = iter(lit)
    passing = None if throughs is None else iter(throughs)
    for light, term in zip(lights, terms, strict=True):
        if term is None:
            intensity = intensity + light.intensity
            if split is not None:
                ambient = ambient + light.intensity
            continue
        light_lit = next(shadow_rays)
        diffuse = light.intensity * term.NL / (length_n * term.length_l)
        if term.factor is not None:  # no attenuation here: a shared sample's g
            diffuse = diffuse * term.factor
        if passing is not None:
            through = next(passing)
            diffuse = diffuse * through
        intensity = np.where(light_lit & term.diffuse_gate, intensity + diffuse, intensity)
        gate = term.gate
        gate &= light_lit
        highlight = light.intensity * np.power(np.where(gate, term.cosine, 1.0), exponent)
        if term.factor is not None:
            highlight = highlight * term.factor
        if passing is not None:
            highlight = highlight * through
        intensity = np.where(gate, intensity + highlight, intensity)
        if split is not None:
            diffuse_sum = np.where(light_lit & term.diffuse_gate, diffuse_sum + diffuse, diffuse_sum)
            specular_sum = np.where(gate, specular_sum + highlight, specular_sum)
    if split is not None:
        split.update(ambient=ambient, diffuse=diffuse_sum, specular=specular_sum)
    return intensity


def _colored(
    scene: PreparedScene,
    lights: list,
    terms: list,
    lit: list[np.ndarray],
    length_n: np.ndarray,
    exponent: np.ndarray,
    split: dict[str, np.ndarray] | None = None,
    throughs: list[np.ndarray] | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """The light-by-light sums of find_intensity with each light's colour and attenuation: (ambient + diffuse,
    specular) (3, n) each; split: also the ambient and the diffuse sums apart (find_intensity)."""
    count = length_n.shape[0]
    diffuse_sum = np.zeros((3, count), dtype=scene.dtype)
    specular_sum = np.zeros((3, count), dtype=scene.dtype)
    ambient = lights_diffuse = None
    if split is not None:
        ambient, lights_diffuse = np.zeros((3, count), dtype=scene.dtype), np.zeros((3, count), dtype=scene.dtype)
    shadow_rays = iter(lit)
    passing = None if throughs is None else iter(throughs)
    for light, term in zip(lights, terms, strict=True):
        if term is None:
            diffuse_sum = diffuse_sum + light.intensity * light.color
            if split is not None:
                ambient = ambient + light.intensity * light.color
            continue
        _, NL, length_l, diffuse_gate, gate, cosine, _, factor, color = term
        light_lit = next(shadow_rays)
        diffuse = light.intensity * NL / (length_n * length_l)
        if light.highlight:
            highlight = light.intensity * np.power(np.where(gate & light_lit, cosine, 1.0), exponent)
        if factor is not None:
            diffuse = diffuse * factor
            highlight = highlight * factor
        if passing is not None:
            through = next(passing)
            diffuse = diffuse * through
            highlight = highlight * through if light.highlight else None
        diffuse_sum = np.where(light_lit & diffuse_gate, diffuse_sum + diffuse * color, diffuse_sum)
        if split is not None:
            lights_diffuse = np.where(light_lit & diffuse_gate, lights_diffuse + diffuse * color, lights_diffuse)
        if not light.highlight:
            continue
        gate &= light_lit
        specular_sum = np.where(gate, specular_sum + highlight * color, specular_sum)
    if split is not None:
        split.update(ambient=ambient, diffuse=lights_diffuse, specular=specular_sum)
    return diffuse_sum, specular_sum
