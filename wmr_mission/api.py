"""The Python API: build or load a mission, run it, look at the result.

Every way in checks a mission exactly as ``wmr-mission validate`` checks a
file, and raises :class:`MissionError` carrying every diagnostic. Overrides
use the dotted paths of ``wmr-mission run --set``. ``docs/python-api.md`` shows
each function at work.
"""

from __future__ import annotations

import numbers
import os
import sys
from collections.abc import Mapping
from typing import TYPE_CHECKING, Any

from wmr_mission.campaign.falsify import DEFAULT_METHOD
from wmr_mission.spec import loader
from wmr_mission.spec.loader import MissionError

if TYPE_CHECKING:
    from wmr_mission.campaign.falsify.command import FalsifyResult
    from wmr_mission.output.result import RunResult
    from wmr_mission.sim.session import Session
    from wmr_mission.spec.models import Mission

__all__ = [
    "MissionError",
    "falsify_campaign",
    "load_mission",
    "load_run",
    "mission_from_dict",
    "mission_from_text",
    "run_mission",
    "start_mission",
]


def load_mission(
    path: str | os.PathLike[str], overrides: Mapping[str, Any] | None = None
) -> Mission:
    """The mission of a YAML file, with ``overrides`` (dotted path -> value) applied.

    Raises :class:`MissionError` with every problem, as ``validate`` reports them.
    """
    return loader.load_mission(os.fspath(path), loader.overrides_of(overrides))


def mission_from_text(
    text: str, overrides: Mapping[str, Any] | None = None, *, filename: str = "<text>"
) -> Mission:
    """The mission of a YAML text; messages give ``filename:LINE:COL``."""
    if not isinstance(text, str):
        raise TypeError(
            f"mission_from_text takes the YAML text as a str, got {type(text).__name__}"
            + (" (decode it, or give the file to load_mission)" if isinstance(text, bytes) else "")
        )
    return loader.load_mission_text(text, filename, loader.overrides_of(overrides))


def mission_from_dict(
    data: Mapping[str, Any], overrides: Mapping[str, Any] | None = None
) -> Mission:
    """The mission of plain data (what ``yaml.safe_load`` of a mission file gives)."""
    if not isinstance(data, Mapping):
        raise TypeError(
            f"mission_from_dict takes a mapping (version, name, ..., phases), "
            f"got {type(data).__name__}"
        )
    return loader.load_mission_data(dict(data), "<dict>", loader.overrides_of(overrides))


def run_mission(mission: Mission, *, seed: int | None = None) -> RunResult:
    """Check ``mission`` as a file would be checked, simulate it and judge it by its ``expect``.

    ``seed`` overrides the mission's seed (of every random draw). Raises
    :class:`MissionError` when the mission is invalid (e.g. a copy made with
    ``model_copy(update=...)``, which pydantic does not validate).
    """
    from wmr_mission.sim.runner import run_mission as simulate
    from wmr_mission.spec.models import Mission

    if not isinstance(mission, Mission):
        raise TypeError(
            f"run_mission takes a Mission (from load_mission, mission_from_text or "
            f"mission_from_dict), got {type(mission).__name__}"
        )
    checked = None if seed is None else _checked_seed(seed)
    _compile_notice()
    return simulate(mission, seed=checked)


def start_mission(mission: Mission, *, seed: int | None = None) -> Session:
    """A run of ``mission`` to drive step by step: ``session.step(n)``,
    ``session.set_path(...)``, ``session.result()`` (docs/python-api.md, "A
    mission step by step"). Checked as :func:`run_mission` checks it; the loop is
    loaded (or compiled) before it returns, at sample 0.
    """
    from wmr_mission.sim.session import Session
    from wmr_mission.spec.models import Mission

    if not isinstance(mission, Mission):
        raise TypeError(
            f"start_mission takes a Mission (from load_mission, mission_from_text or "
            f"mission_from_dict), got {type(mission).__name__}"
        )
    checked = None if seed is None else _checked_seed(seed)
    _compile_notice()
    return Session(mission, checked)


_noticed: list[bool] = []  # the compile notice is printed once per process


def _compile_notice() -> None:
    """One line on stderr before the first run compiles the loop in the foreground."""
    from wmr_mission.kernels.jit import foreground_notice

    if _noticed:
        return
    notice = foreground_notice()
    if notice is not None:
        _noticed.append(True)
        print(notice, file=sys.stderr, flush=True)


def _checked_seed(seed: object) -> int:
    """A sensor seed is an integer in 0 .. 2^32 - 1, as ``--seed`` and ``sensors.seed``
    take it: TypeError or ValueError otherwise."""
    from wmr_mission.fields import LARGEST_SEED

    if isinstance(seed, bool) or not isinstance(seed, numbers.Integral):
        raise TypeError(f"seed is an integer in 0 .. {LARGEST_SEED}, got {seed!r}")
    value = int(seed)
    if not 0 <= value <= LARGEST_SEED:
        raise ValueError(f"seed is an integer in 0 .. {LARGEST_SEED}, got {value}")
    return value


def load_run(run_dir: str | os.PathLike[str]) -> RunResult:
    """The :class:`RunResult` of a run directory written by ``run`` or ``RunResult.write``."""
    from wmr_mission.output.reader import load_run as read

    return read(run_dir)


def falsify_campaign(
    campaign: str | os.PathLike[str],
    *,
    budget: int = 300,
    method: str = DEFAULT_METHOD,
    seed: int | None = None,
    objective: str | None = None,
    first: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    out: str | os.PathLike[str] | None = None,
    plots: bool = False,
) -> FalsifyResult:
    """Search a campaign's axes for failing runs, as ``wmr-mission falsify`` does
    (docs/falsification.md); the evaluations in order and falsify.json's record.

    ``method``: ``gp``, ``cmaes`` or ``random``; ``seed`` (default: the campaign's)
    seeds the search and each run's sensors; ``objective``: a check
    (``phase: metric``, or a metric) whose margin is minimised instead of the
    run's; ``first``: stop after the batch holding the first failing run;
    ``out``: also write the directory (figures when ``plots``). Raises
    :class:`MissionError` for an invalid file, ValueError for a bad setting.
    """
    from wmr_mission.campaign.falsify.command import falsify_campaign as falsify

    return falsify(
        os.fspath(campaign),
        budget=budget,
        method=method,
        seed=seed,
        objective=objective,
        first=first,
        workers=workers,
        scheduler=scheduler,
        out=None if out is None else os.fspath(out),
        plots=plots,
    )
