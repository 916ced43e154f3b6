"""Plants other than our simulator: IR-SIM, and a robot over ROS 2 (docs/backends.md).

A backend is the plant side of a run (wmr_mission.sim.plant_side): it applies
(v, omega), gives a timestamped measurement and says what time it is; the
mission's phases, estimator, controller, verdicts and recording stay ours.
Each backend is one module, imported only when chosen, with the optional
package it needs (`pip install 'wmr-mission[irsim]'`, `'wmr-mission[ros2]'`).
"""

from wmr_mission.backends.registry import BACKENDS, BackendError, open_backend

__all__ = ["BACKENDS", "BackendError", "open_backend"]
