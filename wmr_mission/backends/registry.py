"""The backends by name, each opened as a context manager around one run."""

from __future__ import annotations

import importlib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass

from wmr_mission.sim.plan import MissionPlan
from wmr_mission.sim.plant_side import PlantSide
from wmr_mission.spec.backend import Backend


class BackendError(Exception):
    """A backend that cannot be used: its extra is not installed, or its robot
    never answered. The message is one line, with what to do."""


@dataclass(frozen=True)
class BackendType:
    name: str
    module: str  # the package's own module: names fixed here, never from a mission
    needs: str  # what its extra installs, for the message when it is missing


BACKENDS: dict[str, BackendType] = {
    "irsim": BackendType("irsim", "wmr_mission.backends.irsim", "IR-SIM (ir-sim)"),
    "ros2": BackendType("ros2", "wmr_mission.backends.ros2", "ROS 2's rclpy and messages"),
}


def missing(name: str, error: ImportError) -> BackendError:
    """The one line said when a backend's extra is not installed."""
    what = BACKENDS[name].needs
    return BackendError(
        f"the {name} backend needs {what} ({error}): pip install 'wmr-mission[{name}]'"
    )


@contextmanager
def open_backend(name: str, plan: MissionPlan, settings: Backend) -> Iterator[PlantSide]:
    """The plant side of backend ``name`` for one run of ``plan``; closed (a
    zero command first, for a robot) on every way out."""
    if name not in BACKENDS:
        raise BackendError(f"unknown backend {name!r}; expected sim, {', '.join(BACKENDS)}")
    module = importlib.import_module(BACKENDS[name].module)
    with module.open_plant(plan, settings) as plant:
        yield plant
