"""``wmr-mission sweep`` and :func:`run_campaign`: run a campaign, write its outputs.

Outputs (DESIGN "Campaigns"): ``runs.csv`` written as tasks finish, in run
order, ``campaign.json`` (statistics, worst runs and their replay commands,
throughput), ``manifest.json``, ``worst/RUN/`` run directories (re-simulated
at the end) and the figures.

What stops a campaign early never loses a finished run (docs/reliability.md,
"Campaigns"): a signal (SIGINT, SIGTERM) stops it between two tasks, a write
that fails (a full disk) stops it at the last complete row, and either way
``runs.csv`` holds every finished run and ``campaign.json`` says why it
stopped. A campaign stopped before its first run leaves nothing behind, so
that the same ``--out`` can be used again.
"""

from __future__ import annotations

import math
import shutil
import sys
import time
from collections.abc import Mapping, Sequence
from contextlib import closing, suppress
from dataclasses import dataclass, field
from datetime import datetime
from pathlib import Path
from typing import IO, Any, Final

from wmr_mission.campaign.aggregate import Aggregate
from wmr_mission.campaign.engine import (
    DASK_LOGS,
    Interrupted,
    SchedulerLost,
    SchedulerUnavailable,
    execute,
    local_pool,
    one_line,
    reach_scheduler,
    silence,
    usable_workers,
    warm_up,
)
from wmr_mission.campaign.load import LoadedCampaign, check_campaign, load_campaign, value_text
from wmr_mission.campaign.models import Campaign
from wmr_mission.campaign.plan import Plan
from wmr_mission.campaign.recovery import recovery_report
from wmr_mission.campaign.rows import METRICS, Row, header, replay_command, simulate
from wmr_mission.campaign.stops import stoppable
from wmr_mission.kernels import jit
from wmr_mission.output.environment import environment, package_versions
from wmr_mission.output.files import RowsFile, json_text, write_bytes_atomic
from wmr_mission.output.progress import Steps
from wmr_mission.output.rundir import (
    SUMMARY_FILE,
    RunDirExistsError,
    default_run_dir,
    drop_claim,
    loop_build,
    prepare_run_dir,
    release_run_dir,
    write_run,
)
from wmr_mission.spec import catalog
from wmr_mission.spec.checks import importing_entries
from wmr_mission.spec.loader import overrides_of, overrides_of_texts
from wmr_mission.stopping import GENTLE, HOLD, RAISE, StopSignals, stop_owed
from wmr_mission.terminal import shown
from wmr_mission.verdicts.check import beside

__all__ = ["CampaignResult", "run_campaign", "sweep_command"]

RUNS_FILE: Final = "runs.csv"
CAMPAIGN_FILE: Final = "campaign.json"
MANIFEST_FILE: Final = "manifest.json"
WORST_DIR: Final = "worst"
CELLS_LISTED: Final = 100  # grid cells without runs named in campaign.json, at most
CELLS_SHOWN: Final = 10  # ... and in the sweep's report
EXIT_FAILED: Final = 1  # an invalid file, an expect not met, a worker lost, a fault in drawing
EXIT_OUTPUT: Final = 2  # a usage error: an unusable --out or scheduler, a write that fails
INTERRUPTED_NOTICE: Final = "interrupted: stopping; the finished runs are kept"
LOAD_EARLY_AFTER_SECONDS: Final = 2.0
"""Runs that last longer on the workers (estimated) have matplotlib loaded, for
the figures, while they run: the workers have tasks queued for the time it
takes (about 0.4 s), and no core waits for it after them. Shorter campaigns
load it after their runs, so that it never counts in their runs' time."""


@dataclass(repr=False)
class CampaignResult:
    """What :func:`run_campaign` returns: the rows and the aggregate (campaign.json)."""

    rows: list[dict[str, Any]]  # one per run, in run order, keyed as runs.csv's columns
    summary: dict[str, Any]
    out_dir: Path | None
    columns: list[str] = field(default_factory=list)  # runs.csv's, in order

    def to_dataframe(self) -> Any:
        """The rows as a pandas DataFrame, columns as in ``runs.csv``. Needs pandas."""
        try:
            import pandas
        except ImportError:
            raise ImportError(
                "CampaignResult.to_dataframe needs pandas: pip install 'wmr-mission[dataframe]'"
            ) from None
        return pandas.DataFrame(self.rows, columns=self.columns or None)

    def __repr__(self) -> str:
        summary = self.summary
        return (
            f"CampaignResult(campaign={summary.get('campaign')!r}, runs={summary.get('runs')}, "
            f"succeeded={summary.get('succeeded')}, out_dir={self.out_dir!r})"
        )


