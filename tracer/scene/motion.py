"""Wind and vane settings -> the vane's heading at every frame: a real vane's damped dynamics, or the seed's spin.

Headings are the vane's turn about its axis in degrees, right-handed (counter-clockwise seen from above), as the
scene's `vane.heading`; heading 0 is the vane as modelled, its arrow along +X. A vane points INTO the wind, toward
where the wind comes from, so the wind from compass direction d (clockwise from north = +Y) pulls it toward heading
90 - d.

Wind mode (MacCready & Jex 1964; ASTM D5366): theta'' + 2 zeta w theta' + w^2 wrap(theta - theta_wind) = 0 with
w = 2 pi U / wavelength. Over each sub-step the wind is held at its mid-step value and the linear system is advanced
by its exact transition matrix exp(A h), so the integration is stable for any wind speed and frame rate. Below the
starting threshold speed the wind exerts no torque and bearing friction brings a turning vane to rest with time
constant friction_time.

Spin mode (the seed's program): turn clockwise or counter-clockwise at a set speed, spinning up over `smoothness`
seconds after start and down over the same time after stop.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Iterator
from dataclasses import dataclass, field
from typing import Literal

import numpy as np

from .wind import Wind, sample, wrap_degrees

MAX_SUBSTEP = 1.0 / 120.0  # seconds: the wind is sampled at least this often, whatever the frame rate
CHUNK_FRAMES = 2048  # frames simulated at a time: a long animation starts at once, in little memory


@dataclass(frozen=True)
class Spin:
    direction: Literal["clockwise", "counterclockwise"] = "clockwise"  # seen from above
    speed: float = 90.0  # degrees per second
    smoothness: float = 1.0  # seconds to spin up after start and down after stop
    start: float = 0.0
    stop: float | None = None


@dataclass(frozen=True)
class Motion:
    mode: Literal["wind", "spin"] = "wind"
    damping: float = 0.4  # zeta: 0.3-0.7 in real vanes
    wavelength: float = 8.0  # metres: the natural wavelength lambda_n
    threshold: float = 0.5  # m/s: below it the wind does not turn the vane
    friction_time: float = 0.6  # seconds: how fast bearing friction stops a becalmed vane
    initial_heading: float | None = None  # degrees; None: the scene's vane.heading
    fps: float = 24.0
    wind: Wind = field(default_factory=Wind)
    spin: Spin = field(default_factory=Spin)


def heading_into_wind(direction_from: np.ndarray | float) -> np.ndarray | float:
    """The heading (degrees, counter-clockwise from +X) of a vane pointing into wind from compass direction."""
    return 90.0 - direction_from


def frame_times(frames: int, fps: float) -> np.ndarray:
    """Times in seconds of frames 1..frames (frame 1 at t = 0, as Blender's first frame)."""
    return np.arange(frames, dtype=np.float64) / fps


def transition(zeta: float, omega: float, h: float) -> tuple[float, float, float, float]:
    """exp(A h) for A = [[0, 1], [-omega^2, -2 zeta omega]] as (a11, a12, a21, a22), overflow-free for large w h.

    exp(A h) = e^(s h) (C I + S (A - s I)) with s = -zeta omega and C, S from the eigenvalue split
    d^2 = omega^2 (zeta^2 - 1): cos / sin for an underdamped vane, cosh / sinh above critical damping."""
    sigma = -zeta * omega
    if zeta < 1.0 - 1e-9:
        damped = omega * math.sqrt(1.0 - zeta * zeta)
        decay = math.exp(sigma * h)
        c, s = decay * math.cos(damped * h), decay * math.sin(damped * h) / damped
    elif zeta > 1.0 + 1e-9:
        split = omega * math.sqrt(zeta * zeta - 1.0)
        slow, fast = math.exp((sigma + split) * h), math.exp((sigma - split) * h)
        c, s = (slow + fast) / 2.0, (slow - fast) / (2.0 * split)
    else:
        decay = math.exp(sigma * h)
        c, s = decay, decay * h
    return c + s * zeta * omega, s, -s * omega * omega, c - s * zeta * omega


def simulate_wind(motion: Motion, times: np.ndarray, initial_heading: float = 0.0) -> np.ndarray:
    """Headings (n,) in degrees, unwrapped (no jump from 359 to 0), of a wind-driven vane at increasing times (n,).

    The vane starts at rest at initial_heading at time 0."""
    times = np.asarray(times, dtype=np.float64)
    pieces = (times[first : first + CHUNK_FRAMES] for first in range(0, times.size, CHUNK_FRAMES))
    return np.concatenate([np.empty(0), *_wind_pieces(motion, pieces, initial_heading)])


def _wind_pieces(motion: Motion, pieces: Iterable[np.ndarray], initial_heading: float) -> Iterator[np.ndarray]:
    """simulate_wind's headings, chunk frames at a time: the vane's state carries over, so memory stays small and
    the first frames are ready at once however many follow.

    Each span between frame times is cut into the fewest equal sub-steps of at most MAX_SUBSTEP seconds; the wind
    is held at each sub-step's middle while the exact transition matrix advances the vane."""
    theta, rate, previous = float(initial_heading), 0.0, 0.0
    friction = motion.friction_time
    for part in pieces:
        spans = part - np.concatenate(([previous], part[:-1]))
        counts = np.maximum(0, np.ceil(spans / MAX_SUBSTEP - 1e-9)).astype(np.int64)
        frame_of = np.repeat(np.arange(part.size), counts)  # the frame whose span each sub-step is in
        step = np.arange(frame_of.size) - np.repeat(np.cumsum(counts) - counts, counts)
        h = spans[frame_of] / counts[frame_of] if frame_of.size else np.empty(0)
        starts = part[frame_of] - spans[frame_of]
        direction, speed = sample(motion.wind, starts + (step + 0.5) * h)
        target = heading_into_wind(direction)
        ends = np.cumsum(counts)  # sub-steps done when each frame's time is reached
        out = np.empty(part.size)
        done = 0
        for k in range(part.size):
            for index in range(done, ends[k]):
                if speed[index] < motion.threshold or speed[index] <= 0.0:
                    fade = math.exp(-h[index] / friction)
                    theta += rate * friction * (1.0 - fade)
                    rate *= fade
                else:
                    omega = 2.0 * math.pi * float(speed[index]) / motion.wavelength
                    error = float(wrap_degrees(theta - target[index]))
                    a11, a12, a21, a22 = transition(motion.damping, omega, float(h[index]))
                    new_error = a11 * error + a12 * rate
                    rate = a21 * error + a22 * rate
                    theta += new_error - error
            done = ends[k]
            out[k] = theta
        previous = float(part[-1])
        yield out


def simulate_spin(spin: Spin, times: np.ndarray, initial_heading: float = 0.0) -> np.ndarray:
    """Headings (n,) in degrees of the seed's spinning vane: ramps of `smoothness` seconds at start and stop."""
    times = np.asarray(times, dtype=np.float64)
    speed, ramp = spin.speed, spin.smoothness
    sign = -1.0 if spin.direction == "clockwise" else 1.0

    def spun_up(t: np.ndarray) -> np.ndarray:
        """Degrees turned from start to t while spinning up toward full speed (no stop)."""
        elapsed = np.maximum(t - spin.start, 0.0)
        if ramp <= 0.0:
            return speed * elapsed
        return np.where(
            elapsed <= ramp, speed * elapsed**2 / (2.0 * ramp), speed * ramp / 2.0 + speed * (elapsed - ramp)
        )

    turned = spun_up(times)
    if spin.stop is not None:
        stop = max(spin.stop, spin.start)
        at_stop = float(spun_up(np.array([stop]))[0])
        rate_at_stop = speed if ramp <= 0.0 else speed * min(1.0, (stop - spin.start) / ramp)
        after = np.maximum(times - stop, 0.0)
        if ramp <= 0.0:
            coasting = np.zeros_like(after)
        else:
            slowing = speed / ramp  # the same slope as spinning up
            halt = rate_at_stop / slowing
            after = np.minimum(after, halt)
            coasting = rate_at_stop * after - slowing * after**2 / 2.0
        turned = np.where(times >= stop, at_stop + coasting, turned)
    return initial_heading + sign * turned


def simulate(motion: Motion, frames: int, initial_heading: float = 0.0) -> np.ndarray:
    """The vane's heading (frames,) in degrees at frames 1..frames, unwrapped."""
    return np.concatenate([np.empty(0), *iter_headings(motion, frames, initial_heading)])


def iter_headings(motion: Motion, frames: int, initial_heading: float = 0.0) -> Iterator[np.ndarray]:
    """simulate()'s headings in consecutive pieces (of CHUNK_FRAMES or fewer), computed as they are asked for."""
    start = motion.initial_heading if motion.initial_heading is not None else initial_heading
    pieces = (
        np.arange(first, min(frames, first + CHUNK_FRAMES), dtype=np.float64) / motion.fps
        for first in range(0, frames, CHUNK_FRAMES)
    )  # frame_times(frames, fps), a piece at a time
    if motion.mode == "spin":
        yield from (simulate_spin(motion.spin, times, start) for times in pieces)
    else:
        yield from _wind_pieces(motion, pieces, start)
