"""The controllers a mission may name: one module each (wmr_mission.controllers.registry).

* ``paper``: the paper's two-component controller, the gain-scheduled LQR of
  eqs. (19)-(21) and the corrective control of eqs. (22)-(28)
  (wmr_mission.controllers.paper), the default.
"""

from __future__ import annotations

from wmr_mission.controllers import paper
from wmr_mission.controllers.registry import CONTROLLERS, ControllerSettings, ControllerType

__all__ = ["CONTROLLERS", "ControllerSettings", "ControllerType"]

# The built-in controllers, in the order the schema lists them.
CONTROLLERS.register(paper.CONTROLLER)
