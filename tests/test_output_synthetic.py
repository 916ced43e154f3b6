"""Synthetic runs for the output tests, with values that can be worked out by hand.

``circle_run``: a robot driving a circle of radius 2 m at 0.5 rad/s for 20 s
(dt = 0.01, 2001 samples) in three phases:

| phase | samples | what is known |
|---|---|---|
| approach (track) | 0..499 | reference 0.01 m east of the robot |
| orbit (track) | 500..1499 | same reference; lasts 10 s |
| park (regulate to 0, 0, 0) | 1500..2000 | constraint -0.5, but 0.02 on 1600..1649 (0.5 s) |

The position estimate starts 1 m off in x and y and its error decays as
0.9**k: it is below 0.05 from sample 29 (t = 0.29 s) on. The final position
is 2 m from the park target.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from wmr_mission.output.result import RunResult
from wmr_mission.record import Outcome, PhaseRecord, Transition

DT = 0.01
RADIUS = 2.0
TURN_RATE = 0.5
ERROR_DECAY = 0.9
REF_OFFSET = 0.01
PHASE_STARTS = (0, 500, 1500)
VIOLATION = (1600, 1650, 0.02)

REGIONS: dict[str, Any] = {
    "ellipse": {"type": "ellipse", "center": [0.0, 0.0], "semi_axes": [5.5, 3.0], "rotation": 0.3},
    "pond": {"type": "circle", "center": [3.0, 2.5], "radius": 0.5},
    "dock": {"type": "box", "min": [-1.0, -2.8], "max": [1.0, -2.2]},
    "shed": {"type": "polygon", "vertices": [[-4.0, 0.0], [-3.0, 0.5], [-3.5, 1.5]]},
    "fence": {"type": "half-plane", "normal": [1.0, 0.0], "offset": 4.5},
}


def circle_run(samples: int = 2001, *, theta_error: np.ndarray | None = None) -> RunResult:
    k = np.arange(samples)
    t = np.asarray(k * DT, dtype=np.float64)
    x = RADIUS * np.cos(TURN_RATE * t)
    y = RADIUS * np.sin(TURN_RATE * t)
    theta = np.asarray(TURN_RATE * t + math.pi / 2, dtype=np.float64)
    decay = ERROR_DECAY**k
    theta_est = (
        theta.copy() if theta_error is None else np.asarray(theta - theta_error, dtype=np.float64)
    )
    phase = np.searchsorted(np.array(PHASE_STARTS[1:]), k, side="right").astype(np.int64)
    tracking = phase < 2
    x_ref = np.where(tracking, x + REF_OFFSET, np.nan)
    y_ref = np.where(tracking, y, np.nan)
    constraint = np.where(tracking, np.nan, -0.5)
    start, stop, value = VIOLATION
    constraint[start:stop] = value
    iterations = np.where(k < 5, 3, 0).astype(np.int64)
    return RunResult(
        mission_name="circle",
        dt=DT,
        seed=7,
        phases=[
            PhaseRecord("approach", "track"),
            PhaseRecord("orbit", "track"),
            PhaseRecord(
                "park", "regulate", target=(0.0, 0.0, 0.0), constraints=(("ellipse", "inside"),)
            ),
        ],
        t=t,
        x=x,
        y=y,
        theta=theta,
        x_est=x + decay,
        y_est=y + decay,
        theta_est=theta_est,
        v=np.full(samples, RADIUS * TURN_RATE),
        omega=np.full(samples, TURN_RATE),
        phase=phase,
        x_ref=x_ref,
        y_ref=y_ref,
        constraint=constraint,
        phase2_iterations=iterations,
        compute_ns=(1000 + 10 * (k % 100)).astype(np.int64),
        transitions=_transitions(t),
        outcome=Outcome.success,
        message="all phases done",
        limits=(10.0, 20.0),
        error_bounds=((-0.05, 0.05), (-0.05, 0.05), (math.nan, math.nan)),
        regions=REGIONS,
    )


def _transitions(t: np.ndarray) -> list[Transition]:
    names = ("approach", "orbit", "park")
    conditions = (("reaches", 0.0), ("elapsed", 10.0))
    changes = [
        Transition(float(t[start]), names[i], names[i + 1], *conditions[i])
        for i, start in enumerate(PHASE_STARTS[1:])
        if start < t.size
    ]
    return [*changes, Transition(float(t[-1]), names[len(changes)], None, "settled", 0.004)]


def test_circle_run_is_consistent() -> None:
    run = circle_run()
    assert run.samples == 2001
    assert run.t[-1] == np.float64(2000 * DT)
    assert [int(run.phase[s]) for s in PHASE_STARTS] == [0, 1, 2]
    lengths = {
        np.asarray(getattr(run, name)).shape for name in ("x", "phase", "x_ref", "compute_ns")
    }
    assert lengths == {(2001,)}