def _runs_detail(aggregate: Aggregate, total: int, started: float) -> str:
    """Runs done of ``total``, the success rate so far and the time left."""
    done = aggregate.runs
    rate = aggregate.succeeded / done if done else 0.0
    left = (time.perf_counter() - started) / done * (total - done) if done else math.nan
    return f"{done}/{total} runs, success {rate:.1%}, {left:.0f} s left"


@dataclass
class _Fault:
    """What could not be written or drawn: one line for stderr, an exit code,
    and the exception, which :func:`run_campaign` raises."""

    message: str
    code: int
    error: BaseException


@dataclass
class _Runs:
    """What the runs gave, and why they stopped before the end (None: they did
    not); ``interrupted``: by a signal (Ctrl-C, SIGTERM)."""

    aggregate: Aggregate
    stopped_by: str | None
    interrupted: bool
    fault: _Fault | None
    startup_seconds: float
    runs_seconds: float
    loop_compiled: bool | None  # how the warm-up's run ran (WarmUp), for the manifest


def _execute(
    loaded: LoadedCampaign,
    *,
    runs_file: RowsFile | None,
    workers: int,
    scheduler: str | None,
    plots: bool,
    progress: Steps,
    keep_rows: list[dict[str, Any]] | None,
    stop: StopSignals,
    allow_mixed_cluster: bool,
) -> _Runs:
    """Run every run, each task's rows into ``runs_file`` (none when None).

    A signal before the runs (during the warm-up) raises KeyboardInterrupt:
    nothing was run. During them, the first one stops them between two tasks;
    after them, signals are held (``stop.mode``) for the record to be written.
    """
    plan = Plan(loaded.campaign)
    aggregate = Aggregate(dict(loaded.campaign.vary))
    columns = header(plan.paths)
    stopped_by: str | None = None
    interrupted = False
    fault: _Fault | None = None
    started = time.perf_counter()
    progress.step("starting")  # the kernels loaded, a run timed, the workers started
    notice = jit.foreground_notice()  # a compile of a minute or more: said before it
    if notice is not None:
        progress.note(notice)
    seconds_per_run, loop_compiled = warm_up(loaded, None if scheduler is not None else workers)
    if stop_owed():  # raised inside numba's compiler, where it could not propagate
        raise KeyboardInterrupt  # before the first run: nothing to keep
    load_early = (
        plots
        and runs_file is not None
        and scheduler is None
        and workers > 1
        and len(plan) * seconds_per_run / workers > LOAD_EARLY_AFTER_SECONDS
    )
    runs_started = time.perf_counter()
    progress.step("runs", total=len(plan))
    try:
        stop.mode = GENTLE
        with closing(
            execute(
                loaded,
                workers=workers,
                scheduler=scheduler,
                seconds_per_run=seconds_per_run,
                stop=stop,
                allow_mixed_cluster=allow_mixed_cluster,
                paths=plots,
            )
        ) as batches:
            for rows in batches:
                if load_early:  # while the workers run: no core waits for it
                    _load_matplotlib()
                    load_early = False
                if runs_file is not None:
                    try:
                        runs_file.append([row.cells() for row in rows])
                    except OSError as error:  # the complete rows so far are kept; stop
                        fault = _Fault(_cannot_write(error), EXIT_OUTPUT, error)
                        _take(rows[: runs_file.kept], aggregate, keep_rows, columns)
                        break
                _take(rows, aggregate, keep_rows, columns)
                progress.update(aggregate.runs, _runs_detail(aggregate, len(plan), runs_started))
    except (Interrupted, KeyboardInterrupt):  # a second signal stops at once
        if not stop.stopped:  # else said as the signal came (stop.notify)
            progress.say(INTERRUPTED_NOTICE)
        interrupted = True
    except SchedulerUnavailable:
        raise
    except SchedulerLost as error:  # keep what finished
        stopped_by = str(error)
    except Exception as error:  # a worker lost: keep what finished
        stopped_by = one_line(error)
    finally:
        stop.mode = HOLD  # what ran is written whole, whatever signal comes
    runs_seconds = time.perf_counter() - runs_started
    if fault is not None:
        stopped_by = fault.message
    elif interrupted or stop.stopped:  # also a signal after the last task: the rest is left
        interrupted = True
        stopped_by = stop.name
    return _Runs(
        aggregate,
        stopped_by,
        interrupted,
        fault,
        runs_started - started,
        runs_seconds,
        loop_compiled,
    )


def _cannot_write(error: OSError) -> str:
    return f"{error.filename}: cannot write: {error.strerror or error}"


