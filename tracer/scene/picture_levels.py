"""An image background's picture -> its levels, each half the last's size (means of 2 x 2 texels), and the
background along a direction blurred to the solid angle a sample stands for: filtered importance sampling (Krivanek and
Colbert 2008), so that a glossy lobe that sees the world alone reflects a blur of the picture from its few samples,
not a sharp copy of it per sample."""

from __future__ import annotations

import dataclasses
import math
from collections import OrderedDict

import numpy as np

from . import scene as sc
from .world_light import kept

# the level a sample reads: half the log2 of its solid angle over a texel's, plus this (Colbert and Krivanek's bias:
# a sample's footprint spans about twice its share of the lobe, which keeps neighbouring samples' blurs overlapping)
LEVEL_BIAS = 1.0

_KEPT: OrderedDict[object, tuple[sc.Background, list[sc.Background]]] = OrderedDict()


def levels(background: sc.Background) -> list[sc.Background]:
    """The background at each level: itself first, then its picture halved again and again (bilinear, float32) down to
    one texel's height, kept for KEPT backgrounds a process (by identity where the picture is read-only)."""
    return kept(_KEPT, background, _made)


def _made(background: sc.Background) -> list[sc.Background]:
    made = [background]
    picture = np.asarray(background.image, dtype=np.float32)[..., :3]
    while picture.shape[0] >= 2 and picture.shape[1] >= 2:
        even = picture[: picture.shape[0] // 2 * 2, : picture.shape[1] // 2 * 2]  # an odd last row or column left out
        picture = (even[0::2, 0::2] + even[1::2, 0::2] + even[0::2, 1::2] + even[1::2, 1::2]) * np.float32(0.25)
        picture.flags.writeable = False
        made.append(dataclasses.replace(background, image=picture, interpolation="linear"))
    return made


def level(solid_angle: float, background: sc.Background) -> float:
    """The level (>= 0, fractional) a sample standing for solid_angle steradians reads of the background: half the
    log2 of it over a texel's mean solid angle at level 0 (4 pi / (W H)), plus LEVEL_BIAS."""
    height, width = background.image.shape[:2]
    ratio = solid_angle * (width * height) / (4.0 * math.pi)
    return max(0.0, 0.5 * math.log2(ratio) + LEVEL_BIAS) if ratio > 0.0 else 0.0


def levels_of(solid_angles: np.ndarray, background: sc.Background) -> np.ndarray:
    """level() of each solid angle (n,), the same operations on arrays."""
    height, width = background.image.shape[:2]
    ratio = solid_angles * (width * height) / (4.0 * math.pi)
    with np.errstate(divide="ignore"):
        return np.where(ratio > 0.0, np.maximum(0.0, 0.5 * np.log2(ratio) + LEVEL_BIAS), 0.0)
