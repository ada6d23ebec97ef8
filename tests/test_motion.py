"""The vane's motion against closed forms: step response, shortest arc, threshold, settling, spin, gusts, keys."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tracer.scene.keyframes import interpolate, reduce_keys
from tracer.scene.motion import Motion, Spin, frame_times, heading_into_wind, simulate, transition
from tracer.scene.wind import Gusts, Wind, WindKey, sample


def steady(direction: float, speed: float, **motion: object) -> Motion:
    return Motion(wind=Wind(keys=(WindKey(0.0, direction, speed),)), **motion)


def closed_form_step(times: np.ndarray, step: float, zeta: float, omega: float) -> np.ndarray:
    """Heading of a vane at rest at 0 when a steady wind pulls it toward `step` degrees (underdamped)."""
    damped = omega * math.sqrt(1 - zeta * zeta)
    envelope = np.exp(-zeta * omega * times)
    return step - step * envelope * (np.cos(damped * times) + zeta * omega / damped * np.sin(damped * times))


@pytest.mark.parametrize("fps", [1, 24, 240])
@pytest.mark.parametrize("speed", [1.0, 8.0, 60.0])
@pytest.mark.parametrize("zeta", [0.3, 0.7])
def test_step_response_follows_the_closed_form(fps: int, speed: float, zeta: float) -> None:
    wavelength = 7.0
    motion = steady(direction=30.0, speed=speed, damping=zeta, wavelength=wavelength, threshold=0.1, fps=fps)
    step = heading_into_wind(30.0)  # 60 degrees
    frames = fps * 20 + 1
    headings = simulate(motion, frames, initial_heading=0.0)
    omega = 2 * math.pi * speed / wavelength
    expected = closed_form_step(frame_times(frames, fps), step, zeta, omega)
    assert np.all(np.isfinite(headings))
    assert np.max(np.abs(headings - expected)) < 0.1


@pytest.mark.parametrize("zeta", [0.2, 0.4, 0.6])
def test_overshoot_and_period_of_a_sampled_response(zeta: float) -> None:
    speed, wavelength, fps = 3.0, 8.0, 240
    headings = simulate(steady(0.0, speed, damping=zeta, wavelength=wavelength, fps=fps), fps * 12, 0.0)
    step = heading_into_wind(0.0)  # 90
    overshoot = (headings.max() - step) / step
    assert overshoot * step == pytest.approx(math.exp(-math.pi * zeta / math.sqrt(1 - zeta**2)) * step, abs=0.1)
    # successive maxima are one damped period apart
    peaks = [k for k in range(1, headings.size - 1) if headings[k - 1] < headings[k] >= headings[k + 1]]
    period = (peaks[1] - peaks[0]) / fps
    omega = 2 * math.pi * speed / wavelength
    assert period == pytest.approx(2 * math.pi / (omega * math.sqrt(1 - zeta**2)), abs=1.5 / fps)


@pytest.mark.parametrize("zeta", [0.3, 1.0, 2.5])
def test_transition_matrix_equals_the_exponential_series(zeta: float) -> None:
    omega, h = 5.0, 0.3
    a11, a12, a21, a22 = transition(zeta, omega, h)
    matrix = np.array([[0.0, 1.0], [-(omega**2), -2 * zeta * omega]])
    series, term = np.eye(2), np.eye(2)
    for k in range(1, 60):  # exp(A h) = sum (A h)^k / k!
        term = term @ (matrix * h) / k
        series = series + term
    np.testing.assert_allclose([[a11, a12], [a21, a22]], series, rtol=1e-9, atol=1e-12)


def test_large_wind_at_one_frame_per_second_stays_bounded() -> None:
    headings = simulate(steady(200.0, 60.0, damping=0.3, wavelength=6.0, fps=1), 30, 0.0)
    assert np.all(np.isfinite(headings))
    assert abs((headings[-1] - heading_into_wind(200.0) + 180) % 360 - 180) < 0.1  # settled into the wind


def test_wind_turning_through_north_takes_the_short_way() -> None:
    # from 350 to 10 degrees: the vane turns 20 degrees (plus overshoot), not 340
    wind = Wind(keys=(WindKey(0.0, 350.0, 6.0), WindKey(2.0, 350.0, 6.0), WindKey(4.0, 10.0, 6.0)))
    motion = Motion(wind=wind, damping=0.6, wavelength=8.0, fps=24)
    headings = simulate(motion, 24 * 12, initial_heading=heading_into_wind(350.0))
    travel = headings.max() - headings.min()
    assert travel < 30.0
    assert headings[-1] == pytest.approx(heading_into_wind(350.0) - 20.0, abs=0.1)
    direction, _ = sample(wind, np.array([3.0]))
    assert direction[0] == pytest.approx(0.0, abs=1e-9)  # half way along the short arc: north


def test_below_threshold_the_vane_does_not_move() -> None:
    headings = simulate(steady(90.0, 0.4, threshold=0.5, fps=24), 240, initial_heading=12.0)
    assert np.all(headings == 12.0)


def test_a_stopped_wind_lets_the_vane_settle() -> None:
    wind = Wind(keys=(WindKey(0.0, 180.0, 10.0),), stop=1.0)  # stops while the vane is still swinging
    headings = simulate(Motion(wind=wind, damping=0.2, friction_time=0.5, fps=24), 24 * 10, initial_heading=0.0)
    assert abs(headings[24] - headings[23]) > 0.5  # moving when the wind stops
    assert abs(headings[-1] - headings[-2]) < 1e-6  # at rest after
    assert headings[-1] == pytest.approx(headings[-24 * 2], abs=1e-3)


def test_calm_before_start() -> None:
    wind = Wind(keys=(WindKey(0.0, 0.0, 8.0),), start=2.0)
    headings = simulate(Motion(wind=wind, fps=10), 40, initial_heading=5.0)
    assert np.all(headings[:21] == 5.0) and headings[-1] != 5.0


def test_gusts_are_seeded_and_have_the_stated_spread() -> None:
    times = np.linspace(0, 2000, 200001)
    wind = Wind(keys=(WindKey(0.0, 90.0, 10.0),), gusts=Gusts(intensity=0.2, time_scale=2.0, seed=3))
    direction, speed = sample(wind, times)
    again, _ = sample(wind, times[:1000])
    assert np.array_equal(direction[:1000], again)
    other, _ = sample(Wind(keys=wind.keys, gusts=Gusts(0.2, 2.0, seed=4)), times[:1000])
    assert not np.allclose(other, again)
    assert np.std(speed) / 10.0 == pytest.approx(0.2, rel=0.2)
    assert np.std((direction - 90 + 180) % 360 - 180) == pytest.approx(math.degrees(0.2), rel=0.2)


@pytest.mark.parametrize(("direction", "spin_to"), [("clockwise", -1), ("counterclockwise", 1)])
def test_spin_reaches_its_speed_and_ramps(direction: str, spin_to: int) -> None:
    spin = Spin(direction=direction, speed=90.0, smoothness=1.0, start=1.0, stop=5.0)
    headings = simulate(Motion(mode="spin", spin=spin, fps=100), 801, initial_heading=10.0)
    rate = np.diff(headings) * 100
    assert np.all(headings[:101] == 10.0)
    assert rate[300] == pytest.approx(spin_to * 90.0)  # t = 3 s: full speed
    assert rate[150] == pytest.approx(spin_to * 90.0 * 0.505, abs=1.0)  # half way up the ramp
    # up-ramp 45 + 3 s at 90 + down-ramp 45 degrees
    assert headings[-1] == pytest.approx(10.0 + spin_to * 360.0)


def test_spin_without_smoothness_starts_and_stops_at_once() -> None:
    spin = Spin(speed=30.0, smoothness=0.0, start=0.0, stop=2.0)
    headings = simulate(Motion(mode="spin", spin=spin, fps=10), 41, initial_heading=0.0)
    assert headings[10] == pytest.approx(-30.0) and headings[-1] == pytest.approx(-60.0)


def brute_force_fewest_keys(values: np.ndarray, tolerance: float) -> int:
    count = values.size
    best = [math.inf] * count
    best[0] = 1
    for j in range(1, count):
        for i in range(j):
            run = np.arange(i, j + 1)
            line = values[i] + (values[j] - values[i]) * (run - i) / (j - i)
            if np.max(np.abs(line - values[i : j + 1])) <= tolerance * (1 - 1e-6):
                best[j] = min(best[j], best[i] + 1)
    return int(best[-1])


@pytest.mark.parametrize("seed", range(6))
def test_key_reduction_is_minimal_on_small_curves(seed: int) -> None:
    rng = np.random.default_rng(seed)
    values = np.cumsum(rng.normal(0, 0.05, 40)) + np.sin(np.arange(40) / 5)
    keys = reduce_keys(values, 0.05)
    assert np.max(np.abs(interpolate(keys, values, values.size) - values)) <= 0.05
    assert keys.size == brute_force_fewest_keys(values, 0.05)


@pytest.mark.parametrize(
    "motion",
    [
        steady(250.0, 6.0, fps=24),
        Motion(wind=Wind(keys=(WindKey(0, 200, 6), WindKey(4, 300, 9)), gusts=Gusts(0.25, 1.5, 2)), fps=30),
        Motion(mode="spin", spin=Spin(speed=120, smoothness=2.0, start=0.5, stop=6.0), fps=60),
    ],
    ids=["steady", "gusty", "spin"],
)
def test_reduced_keys_stay_within_tolerance(motion: Motion) -> None:
    headings = simulate(motion, int(motion.fps * 12), initial_heading=0.0)
    keys = reduce_keys(headings)
    assert keys[0] == 0 and keys[-1] == headings.size - 1
    assert np.max(np.abs(interpolate(keys, headings, headings.size) - headings)) <= 0.05
    assert keys.size < headings.size


def test_unwrapped_headings_have_no_jumps() -> None:
    spin = Spin(speed=200.0, smoothness=0.0)
    headings = simulate(Motion(mode="spin", spin=spin, fps=24), 24 * 10, 0.0)
    assert np.max(np.abs(np.diff(headings))) < 10.0 and headings[-1] < -1500