def _campaign(
    loaded: LoadedCampaign,
    *,
    out_dir: Path | None,
    workers: int,
    scheduler: str | None,
    plots: bool,
    progress_stream: IO[str] | None,
    keep_rows: list[dict[str, Any]] | None,
    stop: StopSignals,
    allow_mixed_cluster: bool = False,
) -> _Ended:
    """Run the campaign and write its directory (none when ``out_dir`` is None);
    its steps are shown on ``progress_stream`` if a terminal."""
    progress = Steps(progress_stream)
    stop.notify = lambda: progress.say(INTERRUPTED_NOTICE)
    try:
        return _campaign_steps(
            loaded, out_dir, workers, scheduler, plots, progress, keep_rows, stop,
            allow_mixed_cluster,
        )  # fmt: skip
    finally:
        stop.notify = None
        progress.close()


def _campaign_steps(
    loaded: LoadedCampaign,
    out_dir: Path | None,
    workers: int,
    scheduler: str | None,
    plots: bool,
    progress: Steps,
    keep_rows: list[dict[str, Any]] | None,
    stop: StopSignals,
    allow_mixed_cluster: bool,
) -> _Ended:
    plan = Plan(loaded.campaign)
    runs_file = None if out_dir is None else RowsFile(out_dir / RUNS_FILE, header(plan.paths))
    try:
        try:
            runs = _execute(
                loaded,
                runs_file=runs_file,
                workers=workers,
                scheduler=scheduler,
                plots=plots,
                progress=progress,
                keep_rows=keep_rows,
                stop=stop,
                allow_mixed_cluster=allow_mixed_cluster,
            )
        except BaseException:  # before the first run (a signal while compiling, no
            if runs_file is not None:  # scheduler): nothing to keep, a retry may use --out
                runs_file.close()
                runs_file = None
            if out_dir is not None:
                _discard(out_dir)
            raise
        record = _record(loaded, runs.aggregate, runs.stopped_by, runs.runs_seconds, len(plan))
        record["startup_seconds"] = runs.startup_seconds
        record["workers"] = None if scheduler is not None else workers
        record["scheduler"] = scheduler
        if out_dir is None or runs_file is None:
            return _Ended(record, [], runs.fault, runs.interrupted)
        notices: list[str] = []
        try:  # signals held (stop.mode): the record of what ran is written whole
            if runs_file.finish():
                notices.append(
                    f"{out_dir}: removed during the sweep; written again, with its "
                    f"{runs.aggregate.runs} runs"
                )
            # Again, now that the warm-up has compiled the loop (or not): the
            # manifest says how the runs ran, not how the process started.
            workers_asked = None if scheduler else workers
            manifest = _manifest(loaded, workers_asked, scheduler, runs.loop_compiled)
            write_bytes_atomic(out_dir / MANIFEST_FILE, json_text(manifest).encode("utf-8"))
            _write_record(out_dir, record)
        except OSError as error:
            message = (
                f"{error.filename or out_dir}: cannot write: {error.strerror or error}; "
                f"runs.csv holds the {runs.aggregate.runs} runs done"
            )
            if runs.fault is not None:
                message = f"{runs.fault.message}; {message}"
            return _Ended(record, notices, _Fault(message, EXIT_OUTPUT, error), False)
        if runs.fault is not None:
            message = (
                f"{runs.fault.message}; the campaign stopped after {runs.aggregate.runs} runs, "
                f"which runs.csv and campaign.json hold"
            )
            return _Ended(record, notices, _Fault(message, EXIT_OUTPUT, runs.fault.error), False)
        if runs.interrupted or stop.stopped:  # worst runs and figures are left: a stop is quick
            if not record["interrupted"]:  # a signal while campaign.json was written
                _stopped(record, stop, out_dir)
            return _Ended(record, notices, None, True)
        progress.step("worst runs and figures" if plots else "worst runs")
        stop.mode = RAISE  # a signal stops the worst runs and the figures at once
        fault = _worst_and_figures(loaded, record, runs.aggregate, out_dir, plots, workers, stop)
        return _Ended(record, notices, fault, record["stopped_by"] == stop.name)
    finally:
        if runs_file is not None:
            runs_file.close()
        if out_dir is not None:
            drop_claim(out_dir)  # the record is written


@dataclass
class _Ended:
    """How a campaign ended: campaign.json, notices for stderr, the fault that
    stopped it (if one did), and whether a signal stopped it."""

    record: dict[str, Any]
    notices: list[str]
    fault: _Fault | None
    interrupted: bool


def _write_record(out_dir: Path, record: dict[str, Any]) -> None:
    write_bytes_atomic(out_dir / CAMPAIGN_FILE, json_text(record).encode("utf-8"))


def _stopped(record: dict[str, Any], stop: StopSignals, out_dir: Path) -> None:
    """Mark the record stopped by a signal that came after the runs, and write it."""
    stop.mode = HOLD
    record["interrupted"] = True
    record["stopped_by"] = stop.name
    _write_record(out_dir, record)


