"""``pure-pursuit``: the geometric pure-pursuit law (Coulter, "Implementation
of the Pure Pursuit Path Tracking Algorithm", 1992), a baseline against the
paper's controller.

Along a path: the goal point is the path a look-ahead distance
``L = look_ahead + speed_gain |v_{k-1}|`` along its arc beyond the reference
point at t_k, the arc continued with the path's curvature there
(``omega_r / v_r``, wmr_mission.controllers.reference_motion); the robot
turns onto the circle through its axle and the goal point, tangent to its
heading::

    omega = v * 2 g_y / (g_x^2 + g_y^2)      (g_x, g_y) the goal in the robot's frame

On a circle and on a line the goal point then lies on the path itself, so a
robot on the path stays on it. The path is timed, so the speed keeps the
robot where the reference is: ``v = v_r * a / a_r``, with ``a`` the goal's
distance ahead of the robot along the path's tangent and ``a_r`` its
distance ahead of the reference point (``v = v_r`` when on time, faster when
behind). Then the actuator limits. It knows no constraint rows: a track
phase's zones are not kept. Regulate and hold phases are the paper's
regulator (Case 1 with eq. (28) on the phase's zones,
wmr_mission.controllers.paper.regulate_input) with the paper's default weights.
"""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

from pydantic import Field

from wmr_mission.basics import FloatArray
from wmr_mission.controllers import paper
from wmr_mission.controllers.reference_motion import reference_motion
from wmr_mission.controllers.registry import ControllerSettings, ControllerType
from wmr_mission.fields import NonNegative, Positive
from wmr_mission.kernels.jit import inlined
from wmr_mission.kernels.loop import EnteredPhase
from wmr_mission.kernels.model import saturate
from wmr_mission.kernels.records import Plant, Scratch, scratch

# Below this |curvature * L| the arc is a straight segment to first order (its
# second-order term is kept).
STRAIGHT = 1e-6


class PurePursuitController(ControllerSettings):
    """Pure pursuit; the paper's regulator for regulate and hold phases."""

    type: Literal["pure-pursuit"] = Field(description="Controller kind: pure pursuit.")
    look_ahead: Positive = Field(default=0.3, description="Look-ahead distance at rest [m].")
    speed_gain: NonNegative = Field(
        default=0.0,
        description="Look-ahead added per unit of speed [s]: L = look_ahead + speed_gain * |v|.",
    )


class PurePursuitTuning(NamedTuple):
    look_ahead: float  # [m]
    speed_gain: float  # [s]
    regulation: paper.PaperTuning  # the paper's regulator, its default weights


@inlined
def next_input(
    tuning: PurePursuitTuning,
    phase: EnteredPhase,
    aim_now: FloatArray,
    aim: FloatArray,
    estimate: FloatArray,
    estimate_prev: FloatArray,
    u_prev: FloatArray,
    plant: Plant,
    memory: FloatArray,
    scratch: Scratch,
    u: FloatArray,
) -> None:
    """u_k from x_{k|k}: pure pursuit along a path, the paper's regulator to a pose."""
    if not phase.tracking:
        paper.regulate_input(
            estimate, estimate_prev, u_prev, phase.target, phase.constraint_kinds,
            phase.constraint_params, tuning.regulation, plant, memory, scratch, u,
        )  # fmt: skip
        return
    x_r, y_r, _, v_r, omega_r = reference_motion(aim_now, aim, plant.dt)
    distance = tuning.look_ahead + tuning.speed_gain * abs(u_prev[0])
    tx = aim_now[2]
    ty = aim_now[3]
    # The goal: the arc of the path's curvature, ``distance`` long, from the
    # reference point: ahead = sin(kL) / k, aside = (1 - cos(kL)) / k.
    bend = omega_r / v_r * distance if v_r > 0.0 else 0.0
    if abs(bend) < STRAIGHT:
        ahead = distance
        aside = 0.5 * bend * distance
    else:
        ahead = math.sin(bend) / bend * distance
        aside = (1.0 - math.cos(bend)) / bend * distance
    gx = x_r + ahead * tx - aside * ty
    gy = y_r + ahead * ty + aside * tx
    # The goal in the robot's frame.
    theta = estimate[2]
    c = math.cos(theta)
    s = math.sin(theta)
    dx = gx - estimate[0]
    dy = gy - estimate[1]
    forward = c * dx + s * dy
    left = -s * dx + c * dy
    # On time when the goal is as far ahead of the robot as of the reference.
    v = v_r * (dx * tx + dy * ty) / ahead
    squared = forward * forward + left * left
    omega = v * 2.0 * left / squared if squared > 0.0 else 0.0
    u[0], u[1] = saturate(v, omega, u_prev[0], u_prev[1], plant.limits, plant.dt)


def tuning_of(settings: PurePursuitController, plant: Plant) -> PurePursuitTuning:
    return PurePursuitTuning(
        look_ahead=float(settings.look_ahead),
        speed_gain=float(settings.speed_gain),
        regulation=paper.tuning_of(paper.PaperController(), plant),
    )


# Registered by wmr_mission.controllers.
CONTROLLER = ControllerType(
    settings=PurePursuitController,
    tuning_record=PurePursuitTuning,
    tuning_of=tuning_of,
    memory_size=paper.MEMORY_SIZE,  # the paper's regulator's memory
    new_scratch=lambda tuning: scratch(),
    step=next_input,
)
