"""Declarative YAML missions for wheeled non-holonomic mobile robots.

The controller and estimator follow "A New On-line Observer-Based Controller
for Wheeled Non-holonomic Mobile Robots"; ``docs/paper-notes.md`` maps each of
its equations to the code. The Python API (``docs/python-api.md``):

* ``load_mission``, ``mission_from_text``, ``mission_from_dict``: a checked mission;
* ``run_mission``: check, simulate and judge it; a ``RunResult``;
* ``start_mission``: the same run step by step, its path or target changed between steps;
* ``plot_verdicts`` (what judged the run), ``plot_xy``, ``plot_states``,
  ``plot_estimation_error``, ``plot_inputs``: figures;
* ``run_campaign``: a campaign (``docs/campaigns.md``): its rows and statistics;
* ``falsify_campaign``: a search of a campaign's axes for failing runs (``docs/falsification.md``);
* ``load_run``: a run directory read back; ``MissionError``: what every check raises.
"""

from __future__ import annotations

import importlib

from wmr_mission.version import __version__

# Not typing's: the package's first lines run before the program's first
# module (wmr_mission._start) gives Ctrl-C its default action, and importing
# typing there was most of that time. Type checkers take any TYPE_CHECKING as true.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from typing import Any

    from wmr_mission.api import (
        MissionError,
        falsify_campaign,
        load_mission,
        load_run,
        mission_from_dict,
        mission_from_text,
        run_mission,
        start_mission,
    )
    from wmr_mission.campaign.sweep import run_campaign
    from wmr_mission.output.figures import (
        plot_estimation_error,
        plot_inputs,
        plot_states,
        plot_verdicts,
        plot_xy,
    )
    from wmr_mission.output.result import RunResult
    from wmr_mission.spec.models import Mission

# Lazy: `wmr-mission validate` and `--help` must not pay for numpy/scipy/matplotlib.
_WHERE = {
    "MissionError": "wmr_mission.api",
    "falsify_campaign": "wmr_mission.api",
    "load_mission": "wmr_mission.api",
    "load_run": "wmr_mission.api",
    "mission_from_dict": "wmr_mission.api",
    "mission_from_text": "wmr_mission.api",
    "run_mission": "wmr_mission.api",
    "start_mission": "wmr_mission.api",
    "plot_xy": "wmr_mission.output.figures",
    "plot_states": "wmr_mission.output.figures",
    "plot_estimation_error": "wmr_mission.output.figures",
    "plot_inputs": "wmr_mission.output.figures",
    "plot_verdicts": "wmr_mission.output.figures",
    "run_campaign": "wmr_mission.campaign.sweep",
    "RunResult": "wmr_mission.output.result",
    "Mission": "wmr_mission.spec.models",
}

__all__ = [
    "Mission",
    "MissionError",
    "RunResult",
    "__version__",
    "falsify_campaign",
    "load_mission",
    "load_run",
    "mission_from_dict",
    "mission_from_text",
    "plot_estimation_error",
    "plot_inputs",
    "plot_states",
    "plot_verdicts",
    "plot_xy",
    "run_campaign",
    "run_mission",
    "start_mission",
]


def __getattr__(name: str) -> Any:
    module = _WHERE.get(name)
    if module is None:
        raise AttributeError(f"module 'wmr_mission' has no attribute {name!r}")
    return getattr(importlib.import_module(module), name)


def __dir__() -> list[str]:
    # The lazy names too, so that dir() and tab completion show them.
    return sorted(set(globals()) | set(__all__))
