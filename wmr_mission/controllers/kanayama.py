"""``kanayama``: the tracking law of Kanayama, Kimura, Miyazaki and Noguchi
("A stable tracking control method for an autonomous mobile robot", 1990), a
baseline against the paper's controller.

Along a path, with the error of the reference pose in the robot's frame
``(e_x, e_y, e_theta)`` and the feed-forward ``(v_r, omega_r)``
(wmr_mission.controllers.reference_motion)::

    v     = v_r cos(e_theta) + k_x e_x
    omega = omega_r + v_r (k_y e_y + k_theta sin(e_theta))

then the actuator limits. It knows no constraint rows: a track phase's zones
are not kept. Regulate and hold phases are the paper's regulator (Case 1 with
eq. (28) on the phase's zones, wmr_mission.controllers.paper.regulate_input)
with the paper's default weights.
"""

from __future__ import annotations

import math
from typing import Literal, NamedTuple

from pydantic import Field

from wmr_mission.basics import FloatArray
from wmr_mission.controllers import paper
from wmr_mission.controllers.reference_motion import reference_motion
from wmr_mission.controllers.registry import ControllerSettings, ControllerType
from wmr_mission.fields import Model, NonNegative
from wmr_mission.kernels.jit import inlined
from wmr_mission.kernels.loop import EnteredPhase
from wmr_mission.kernels.model import saturate, wrap_angle
from wmr_mission.kernels.records import Plant, Scratch, scratch


class KanayamaGains(Model):
    """The three gains of the law."""

    x: NonNegative = Field(default=10.0, description="k_x: along-track error gain [1/s].")
    y: NonNegative = Field(default=64.0, description="k_y: cross-track error gain [1/m^2].")
    theta: NonNegative = Field(default=16.0, description="k_theta: heading error gain [1/m].")


class KanayamaController(ControllerSettings):
    """Kanayama's tracking law; the paper's regulator for regulate and hold phases."""

    type: Literal["kanayama"] = Field(description="Controller kind: Kanayama's tracking law.")
    gains: KanayamaGains = Field(default_factory=KanayamaGains, description="k_x, k_y, k_theta.")


class KanayamaTuning(NamedTuple):
    k_x: float  # [1/s]
    k_y: float  # [1/m^2]
    k_theta: float  # [1/m]
    regulation: paper.PaperTuning  # the paper's regulator, its default weights


@inlined
def next_input(
    tuning: KanayamaTuning,
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
    """u_k from x_{k|k}: Kanayama's law along a path, the paper's regulator to a pose."""
    if not phase.tracking:
        paper.regulate_input(
            estimate, estimate_prev, u_prev, phase.target, phase.constraint_kinds,
            phase.constraint_params, tuning.regulation, plant, memory, scratch, u,
        )  # fmt: skip
        return
    x_r, y_r, theta_r, v_r, omega_r = reference_motion(aim_now, aim, plant.dt)
    theta = estimate[2]
    c = math.cos(theta)
    s = math.sin(theta)
    dx = x_r - estimate[0]
    dy = y_r - estimate[1]
    e_x = c * dx + s * dy
    e_y = -s * dx + c * dy
    e_theta = wrap_angle(theta_r - theta)
    v = v_r * math.cos(e_theta) + tuning.k_x * e_x
    omega = omega_r + v_r * (tuning.k_y * e_y + tuning.k_theta * math.sin(e_theta))
    u[0], u[1] = saturate(v, omega, u_prev[0], u_prev[1], plant.limits, plant.dt)


def tuning_of(settings: KanayamaController, plant: Plant) -> KanayamaTuning:
    gains = settings.gains
    return KanayamaTuning(
        k_x=float(gains.x),
        k_y=float(gains.y),
        k_theta=float(gains.theta),
        regulation=paper.tuning_of(paper.PaperController(), plant),
    )


# Registered by wmr_mission.controllers.
CONTROLLER = ControllerType(
    settings=KanayamaController,
    tuning_record=KanayamaTuning,
    tuning_of=tuning_of,
    memory_size=paper.MEMORY_SIZE,  # the paper's regulator's memory
    new_scratch=lambda tuning: scratch(),
    step=next_input,
)
