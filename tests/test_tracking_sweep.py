"""The tracking law from many starts, with and without noise, at three sampling
periods (scripts/tracking_sweep.py; docs/paper-notes.md, "The default
tracking law"). A few starts run by default; the whole sweep with -m sweep."""

from __future__ import annotations

import math

import pytest
from tracking_sweep import ROOT, Start, failures, run, starts, turn_rate_jitter

DTS = (0.005, 0.01, 0.02)
NOISE = 0.01  # [m and rad]


def _check(todo: list[Start]) -> None:
    missed = {
        f"case {s.case}, heading {math.degrees(s.heading):.0f} deg, estimate "
        f"{math.degrees(s.estimate_heading):.0f} deg, seed {s.seed}, dt {s.dt}": found
        for s in todo
        if (found := failures(s, run(s, {})))
    }
    assert not missed, missed


# Starts where the former one-sample law (look-ahead 0.05 m) failed: flown partly
# in reverse with the turn rate at its limit on up to 98 % of the orbit, or a
# turn-rate jitter of 2-20 rad/s under noise.
@pytest.mark.slow
@pytest.mark.parametrize(
    "start",
    [
        Start(2, math.radians(165), math.radians(165), 0.0, 0, 0.01),
        Start(1, math.radians(-90), 0.0, 0.0, 0, 0.01),
        Start(2, math.radians(-60), 0.0, 0.0, 0, 0.02),
        Start(2, math.radians(165), 0.0, NOISE, 1, 0.01),
        Start(1, math.radians(45), math.radians(45), NOISE, 0, 0.005),
    ],
    ids=["case2-165", "case1-m90-estimate0", "case2-m60-dt0.02", "case2-noisy", "case1-dt0.005"],
)
def test_a_few_starts(start: Start) -> None:
    _check([start])


@pytest.mark.sweep
@pytest.mark.parametrize("dt", DTS)
def test_every_fifteen_degrees_noise_free(dt: float) -> None:
    _check(starts(15.0, 0.0, 1, dt))


@pytest.mark.sweep
@pytest.mark.parametrize("dt", DTS)
def test_every_fifteen_degrees_with_noise_four_seeds(dt: float) -> None:
    _check(starts(15.0, NOISE, 4, dt))


@pytest.mark.slow
@pytest.mark.parametrize("name", ["noisy-ekf", "noisy-observer"])
def test_shipped_noisy_missions_command_a_smooth_turn_rate(name: str) -> None:
    # sigma = 0.02 m and rad, nominal turn rate 0.5 rad/s: the one-sample law
    # commanded it with a 3.4 rad/s standard deviation (noisy-ekf), 12.5 % of
    # the samples at the 6 rad/s limit.
    import numpy as np

    from wmr_mission import load_mission, run_mission

    result = run_mission(load_mission(ROOT / "missions" / f"{name}.yaml"))
    circle = (result.phase == 0) & (result.t >= 1.0)
    omega = result.omega[circle]
    assert turn_rate_jitter(omega) <= 0.5
    assert np.std(omega) <= 0.5
    assert np.mean(np.abs(omega) >= result.limits[1]) <= 0.01
