"""Declarative YAML missions for wheeled non-holonomic mobile robots.

The controller and estimator follow "A New On-line Observer-Based Controller
for Wheeled Non-holonomic Mobile Robots"; ``docs/paper-notes.md`` maps each of
its equations to the code.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

__version__ = "0.1.0"

if TYPE_CHECKING:
    from wmr_mission.campaign.sweep import run_campaign
    from wmr_mission.result import RunResult
    from wmr_mission.runner import run_mission
    from wmr_mission.spec.loader import load_mission

__all__ = ["RunResult", "__version__", "load_mission", "run_campaign", "run_mission"]


def __getattr__(name: str) -> Any:
    # Lazy: `wmr-mission validate` and `--help` must not pay for numpy/scipy/matplotlib.
    if name == "load_mission":
        from wmr_mission.spec.loader import load_mission

        return load_mission
    if name == "run_mission":
        from wmr_mission.runner import run_mission

        return run_mission
    if name == "run_campaign":
        from wmr_mission.campaign.sweep import run_campaign

        return run_campaign
    if name == "RunResult":
        from wmr_mission.result import RunResult

        return RunResult
    raise AttributeError(name)