def _worst_and_figures(
    loaded: LoadedCampaign,
    record: dict[str, Any],
    aggregate: Aggregate,
    out_dir: Path,
    plots: bool,
    workers: int,
    stop: StopSignals,
) -> _Fault | None:
    """worst/ and the figures, after campaign.json: a fault here costs only them."""
    kept = f"runs.csv and campaign.json are in {out_dir}"
    drawn: list[bool] = []
    try:
        _write_worst(loaded, record, aggregate, out_dir, plots, workers, drawn)
    except KeyboardInterrupt:  # every run is in runs.csv; the worst runs' directories stop
        _not_written(record, out_dir, figures=False)
        _stopped(record, stop, out_dir)
    except OSError as error:
        lost = _not_written(record, out_dir, figures=plots and bool(aggregate.runs) and not drawn)
        return _Fault(f"{_cannot_write(error)}; {lost}{kept}", EXIT_OUTPUT, error)
    except Exception as error:  # a fault in drawing must not look like a lost campaign
        lost = _not_written(record, out_dir, figures=plots and bool(aggregate.runs) and not drawn)
        message = (
            f"{out_dir}: cannot write the worst runs or the figures ({one_line(error)}); "
            f"{lost}{kept}; please report it"
        )
        return _Fault(message, EXIT_FAILED, error)
    return None


def _not_written(record: dict[str, Any], out_dir: Path, *, figures: bool) -> str:
    """``not written: worst/RUN, ..., the figures; `` for what a fault left out
    (empty where nothing was). A worst run's directory without its
    summary.json, begun when the fault came, is removed, and worst/ where it
    is left empty: no directory passes for a run that is not there."""
    missing = []
    for entry in record["worst"]:
        directory = out_dir / WORST_DIR / str(entry["run"])
        if not (directory / SUMMARY_FILE).is_file():
            shutil.rmtree(directory, ignore_errors=True)
            missing.append(f"{WORST_DIR}/{entry['run']}")
    with suppress(OSError):
        (out_dir / WORST_DIR).rmdir()  # only where empty
    if figures:
        missing.append("the figures")
    return f"not written: {', '.join(missing)}; " if missing else ""


def _discard(out_dir: Path) -> None:
    """Leave no trace of a campaign that ran nothing: a retry may use the same --out."""
    for name in (RUNS_FILE, MANIFEST_FILE, CAMPAIGN_FILE):
        (out_dir / name).unlink(missing_ok=True)
    release_run_dir(out_dir)


def _take(
    rows: list[Row],
    aggregate: Aggregate,
    keep_rows: list[dict[str, Any]] | None,
    columns: list[str],
) -> None:
    paths = aggregate.paths
    for row in rows:
        aggregate.add(row)
        if keep_rows is not None:
            keep_rows.append(
                {
                    "run": row.run,
                    "seed": row.seed,
                    "outcome": row.outcome,
                    # lists and mappings as in runs.csv (JSON text), so that they group
                    **{
                        path: value if isinstance(value, int | float | str) else value_text(value)
                        for path, value in zip(paths, row.values, strict=True)
                    },
                    **dict(zip(METRICS, row.metrics, strict=True)),
                    "margin": row.margin,
                    "margin_check": row.margin_check,
                    "reason": row.reason,
                }
            )


def _record(
    loaded: LoadedCampaign,
    aggregate: Aggregate,
    stopped_by: str | None,
    runs_seconds: float,
    planned: int,
) -> dict[str, Any]:
    campaign = loaded.campaign
    plan = Plan(campaign)
    statistics = aggregate.statistics()
    worst = [
        {
            "run": run,
            "seed": seed,
            "outcome": outcome,
            "reason": reason,
            "margin": margin,
            "margin_check": margin_check,
            "replay": replay_command(loaded, plan.draw(run)),
        }
        for run, seed, outcome, reason, margin, margin_check in aggregate.worst_runs()
    ]
    failures = [
        {
            "failure": kind,
            "runs": count,
            "worst": [
                {
                    "run": f.run,
                    "seed": f.seed,
                    "phase": f.phase,
                    "value": f.value,
                    f.side: f.bound,  # "min" for a lower bound, as summary.json has it
                    "replay": replay_command(loaded, plan.draw(f.run)),
                }
                for f in worst
            ],
        }
        for kind, count, worst in aggregate.worst_by_failure()
    ]
    missing = planned - aggregate.runs
    expectations = []
    if campaign.expect.success_rate is not None:
        least = campaign.expect.success_rate.min
        rate = statistics["success_rate"]
        met, verdict = _success_rate_verdict(least, rate, aggregate.succeeded, missing, planned)
        expectations.append(
            {"metric": "success_rate", "min": least, "value": rate, "met": met, "verdict": verdict}
        )
    empty_cells, empty_count = _cells_without_runs(campaign, aggregate)
    return {
        "campaign": campaign.name,
        "interrupted": stopped_by is not None,
        "stopped_by": stopped_by,
        "planned_runs": planned,
        "missing_runs": missing,
        **statistics,
        "cells_without_runs": empty_cells,
        "cells_without_runs_count": empty_count,
        "expectations": expectations,
        "worst": worst,
        "failures": failures,
        "wall_seconds": runs_seconds,
        "missions_per_second": aggregate.runs / runs_seconds if runs_seconds > 0 else None,
    }


