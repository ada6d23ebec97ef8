"""A wind description -> wind direction and speed at any times: constant or keyed, with seeded gusts, start and stop.

Directions follow meteorology: the direction the wind comes FROM, in degrees clockwise from north (+Y). Keyed
directions are interpolated along the shorter arc (350 -> 10 passes through north), speeds linearly. Gusts add
turbulence of intensity I = sigma_u / U: the speed varies by U * I * n_u(t) and the direction by I radians *
n_d(t) (for isotropic turbulence sigma_theta ~ sigma_v / U), where n_u and n_d are seeded unit-variance processes
with correlation time T (a sum of random-phase cosines with a Lorentzian spectrum, so exp(-|tau| / T)
autocorrelation). Outside [start, stop) the air is calm.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

GUST_COMPONENTS = 64
GUST_HIGHEST_QUANTILE = 0.97  # caps the Lorentzian's frequencies at about 20 / T, far above any vane's response


@dataclass(frozen=True)
class WindKey:
    time: float  # seconds
    direction: float  # degrees the wind comes from, clockwise from north
    speed: float  # m/s


@dataclass(frozen=True)
class Gusts:
    intensity: float = 0.2  # sigma_u / U
    time_scale: float = 2.0  # seconds: correlation time of the fluctuations
    seed: int = 0


@dataclass(frozen=True)
class Wind:
    keys: tuple[WindKey, ...] = (WindKey(0.0, 270.0, 5.0),)
    gusts: Gusts | None = None
    start: float = 0.0
    stop: float | None = None  # None: blows to the end


def wrap_degrees(angle: np.ndarray | float) -> np.ndarray | float:
    """An angle in degrees wrapped into [-180, 180)."""
    return (angle + 180.0) % 360.0 - 180.0


def _unit_noise(times: np.ndarray, time_scale: float, seed: int) -> np.ndarray:
    """A seeded, smooth, unit-variance random signal with autocorrelation about exp(-|tau| / time_scale)."""
    rng = np.random.default_rng(seed)
    quantiles = rng.uniform(0.0, GUST_HIGHEST_QUANTILE, GUST_COMPONENTS)
    frequencies = np.tan(np.pi * quantiles / 2.0) / time_scale  # rad/s, Lorentzian spectrum
    phases = rng.uniform(0.0, 2.0 * np.pi, GUST_COMPONENTS)
    waves = np.cos(np.multiply.outer(times, frequencies) + phases)
    return math.sqrt(2.0 / GUST_COMPONENTS) * waves.sum(axis=-1)


def sample(wind: Wind, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Wind at times (n,) seconds -> (direction the wind comes from in degrees [0, 360), speed m/s), each (n,)."""
    times = np.asarray(times, dtype=np.float64)
    keys = sorted(wind.keys, key=lambda key: key.time)
    key_times = np.array([key.time for key in keys])
    speeds = np.array([key.speed for key in keys])
    # unwrap the keyed directions so that consecutive keys differ by the shorter arc, then interpolate
    directions = np.array([keys[0].direction] + [0.0] * (len(keys) - 1))
    for k in range(1, len(keys)):
        directions[k] = directions[k - 1] + wrap_degrees(keys[k].direction - keys[k - 1].direction)
    direction = np.interp(times, key_times, directions)
    speed = np.interp(times, key_times, speeds)
    if wind.gusts is not None and wind.gusts.intensity > 0.0:
        gusts = wind.gusts
        speed = np.maximum(speed * (1.0 + gusts.intensity * _unit_noise(times, gusts.time_scale, gusts.seed)), 0.0)
        swing = math.degrees(gusts.intensity) * _unit_noise(times, gusts.time_scale, gusts.seed + 1_000_003)
        direction = direction + swing
    blowing = times >= wind.start
    if wind.stop is not None:
        blowing &= times < wind.stop
    return direction % 360.0, np.where(blowing, speed, 0.0)
