"""One run of a campaign: the mission with the run's values set, simulated, reduced to a row.

The mission is loaded exactly as ``wmr-mission run MISSION --set PATH=VALUE
... --seed SEED`` loads it, so that the run's ``replay`` command reproduces
it byte for byte.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Final

import numpy as np

from wmr_mission.campaign.checked import checked_mission, mission_of
from wmr_mission.campaign.comparison import COMPARISON_METRICS, comparison_metrics
from wmr_mission.campaign.load import LoadedCampaign, replay_line, value_text
from wmr_mission.campaign.plan import Draw, Plan
from wmr_mission.campaign.written import Written, WrittenRun, written_runs
from wmr_mission.record import Outcome
from wmr_mission.spec import catalog
from wmr_mission.verdicts import recovery
from wmr_mission.verdicts.check import Check
from wmr_mission.verdicts.metrics import judge_run_metrics, summary_value

if TYPE_CHECKING:
    from wmr_mission.output.result import RunResult

__all__ = [
    "ERROR",
    "INVALID",
    "MARGIN_COLUMNS",
    "METRICS",
    "Row",
    "checked_mission",
    "header",
    "mission_of",
    "replay_command",
    "run_row",
    "run_rows",
    "simulate",
]

INVALID: Final = "invalid"
"""Outcome of a run whose drawn values the mission refuses (a normal draw beyond
the 4 std that `validate` checked)."""

ERROR: Final = "error"
"""Outcome of a run that raised an exception: a bug, reported with the run's replay."""

# The run's metrics: those of the catalog with a column (wmr_mission.spec.catalog:
# the run's, then a phase's worst over the run), computed by the code that
# writes summary.json, then how the robot was driven (a head-to-head's figures,
# wmr_mission.campaign.comparison).
COLUMNS: Final = catalog.columns()
METRICS: Final = (*(m.name for m in COLUMNS), *COMPARISON_METRICS)

# After the metrics: the run's margin and the check that sets it (summary.json's).
MARGIN_COLUMNS: Final = ("margin", "margin_check")

# Points kept of each run's path for the campaign's trajectory figure.
PATH_POINTS: Final = 600
# A row's path where no figure is drawn: one array for every row, so a task's
# rows are sent without a path each (pickle writes a shared object once).
NO_PATH: Final = np.zeros((2, 0), dtype=np.float32)
NO_PATH.flags.writeable = False


@dataclass(frozen=True)
class Row:
    """One line of runs.csv, and what the campaign's figures need of the run."""

    run: int
    seed: int
    outcome: str
    values: tuple[Any, ...]
    metrics: tuple[float | None, ...]
    reason: str
    path_xy: np.ndarray  # (2, <= PATH_POINTS) float32, thinned true path; NO_PATH: none kept
    # the reactions that fired, one kind per firing (wmr_mission.verdicts.recovery.fired)
    fired: tuple[str, ...] = ()
    # the run's margin (wmr_mission.verdicts.check: None for -inf, or +inf without
    # a check), the check or outcome that sets it, and the checks it missed
    margin: float | None = None
    margin_check: str | None = None
    missed: tuple[Check, ...] = ()
    # the metric of the check that sets the margin, or the outcome (summary.json's
    # margin_metric): how campaign.json counts the margins, as data
    margin_metric: str | None = None
    samples: int = 0  # the run's samples (0: not run)
    # how its loop ran (RunRecord.loop_compiled; None: not run): the campaign's
    # manifest says so, a plug-in of plain Python objects running it plain
    loop_compiled: bool | None = None

    @property
    def succeeded(self) -> bool:
        return self.outcome == _SUCCESS

    def cells(self) -> list[str]:
        return [
            str(self.run),
            str(self.seed),
            self.outcome,
            *(_cell(v) for v in self.values),
            *("" if m is None else repr(m) for m in self.metrics),
            "" if self.margin is None else repr(self.margin),
            self.margin_check or "",
            self.reason,
        ]


_SUCCESS: Final = Outcome.success.value


def _cell(value: Any) -> str:
    """A drawn value's cell: its text (value_text), a finite float's written
    by ``repr`` as JSON writes it, without JSON's encoder (a tenth of the
    sweep's own time a row)."""
    if type(value) is float and math.isfinite(value):
        return repr(value)
    return value if isinstance(value, str) else value_text(value)


def header(paths: Sequence[str]) -> list[str]:
    return ["run", "seed", "outcome", *paths, *METRICS, *MARGIN_COLUMNS, "reason"]