def _success_rate_verdict(
    least: float, rate: float | None, succeeded: int, missing: int, planned: int
) -> tuple[bool | None, str]:
    """``met`` (None: not judged) and the verdict's text of ``success_rate: {min}``.

    A campaign stopped early holds the first runs only (runs go cell by cell,
    so a grid's later cells may have none): its rate says nothing of the
    campaign's, and is not judged, unless even the missing runs all
    succeeding would leave the rate over the planned runs below the bound."""
    if missing <= 0:
        met = rate is not None and rate >= least
        return met, "met" if met else "not met"
    done = planned - missing
    best = (succeeded + missing) / planned
    if best < least:
        return False, f"not met whatever the {missing} missing runs give (at most {best:.4g})"
    return None, f"not judged: interrupted after {done} of {planned} runs"


def _cells_without_runs(
    campaign: Campaign, aggregate: Aggregate
) -> tuple[list[dict[str, Any]], int]:
    """The grid cells that have no run (their values, as ``cells`` gives them),
    the first CELLS_LISTED in grid order, and how many there are."""
    grid = [(path, axis.grid) for path, axis in campaign.vary.items() if axis.grid is not None]
    total = campaign.grid_cells()
    if not grid or len(aggregate.cells) == total:
        return [], 0
    listed: list[dict[str, Any]] = []
    # Cells with runs are at most the runs done: the loop ends within
    # len(aggregate.cells) + CELLS_LISTED steps however many cells the grid has.
    for flat in range(total):
        if len(listed) >= CELLS_LISTED:
            break
        rest, index = flat, []
        for _, values in reversed(grid):  # the last grid axis fastest, as Plan.draw
            rest, i = divmod(rest, len(values))
            index.append(i)
        cell = tuple(reversed(index))
        if cell not in aggregate.cells:
            listed.append({path: values[i] for (path, values), i in zip(grid, cell, strict=True)})
    return listed, total - len(aggregate.cells)


def _regions(loaded: LoadedCampaign) -> dict[str, Any]:
    regions: dict[str, Any] = _mission(loaded)["regions"]
    return regions


def _mission(loaded: LoadedCampaign) -> dict[str, Any]:
    """The campaign's mission as every run starts from it (its settings, no
    run's values), with its defaults."""
    mission, _ = loaded.mission_with([])
    if mission is None:  # checked when the campaign loaded
        raise ValueError(f"{loaded.mission_path}: the campaign's mission no longer checks")
    dumped: dict[str, Any] = mission.model_dump(mode="json")
    return dumped


CLEARANCE: Final = "clearance_min"


def _bounds(mission: dict[str, Any]) -> dict[str, tuple[str, float]]:
    """The mission-wide `expect` bounds of the metrics runs.csv records, each
    with its side: ``max``, or ``min`` for `clearance_min`, a lower bound
    written as the number alone (every phase that constrains a zone is judged
    by it, and the row's value is the least over those phases)."""
    expect = mission.get("expect") or {}
    bounds = {
        name: ("max", float(expect[name]["max"]))
        for name in (m.name for m in catalog.run_metrics())
        if isinstance(expect.get(name), dict) and expect[name].get("max") is not None
    }
    if isinstance(expect.get(CLEARANCE), int | float):
        bounds[CLEARANCE] = ("min", float(expect[CLEARANCE]))
    return bounds


def _write_worst(
    loaded: LoadedCampaign,
    record: dict[str, Any],
    aggregate: Aggregate,
    out_dir: Path,
    plots: bool,
    workers: int,
    drawn: list[bool],
) -> None:
    """Re-simulate each worst run (same values, same seed: the same run) into
    worst/RUN/, and draw the campaign's figures (``drawn`` then holds True):
    with several workers, the runs on worker processes while this one draws."""
    runs = [entry["run"] for entry in record["worst"]]
    if plots:
        _load_matplotlib()  # before the pool forks, if not yet loaded
    if workers > 1 and runs:
        # The campaign's three figures cost this process about what one run
        # directory costs a worker (about 0.65 s of CPU each, case2-headings:
        # `python benchmarks/measure.py drawing`):
        # where the workers' last round would not be full, this process takes
        # the last run after drawing, and no core waits at the end.
        own = runs[-1:] if len(runs) > workers and len(runs) % workers else []
        pooled = runs[: len(runs) - len(own)]
        # A worker writing a run directory is let finish it (no temporary file
        # left); the runs not started are dropped.
        with local_pool(min(workers, len(pooled)), writes=True) as pool:
            written = [pool.submit(_write_run_dir, loaded, run, out_dir, plots) for run in pooled]
            _draw(loaded, aggregate, out_dir, plots)
            drawn.append(True)
            for run in own:
                _write_run_dir(loaded, run, out_dir, plots)
            for future in written:
                future.result()
        return
    for run in runs:
        _write_run_dir(loaded, run, out_dir, plots)
    _draw(loaded, aggregate, out_dir, plots)
    drawn.append(True)


