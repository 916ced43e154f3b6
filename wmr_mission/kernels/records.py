"""The records every control law may read: plain named tuples of numbers and
arrays, built once per run and passed whole, so a kernel reads ``plant.dt``
instead of its seventh positional argument.

Named tuples are what numba passes into compiled code without copying. Each
estimator and controller has its own tuning record besides these
(wmr_mission.estimators, wmr_mission.controllers).
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from wmr_mission.basics import FloatArray

# A position farther than this from every coordinate the mission names is a
# runaway, not a robot [m]: the threshold follows the mission's own scale, so a
# mission written in map coordinates (y = 5e6) runs like one near the origin.
RUNAWAY_DISTANCE = 1e6
# An input beyond this, whatever the limits say, is a runaway [m/s, rad/s]:
# no wheeled robot drives at 1 km/s or turns 160 times a second.
RUNAWAY_INPUT = 1e3


class Plant(NamedTuple):
    """The robot as the controller and the divergence checks see it."""

    dt: float  # [s] sampling period
    limits: FloatArray  # |v|, |omega|, then rate limits [m/s^2, rad/s^2] (inf when absent)
    # |x| or |y| [m], |v| or |omega| [m/s, rad/s] beyond which the run has diverged.
    runaway_position: float = RUNAWAY_DISTANCE
    runaway_input: float = RUNAWAY_INPUT
    # [m] every zone's allowed side shrunk by this: what the estimate may be off
    # by, so that the true robot keeps a zone the estimate keeps (the estimator's
    # ``constraint_margin``; docs/paper-notes.md, eq. (28)).
    constraint_margin: float = 0.0
    # [m] the body's reach from the axle's centre, of the margin above
    body: float = 0.0


class Scratch(NamedTuple):
    """Scratch arrays of the corrective control laws, allocated once per run."""

    d: FloatArray  # (2, 3) constraint Jacobian D of eq. (26)
    eta: FloatArray  # (2,) constraint residual of eq. (26)
    b: FloatArray  # (3, 2) input Jacobian B of eq. (24)
    gain: FloatArray  # (2, 3) regulator gain T of eq. (20)
    h: FloatArray  # (2, 2) weight of the tracking output's motion (constrained tracking)


def scratch() -> Scratch:
    return Scratch(
        d=np.zeros((2, 3)),
        eta=np.zeros(2),
        b=np.zeros((3, 2)),
        gain=np.zeros((2, 3)),
        h=np.zeros((2, 2)),
    )
