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
from wmr_mission.verdicts.clearance import region_geometry

# A robot needs a world; ours has no border that stops it, and the mission's
# keep-out zones as obstacles (:func:`obstacles`).
WORLD = "world: {{height: 1000, width: 1000, step_time: {dt!r}}}\n"
# Corners of the polygon an ellipse zone becomes in IR-SIM (inscribed: 1.2e-4
# of its semi-major axis inside it at most; IR-SIM checks collisions per corner).
ELLIPSE_CORNERS = 144
# The disc IR-SIM draws a robot without robot.footprint as [m]: a point, as
# far as a disc can be.
POINT_RADIUS = 0.01


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
        self.shape = robot_shape(plan.footprint)
        self.robot = self.env.create_robot(
            kinematics={"name": "diff"},
            shape=self.shape,
            state=[float(v) for v in plan.initial_state],
            vel_max=[v_max, omega_max],
            vel_min=[-v_max, -omega_max],
        )
        self.env.add_object(self.robot)  # first: IR-SIM steps its first object with the input
        self.obstacles = obstacles(plan)
        for _, shape, state in self.obstacles:
            self.env.add_object(self.env.create_obstacle(shape=shape, state=state))
        self.limits = (v_max, omega_max)
        self.collided = False

    def substitutes(self) -> Mapping[Any, Callable[..., Any]]:
        return {disturbances.plant_step: self.plant_step}

    def start(self, state: FloatArray) -> None:
        pass

    def stop(self) -> None:
        self.env.end()

    def confirm_stop(self) -> None:
        pass

    def report(self) -> dict[str, Any] | None:
        return None

    def obstacle_geometries(self) -> list[Any]:
        """The shapely geometry of each obstacle of IR-SIM's world, in its order."""
        return [obstacle.geometry for obstacle in self.env.obstacle_list]

    def describe(self) -> dict[str, Any]:
        return {
            "type": "irsim",
            "versions": {"ir-sim": self.version},
            "settings": {
                "kinematics": "diff",
                "integration": "forward Euler",
                "vel_max": list(self.limits),
                "acce": "none",
                "robot_shape": self.shape,
                "obstacles": [name for name, _, _ in self.obstacles],
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
        self.collided |= bool(self.robot.collision_flag)  # IR-SIM's own word on the zones
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


def obstacles(plan: MissionPlan) -> list[tuple[str, dict[str, Any], list[float]]]:
    """(region name, IR-SIM shape, state) of each region a phase keeps out of:
    a circle as a circle, an ellipse as a polygon of ELLIPSE_CORNERS corners,
    a box or polygon as its corners. A half-plane has no bound an obstacle can
    have, and is left out."""
    names = sorted(
        {name for phase in plan.phases for name, side in phase.constraints if side == "outside"}
    )
    found = []
    for name in names:
        region = plan.regions[name]
        if region["type"] == "half-plane":
            continue
        if region["type"] == "circle":
            cx, cy = (float(v) for v in region["center"])  # type: ignore[attr-defined]
            radius = float(region["radius"])  # type: ignore[arg-type]
            found.append((name, {"name": "circle", "radius": radius}, [cx, cy, 0.0]))
            continue
        outline = region_geometry(region, ELLIPSE_CORNERS).exterior.coords[:-1]
        corners = [[float(x), float(y)] for x, y in outline]
        found.append((name, {"name": "polygon", "vertices": corners}, [0.0, 0.0, 0.0]))
    return found


def robot_shape(footprint: Mapping[str, Any] | None) -> dict[str, Any]:
    """IR-SIM's shape of the robot: its footprint, or a disc of POINT_RADIUS."""
    if footprint is None:
        return {"name": "circle", "radius": POINT_RADIUS}
    if "radius" in footprint:
        return {"name": "circle", "radius": float(footprint["radius"])}
    return {"name": "polygon", "vertices": [[float(x), float(y)] for x, y in footprint["polygon"]]}


@contextlib.contextmanager
def open_plant(plan: MissionPlan, settings: Backend) -> Iterator[IrSimPlant]:
    plant = IrSimPlant(plan)
    try:
        yield plant
    finally:
        plant.stop()