def _load_matplotlib() -> None:
    """matplotlib's modules for the figures, loaded in this process (about 0.4 s
    of CPU): the worst runs' workers fork from it and find them loaded."""
    import matplotlib.backends.backend_agg
    import matplotlib.collections
    import matplotlib.figure  # noqa: F401


def _write_run_dir(loaded: LoadedCampaign, run: int, out_dir: Path, plots: bool) -> None:
    result, _ = simulate(loaded, Plan(loaded.campaign).draw(run))
    if result is None:  # the mission refused the drawn values: nothing to write
        return
    write_run(
        result,
        out_dir / WORST_DIR / str(run),
        mission_sha256=loaded.mission_sha256,  # the text that ran, read once
        mission_file=str(loaded.mission_path),
        plots=plots,
        animate=False,
    )


def _draw(loaded: LoadedCampaign, aggregate: Aggregate, out_dir: Path, plots: bool) -> None:
    if plots and aggregate.runs:
        from wmr_mission.campaign.figures import draw_campaign

        mission = _mission(loaded)
        varied = _varied_regions(loaded.campaign.vary, mission["regions"])
        drawn = {name: r for name, r in mission["regions"].items() if name not in varied}
        draw_campaign(aggregate, drawn, out_dir, bounds=_bounds(mission), left_out=varied)


def _varied_regions(vary: Mapping[str, Any], regions: Mapping[str, Any]) -> list[str]:
    """The regions a campaign varies (a field of theirs, or all of them): each
    run has its own, and the mission's as written would show the runs'
    paths through a zone none of them met where it is drawn."""
    varied: list[str] = []
    for path in vary:
        head, _, rest = path.partition(".")
        if head.split("[", 1)[0] != "regions":
            continue
        name = rest.split(".", 1)[0].split("[", 1)[0]
        for each in regions if not name else [name]:
            if each in regions and each not in varied:
                varied.append(each)
    return varied


def _prepare(
    loaded: LoadedCampaign, out: Path, workers: int, scheduler: str | None, *, suffix: bool
) -> Path:
    """The campaign directory, made empty (refuses one holding files; with
    ``suffix``, takes the next free ``-2``, ``-3``, ... instead) and claimed, with
    its manifest (written again once the runs are done); return it."""
    out_dir = prepare_run_dir(out, suffix_on_collision=suffix)
    manifest = json_text(_manifest(loaded, None if scheduler else workers, scheduler))
    try:
        write_bytes_atomic(out_dir / MANIFEST_FILE, manifest.encode("utf-8"))
    except BaseException:
        _discard(out_dir)
        raise
    return out_dir


def _manifest(
    loaded: LoadedCampaign,
    workers: int | None,
    scheduler: str | None,
    compiled: bool | None = None,
) -> dict[str, Any]:
    """manifest.json; ``compiled``: how the campaign's runs ran its loop, if
    known (RunRecord.loop_compiled of the warm-up's run; else this process's)."""
    return {
        "campaign_file": str(loaded.path),
        "campaign_sha256": loaded.campaign_sha256,
        "mission_file": str(loaded.mission_path),
        "mission_sha256": loaded.mission_sha256,
        "resolved_campaign": loaded.campaign.model_dump(mode="json"),
        "settings": loaded.setting_texts(),
        "versions": package_versions(),
        "environment": environment(compiled),
        "loop": loop_build(compiled),
        "workers": workers,
        "scheduler": scheduler,
    }


