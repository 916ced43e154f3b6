"""irsim: IR-SIM's differential-drive robot as the true plant, stepped at dt, headless.

Our actuation (input delay, lag, slip) decides the (v, omega) IR-SIM is
stepped with; our skid and process noise are added to the pose it returns,
and our sensors measure that pose. IR-SIM integrates by forward Euler
(``x_{k+1} = x_k + dt v cos theta_k``, ``theta`` wrapped to [-pi, pi)),
where eq. (1) adds the second-order terms ``-/+ dt^2 v omega sin/cos theta / 2``:
a heading lag of dt omega / 2, a position offset of the order of v dt
(docs/backends.md). The heading is unwrapped back into ours.
"""

from __future__ import annotations

import contextlib
import io
import math
import tempfile
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path
from typing import Any

from wmr_mission.backends.registry import missing
from wmr_mission.basics import FloatArray
from wmr_mission.kernels import disturbances
from wmr_mission.kernels.disturbances import PROCESS_NOISE, SKID, Actuation
from wmr_mission.kernels.model import wrap_angle
from wmr_mission.sim.plan import MissionPlan
from wmr_mission.spec.backend import Backend

# A robot needs a world; ours has no obstacles and no border that stops it.
WORLD = "world: {{height: 1000, width: 1000, step_time: {dt!r}}}\n"


def _import_irsim() -> Any:
    """IR-SIM, imported quietly: at import it prints to stdout while it tries
    interactive matplotlib backends, and switches the process's backend."""
    import matplotlib

    chosen = matplotlib.get_backend()
    with contextlib.redirect_stdout(io.StringIO()):
        import irsim
    matplotlib.use(chosen)
    return irsim


class IrSimPlant:
    """IR-SIM in place of the loop's plant step (wmr_mission.sim.plant_side)."""

    def __init__(self, plan: MissionPlan) -> None:
        try:
            irsim = _import_irsim()
        except ImportError as error:
            raise missing("irsim", error) from None
        self.version = str(irsim.__version__)
        with tempfile.TemporaryDirectory() as directory:
            world = Path(directory) / "world.yaml"
            world.write_text(WORLD.format(dt=plan.dt))
            self.env = irsim.make(str(world), headless=True, log_level="ERROR")
        v_max, omega_max = float(plan.plant.limits[0]), float(plan.plant.limits[1])
        # IR-SIM's own limits default to +-1: the robot's limits instead (the
        # controller saturates to them already), and no acceleration limit.
        self.robot = self.env.create_robot(
            kinematics={"name": "diff"},
            shape={"name": "circle", "radius": 0.2},
            state=[float(v) for v in plan.initial_state],
            vel_max=[v_max, omega_max],
            vel_min=[-v_max, -omega_max],
        )
        self.env.add_object(self.robot)
        self.limits = (v_max, omega_max)

    def substitutes(self) -> Mapping[Any, Callable[..., Any]]:
        return {disturbances.plant_step: self.plant_step}

    def start(self, state: FloatArray) -> None:
        pass

    def stop(self) -> None:
        self.env.end()

    def report(self) -> dict[str, Any] | None:
        return None

    def describe(self) -> dict[str, Any]:
        return {
            "type": "irsim",
            "versions": {"ir-sim": self.version},
            "settings": {
                "kinematics": "diff",
                "integration": "forward Euler",
                "vel_max": list(self.limits),
                "acce": "none",
            },
        }

    def plant_step(
        self,
        state: FloatArray,
        applied: FloatArray,
        dt: float,
        actuation: Actuation,
        draws: FloatArray,
    ) -> None:
        """wmr_mission.kernels.disturbances.plant_step with IR-SIM's step in
        place of eq. (1)."""
        x = state[0]
        y = state[1]
        theta = state[2]
        v = applied[0]
        if actuation.slip != 0.0:
            v *= 1.0 - actuation.slip
        self.robot.set_state([x, y, theta])  # ours, with what our disturbances added
        self.env.step([v, applied[1]])
        moved = self.robot.state
        state[0] = moved[0, 0]
        state[1] = moved[1, 0]
        state[2] = theta + wrap_angle(moved[2, 0] - theta)  # IR-SIM wraps; ours does not
        skid = draws[SKID]
        if skid != 0.0:
            state[0] -= dt * skid * math.sin(theta)
            state[1] += dt * skid * math.cos(theta)
        for i in range(3):
            if draws[PROCESS_NOISE + i] != 0.0:
                state[i] += draws[PROCESS_NOISE + i]


@contextlib.contextmanager
def open_plant(plan: MissionPlan, settings: Backend) -> Iterator[IrSimPlant]:
    plant = IrSimPlant(plan)
    try:
        yield plant
    finally:
        plant.stop()
