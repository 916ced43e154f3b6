"""The controllers a mission may name: one module each (wmr_mission.controllers.registry).

* ``paper``: the paper's two-component controller, the gain-scheduled LQR of
  eqs. (19)-(21) and the corrective control of eqs. (22)-(28)
  (wmr_mission.controllers.paper), the default;
* ``pure-pursuit``: geometric pure pursuit (wmr_mission.controllers.pure_pursuit);
* ``kanayama``: Kanayama's tracking law (wmr_mission.controllers.kanayama);
* ``python``: a plug-in written in Python (wmr_mission.controllers.plugin);

the two baselines regulate with the paper's regulator.
"""

from __future__ import annotations

from wmr_mission.controllers import kanayama, paper, plugin, pure_pursuit
from wmr_mission.controllers.registry import CONTROLLERS, ControllerSettings, ControllerType

__all__ = ["CONTROLLERS", "ControllerSettings", "ControllerType"]

# The built-in controllers, in the order the schema lists them.
CONTROLLERS.register(paper.CONTROLLER)
CONTROLLERS.register(pure_pursuit.CONTROLLER)
CONTROLLERS.register(kanayama.CONTROLLER)
CONTROLLERS.register(plugin.CONTROLLER)