def run_campaign(
    campaign: str | Path,
    *,
    out: str | Path | None = None,
    workers: int | None = None,
    scheduler: str | None = None,
    plots: bool = False,
    allow_mixed_cluster: bool = False,
    overrides: Mapping[str, Any] | None = None,
) -> CampaignResult:
    """Run a campaign file; return its rows and its aggregate (the content of campaign.json).

    ``out``: also write the campaign directory there (runs.csv, campaign.json,
    manifest.json, worst/, figures when ``plots``). ``workers`` defaults to
    every core, and is at most that; ``scheduler`` is the address of a Dask
    scheduler, refused when its workers differ from this process in what
    decides the bytes unless ``allow_mixed_cluster``. ``overrides`` (dotted
    path -> value) sets fields of the campaign's mission for every run, as
    ``sweep --set`` does. Raises ``MissionError``
    (with every problem and its position) for an invalid file, TypeError or
    ValueError for a bad argument,
    ``SchedulerUnavailable`` (a RuntimeError) when no Dask scheduler answers at
    ``scheduler``, and the error of a write that failed once every run done
    is kept.
    """
    if scheduler is not None and not isinstance(scheduler, str):
        raise TypeError(f"scheduler is an address such as 'tcp://host:8786', got {scheduler!r}")
    used = usable_workers(workers)
    settings = overrides_of(overrides)
    with importing_entries():  # a campaign's runs import the mission's plug-ins
        loaded = load_campaign(campaign, settings)
    if scheduler is not None:
        reach_scheduler(scheduler)
    out_dir = None if out is None else _prepare(loaded, Path(out), used, scheduler, suffix=False)
    rows: list[dict[str, Any]] = []
    with StopSignals() as stop:
        ended = _campaign(
            loaded,
            out_dir=out_dir,
            workers=used,
            scheduler=scheduler,
            plots=plots,
            progress_stream=None,
            keep_rows=rows,
            stop=stop,
            allow_mixed_cluster=allow_mixed_cluster,
        )
    if ended.fault is not None:
        raise ended.fault.error
    return CampaignResult(rows, ended.record, out_dir, header(Plan(loaded.campaign).paths))


def sweep_command(
    campaign_path: Path,
    *,
    out: Path | None,
    workers: int | None,
    scheduler: str | None,
    plots: bool,
    allow_mixed_cluster: bool = False,
    runs: int | None = None,
    settings: Sequence[str] = (),
) -> int:
    """``runs``: runs per grid cell, instead of the campaign's; ``settings``:
    ``PATH=VALUE`` texts of ``--set``, fields of the mission set for every run.

    Exit code: 0 the campaign ran and its expect holds; 1 invalid, expect not
    met or a worker lost; 2 unusable output directory or scheduler (or a mixed
    cluster), or a write that failed; 130 or 143 stopped by SIGINT or SIGTERM
    (what ran is kept)."""
    return stoppable(
        campaign_path,
        lambda stop: _sweep(
            campaign_path,
            out,
            workers,
            scheduler,
            plots,
            stop,
            allow_mixed_cluster,
            runs,
            settings,
        ),
    )


def _is_mission(path: Path) -> bool:
    from wmr_mission.spec.loader import document_kind

    try:
        return document_kind(path.read_text(encoding="utf-8")) == "mission"
    except (OSError, UnicodeDecodeError):
        return False


def _sweep(
    campaign_path: Path,
    out: Path | None,
    workers: int | None,
    scheduler: str | None,
    plots: bool,
    stop: StopSignals,
    allow_mixed_cluster: bool,
    runs: int | None = None,
    setting_texts: Sequence[str] = (),
) -> int:
    started = time.perf_counter()
    settings, problems, code = overrides_of_texts(setting_texts)
    for problem in problems:
        print(problem, file=sys.stderr)
    if problems:
        return code
    loaded, diagnostics = check_campaign(campaign_path, settings)
    if loaded is None and _is_mission(campaign_path):
        print(
            f"{campaign_path}: this is a mission: run it with `wmr-mission run {campaign_path}`",
            file=sys.stderr,
        )
        return EXIT_FAILED
    for diagnostic in diagnostics:
        print(diagnostic, file=sys.stderr)
    if loaded is None:
        return EXIT_FAILED
    if runs is not None:  # the campaign's own `runs`, for this sweep
        loaded.campaign = loaded.campaign.model_copy(update={"runs": runs})
    used = usable_workers(workers)
    if workers is not None and used < workers and scheduler is None:
        print(
            f"--workers {workers}: {used} worker{'s' if used > 1 else ''}, one per core "
            "this sweep may use, by its CPU affinity and quota (more would only wait for a core)",
            file=sys.stderr,
        )
    if scheduler is not None:
        try:
            reach_scheduler(scheduler)
        except SchedulerUnavailable as error:
            print(f"{campaign_path}: {error}", file=sys.stderr)
            return EXIT_OUTPUT
        silence(*DASK_LOGS)  # to the end: they log while the client closes
    out_dir = out if out is not None else default_run_dir(loaded.campaign.name, datetime.now())
    try:
        out_dir = _prepare(loaded, out_dir, used, scheduler, suffix=out is None)
    except (RunDirExistsError, OSError) as error:
        print(f"{out_dir}: {getattr(error, 'strerror', None) or error}", file=sys.stderr)
        return EXIT_OUTPUT
    try:
        ended = _campaign(
            loaded,
            out_dir=out_dir,
            workers=used,
            scheduler=scheduler,
            plots=plots,
            progress_stream=sys.stderr,
            keep_rows=None,
            stop=stop,
            allow_mixed_cluster=allow_mixed_cluster,
        )
    except SchedulerUnavailable as error:  # nothing ran, nothing is left
        print(f"{campaign_path}: {error}", file=sys.stderr)
        return EXIT_OUTPUT
    record = ended.record
    for notice in ended.notices:
        print(notice, file=sys.stderr)
    print(_report(record, out_dir, time.perf_counter() - started))
    if ended.fault is not None:
        print(ended.fault.message, file=sys.stderr)
        return ended.fault.code
    if record["interrupted"]:
        print(
            f"{campaign_path}: interrupted ({record['stopped_by']}); "
            f"the {record['runs']} finished runs are kept in {out_dir}",
            file=sys.stderr,
        )
        return stop.exit_code if ended.interrupted else EXIT_FAILED
    failed = [e for e in record["expectations"] if not e["met"]]
    line, column = loaded.positions.get(("expect", "success_rate"), (0, 0))
    where = f"{campaign_path}:{line}:{column}" if line else str(campaign_path)
    for expectation in failed:
        print(
            f"{where}: expectation not met: success_rate = "
            f"{expectation['value']:.4g} (min {expectation['min']:.4g})",
            file=sys.stderr,
        )
    return EXIT_FAILED if failed else 0


