"""The estimators a mission may name: one module each (wmr_mission.estimators.registry).

* ``constrained-observer``: the paper's two-phase constrained estimator, eqs.
  (4)-(12) (wmr_mission.estimators.observer), the default;
* ``ekf``: a baseline extended Kalman filter (wmr_mission.estimators.ekf);
* ``python``: a plug-in written in Python (wmr_mission.estimators.plugin).
"""

from __future__ import annotations

from wmr_mission.estimators import ekf, observer, plugin
from wmr_mission.estimators.registry import (
    ESTIMATORS,
    EstimatorSettings,
    EstimatorType,
    Measurements,
)

__all__ = ["ESTIMATORS", "EstimatorSettings", "EstimatorType", "Measurements"]

# The built-in estimators, in the order the schema lists them.
ESTIMATORS.register(observer.ESTIMATOR)
ESTIMATORS.register(ekf.ESTIMATOR)
ESTIMATORS.register(plugin.ESTIMATOR)
