"""Render pass names -> what each holds, its channels, Blender's name for it, and how a pixel's samples combine.

A render asks for passes by name (`render.passes` in a scene file, `--passes` on the command line, View Layer >
Passes in Blender); each comes out beside the image as its own (height, width, channels) array. Data passes are the
first hit's, as Cycles writes them; the Whitted passes split the documented shading term by term and add up to the
image (docs/passes.md)."""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal


@dataclass(frozen=True)
class Pass:
    """name: the tracer's; blender: Blender's pass name (a custom pass where Blender has none); channels: Blender's
    channel letters; combine: how a pixel's samples give its value ("mean"; "centre": the sample nearest the
    pixel's centre (centre_sample), as Cycles writes depth, position and the indices from its first sample, which
    lands on the centre; "ranks": Cryptomatte's (id, coverage) pairs from every sample's id); what: one line for the
    docs and the tooltips."""

    name: str
    blender: str
    channels: str
    combine: Literal["mean", "centre", "ranks"]
    what: str


def centre_sample(samples: int) -> int:
    """The sample of a pixel's n x n stratified grid (row by row) that a "centre" pass takes: the middle stratum's,
    (n // 2, n // 2), the one over the pixel's centre (odd n) or next to it (even n: a quarter of a stratum off)."""
    n = math.isqrt(samples)
    return (n // 2) * n + n // 2


# Cryptomatte levels: the (id, coverage) ranks kept per pixel, Blender's View Layer > Passes > Cryptomatte > Levels
# (2 to 16, 6 by default); they go two to an RGBA layer, an odd count rounded up (cryptomatte_layers), as in Cycles.
CRYPTOMATTE_LEVELS = 6
CRYPTOMATTE_LEVELS_MAX = 16
# The depth and position of a camera ray that meets nothing (Cycles' "far" value for the background).
FAR = 1.0e10

PASSES: dict[str, Pass] = {
    p.name: p
    for p in (
        Pass("depth", "Depth", "Z", "centre", "distance along the camera's view axis to the first hit; 1e10 for none"),
        Pass("mist", "Mist", "Z", "mean", "0 at the mist start to 1 at start + depth, by the World's mist falloff"),
        Pass("normal", "Normal", "XYZ", "mean", "the first hit's shading normal, world space, unit length"),
        Pass("position", "Position", "XYZ", "centre", "the first hit's point, world space"),
        Pass("object_index", "IndexOB", "X", "centre", "the first hit object's pass index"),
        Pass("material_index", "IndexMA", "X", "centre", "the first hit material's pass index"),
        Pass("ambient", "Ambient", "RGB", "mean", "ambient lights times colour times (1 - reflectivity)"),
        Pass("diffuse", "DiffDir", "RGB", "mean", "the lights' diffuse terms times colour times (1 - reflectivity)"),
        Pass("specular", "GlossDir", "RGB", "mean", "the lights' highlight terms of the model in use"),
        Pass("emission", "Emit", "RGB", "mean", "the first hit's emission"),
        Pass("reflection", "Reflection", "RGB", "mean", "what the mirror rays bring back (their surfaces' terms)"),
        Pass("environment", "Env", "RGB", "mean", "the background seen by camera rays and mirror rays"),
        Pass("transmission", "Transmission", "RGB", "mean", "what refracted and straight-through rays bring back"),
        Pass("shadow", "Shadow", "X", "mean", "the share of the lights (not ambient) that reach the first hit"),
        # one RGBA layer's channels, lower case as Cycles names them (CryptoObject00.r, ...); cryptomatte_layers of them
        Pass("cryptomatte_object", "CryptoObject", "rgba", "ranks", "Cryptomatte by object"),
        Pass("cryptomatte_material", "CryptoMaterial", "rgba", "ranks", "by material"),
    )
}
# these add up to the image
WHITTED = ("ambient", "diffuse", "specular", "emission", "reflection", "environment", "transmission")
SHADING = (*WHITTED, "shadow")  # what the lights and mirrors give: traced with the image's terms


def cryptomatte_layers(levels: int = CRYPTOMATTE_LEVELS) -> int:
    """A Cryptomatte pass's RGBA layers for its levels: two ranks a layer, rounded up, at most 16 ranks (Cycles'
    `(min(16, levels) + 1) // 2`: levels 2 -> 1 layer, 6 -> 3, 10 -> 5)."""
    if levels < 1:
        raise ValueError(f"Cryptomatte levels {levels}: at least 1 rank is needed")
    return (min(CRYPTOMATTE_LEVELS_MAX, levels) + 1) // 2


def width(name: str, levels: int = CRYPTOMATTE_LEVELS) -> int:
    """The channels a pass takes in the traced image: a Cryptomatte pass 4 per RGBA layer of its levels."""
    definition = PASSES[name]
    if definition.combine == "ranks":
        return len(definition.channels) * cryptomatte_layers(levels)
    return len(definition.channels)


def layout(names: tuple[str, ...], levels: int = CRYPTOMATTE_LEVELS) -> dict[str, slice]:
    """Where each pass's channels sit after the colour (and alpha) channels of a combined pixel: name -> slice,
    counted from 0 (the caller adds the colour channels' count); levels: the Cryptomatte passes' (width)."""
    where, start = {}, 0
    for name in names:
        where[name] = slice(start, start + width(name, levels))
        start += width(name, levels)
    return where


def parse(text: str) -> tuple[str, ...]:
    """A --passes value ("all" or names separated by commas) -> the names in the registry's order. Raises
    ValueError naming what is unknown."""
    wanted = [part.strip() for part in text.split(",") if part.strip()]
    if wanted == ["all"]:
        return tuple(PASSES)
    unknown = [name for name in wanted if name not in PASSES]
    if unknown or not wanted:
        raise ValueError(f"unknown pass {', '.join(unknown) or '(none)'}; one of: all, {', '.join(PASSES)}")
    return tuple(name for name in PASSES if name in wanted)