def _beyond(worst: dict[str, Any]) -> str:
    """`` (south: 2.38, max 2)``: where and how far a run failed its bound
    (``min`` for a lower bound)."""
    side = "min" if worst.get("min") is not None else "max"
    if worst.get(side) is None:
        return ""
    value, bound = ("none", f"{worst[side]:.3g}")
    if worst["value"] is not None:
        value, bound = beside(worst["value"], worst[side], 3)
    where = f"{worst['phase']}: " if worst.get("phase") else ""
    return f" ({where}{value}, {side} {bound})"


def _timing(record: dict[str, Any], total: float) -> str:
    """What the rate counts, and where the rest of the sweep's time went: the
    runs alone are timed (missions_per_second), not the start-up of the
    workers or the writing of worst runs and figures after them."""
    runs, simulating, startup = record["runs"], record["wall_seconds"], record["startup_seconds"]
    rate = record["missions_per_second"] or 0.0
    after = max(0.0, total - startup - simulating)
    return (
        f"{runs} runs simulated in {simulating:.1f} s ({rate:.1f} runs per second of "
        f"simulating); the sweep took {total:.1f} s: start-up {startup:.1f} s, runs "
        f"{simulating:.1f} s, the rest (checks, worst runs, figures) {after:.1f} s"
    )


def _missing(record: dict[str, Any]) -> list[str]:
    """What a campaign stopped early lacks, and its expectations' verdicts,
    which then cover only the runs done (none for a whole campaign, whose
    missed expectations stderr says)."""
    missing = record.get("missing_runs") or 0
    if missing <= 0:
        return []
    runs, planned = record["runs"], record["planned_runs"]
    lines = [f"runs missing: {missing} of the {planned} planned (interrupted after {runs})"]
    count = record.get("cells_without_runs_count") or 0
    if count:
        listed = record["cells_without_runs"]
        named = [
            ", ".join(f"{path}={shown(value_text(value))}" for path, value in cell.items())
            for cell in listed[:CELLS_SHOWN]
        ]
        more = f"; and {count - len(named)} more" if count > len(named) else ""
        lines.append(f"grid cells with no runs ({count}): " + "; ".join(named) + more)
    for expectation in record["expectations"]:
        lines.append(
            f"expect {expectation['metric']} (min {expectation['min']:.4g}): "
            f"{expectation['verdict']}"
        )
    return lines


def _report(record: dict[str, Any], out_dir: Path, total: float) -> str:
    lo, hi = record["success_interval"]
    rate = record["success_rate"]
    lines = [
        f"campaign {record['campaign']}: {record['runs']} runs, {record['succeeded']} succeeded"
        + (f" ({rate:.2%}, 95 % interval {lo:.2%} .. {hi:.2%})" if rate is not None else ""),
        "outcomes: " + ", ".join(f"{k} {v}" for k, v in record["outcomes"].items()),
        _timing(record, total),
    ]
    lines += _missing(record)
    recovered = record.get("recovery")
    if recovered and recovered["needed"]:
        lines.append(recovery_report(recovered))
    if record.get("failures"):
        lines.append("failures by kind (runs; the worst run, its replay):")
        for failure in record["failures"]:
            worst = failure["worst"][0]
            lines.append(
                f"  {failure['failure']}: {failure['runs']}; run {worst['run']}"
                f"{_beyond(worst)}: {worst['replay']}"
            )
    elif record["worst"]:
        lines.append("worst runs (replay):")
        lines += [f"  {w['run']}: {w['outcome']}: {w['replay']}" for w in record["worst"]]
    lines.append(f"written to {out_dir}")
    return "\n".join(lines)