def simulate(loaded: LoadedCampaign, draw: Draw) -> tuple[RunResult | None, str]:
    """The run as its ``replay`` command runs it, for its run directory (None
    when the mission refuses its values, with the reason)."""
    from wmr_mission.sim.runner import run_mission

    mission, reason = checked_mission(loaded, draw)
    if mission is None:
        return None, reason
    return _uninterrupted(run_mission(mission, seed=draw.seed)), ""


def _uninterrupted(result: RunResult) -> RunResult:
    """A campaign's run is never cut short: a Ctrl-C that ``run_mission`` turned
    into an ``interrupted`` result stops the campaign, not the run, whose row
    or directory would no longer be what its ``replay`` gives."""
    if result.outcome is Outcome.interrupted:
        raise KeyboardInterrupt
    return result


def _not_run(draw: Draw, outcome: str, reason: str) -> Row:
    values = tuple(draw.values.values())
    metrics = (None,) * len(METRICS)
    return Row(
        draw.run,
        draw.seed,
        outcome,
        values,
        metrics,
        reason,
        NO_PATH,
        margin_check=outcome,
        margin_metric=outcome,
    )


def run_row(
    loaded: LoadedCampaign, draw: Draw, written: WrittenRun | None = None, path: bool = True
) -> Row:
    """One run reduced to its row: simulated and judged as ``run_mission`` does
    (the same samples, the same outcome), its metrics from the code of summary.json.

    The mission is checked and planned once per combination of the campaign's
    choice and grid values, each run's drawn pose written into a copy of its
    plan (wmr_mission.campaign.written); ``written``: that, made beforehand.
    ``path``: whether the row keeps the run's thinned path, which only the
    campaign's trajectory figure draws (else NO_PATH)."""
    from wmr_mission.sim.runner import run_mission

    plan, summary_mission, reason = written_runs(loaded).run(draw) if written is None else written
    if plan is None:
        return _not_run(draw, INVALID, reason)
    result = _uninterrupted(run_mission(plan))
    summary = judge_run_metrics(result, summary_mission)
    metrics = (
        *(summary_value(summary, metric.run_path) for metric in COLUMNS),
        *comparison_metrics(result, summary_mission),
    )
    path_xy = _thinned_path(result) if path else NO_PATH
    reason = "" if result.outcome is Outcome.success else result.message
    values = tuple(draw.values.values())
    fired = tuple(kind for tr in result.transitions for kind in recovery.fired(tr))
    missed = tuple(Check.read(record) for record in summary.get("missed") or [])
    return Row(
        draw.run,
        draw.seed,
        result.outcome.value,
        values,
        metrics,
        reason,
        path_xy,
        fired,
        summary["margin"],
        summary["margin_check"],
        missed,
        summary["margin_metric"],
        result.samples,
        result.loop_compiled,
    )


def _thinned_path(result: RunResult) -> np.ndarray:
    step = max(1, math.ceil(result.samples / PATH_POINTS))
    return np.vstack([result.x[::step], result.y[::step]]).astype(np.float32)


def run_rows(loaded: LoadedCampaign, start: int, stop: int, paths: bool = True) -> list[Row]:
    """Rows of runs ``start .. stop - 1``: one task of a worker; ``paths``:
    whether they keep their paths (run_row: a campaign that draws no figure
    sends none, some 4 KB a row).

    Its runs are drawn and written into their plans first, then simulated one
    after another: drawn and written right after a run's simulation and
    judging, whose code and arrays have pushed theirs out of the caches, each
    cost several times as much (4-5 % of a case-2 row, docs/performance.md)."""
    plan = Plan(loaded.campaign)
    runs = written_runs(loaded)
    draws = [plan.draw(run) for run in range(start, stop)]
    made = [_written(runs, draw) for draw in draws]
    rows = []
    for draw, written in zip(draws, made, strict=True):
        try:
            if isinstance(written, Exception):
                raise written
            rows.append(run_row(loaded, draw, written, paths))
        except Exception as error:  # one run's fault must not lose the campaign
            reason = f"internal error ({type(error).__name__}: {error}); please report it"
            rows.append(_not_run(draw, ERROR, reason))
    return rows


def _written(runs: Written, draw: Draw) -> WrittenRun | Exception:
    """The run's plan and record (Written.run), or the exception that made
    them fail: said in the run's row, as a fault in its simulation is."""
    try:
        return runs.run(draw)
    except Exception as error:
        return error


def replay_command(loaded: LoadedCampaign, draw: Draw) -> str:
    """The one-line ``wmr-mission run`` command that reproduces a run byte for byte
    (in an environment of the same fingerprint: ``run`` warns in another)."""
    from wmr_mission.output.environment import own_fingerprint

    return replay_line(
        str(loaded.mission_path),
        loaded.setting_texts(),
        draw.values,
        draw.seed,
        own_fingerprint(),
        loaded.mission_sha256,
    )
