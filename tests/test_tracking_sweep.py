"""The tracking law from many starts, with and without noise, at three sampling
periods (scripts/tracking_sweep.py; docs/paper-notes.md, "The default
tracking law"). A few starts run by default; the whole sweep with -m sweep."""

from __future__ import annotations

import math

import pytest
from tracking_sweep import Start, failures, run, starts

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
