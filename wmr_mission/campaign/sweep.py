"""``wmr-mission sweep`` and :func:`run_campaign`: run a campaign, write its outputs.

Outputs (DESIGN "Campaigns"): ``runs.csv`` streamed row by row in run order,
``campaign.json`` (statistics, worst runs and their replay commands,
throughput), ``manifest.json``, ``worst/RUN/`` run directories (re-simulated
at the end) and the figures.
"""

from __future__ import annotations

import csv
import hashlib
import math
import sys
import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import IO, Any, Final

from wmr_mission.campaign.aggregate import Aggregate
from wmr_mission.campaign.engine import (
    Interrupted,
    SchedulerUnavailable,
    StopFlag,
    default_workers,
    execute,
    local_pool,
    warm_up,
)
from wmr_mission.campaign.load import LoadedCampaign, check_campaign, load_campaign, value_text
from wmr_mission.campaign.plan import Plan
from wmr_mission.campaign.rows import Row, header, replay_command, simulate
from wmr_mission.output.environment import environment, package_versions
from wmr_mission.output.files import json_text, write_bytes_atomic
from wmr_mission.output.progress import Steps
from wmr_mission.output.rundir import (
    RunDirExistsError,
    default_run_dir,
    loop_build,
    prepare_run_dir,
    write_run,
)

__all__ = ["CampaignResult", "run_campaign", "sweep_command"]

RUNS_FILE: Final = "runs.csv"
CAMPAIGN_FILE: Final = "campaign.json"
MANIFEST_FILE: Final = "manifest.json"
WORST_DIR: Final = "worst"
INTERRUPTED_EXIT: Final = 130  # as a shell reports a command stopped by Ctrl-C
INTERRUPTED_NOTICE: Final = "interrupted: stopping; the finished runs are kept"
LOAD_EARLY_AFTER_SECONDS: Final = 2.0
"""Runs that last longer on the workers (estimated) have matplotlib loaded, for
the figures, while they run: the workers have tasks queued for the time it
takes (about 0.4 s), and no core waits for it after them. Shorter campaigns
load it after their runs, so that it never counts in their runs' time."""


@dataclass
class CampaignResult:
    """What :func:`run_campaign` returns: the rows and the aggregate (campaign.json)."""

    rows: Any  # a pandas DataFrame when pandas is installed, else a list of dicts
    summary: dict[str, Any]
    out_dir: Path | None


def _runs_detail(aggregate: Aggregate, total: int, started: float) -> str:
    """Runs done of ``total``, the success rate so far and the time left."""
    done = aggregate.runs
    rate = aggregate.succeeded / done if done else 0.0
    left = (time.perf_counter() - started) / done * (total - done) if done else math.nan
    return f"{done}/{total} runs, success {rate:.1%}, {left:.0f} s left"


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def _execute(
    loaded: LoadedCampaign,
    *,
    out_dir: Path | None,
    workers: int,
    scheduler: str | None,
    plots: bool,
    progress_stream: IO[str] | None,
    keep_rows: list[dict[str, Any]] | None,
    allow_mixed_cluster: bool = False,
) -> dict[str, Any]:
    """Run every run; write the outputs to ``out_dir`` (none when None); return
    campaign.json. Its steps are shown on ``progress_stream`` if a terminal."""
    progress = Steps(progress_stream)
    try:
        return _execute_steps(
            loaded, out_dir, workers, scheduler, plots, keep_rows, progress, allow_mixed_cluster
        )
    finally:
        progress.close()


def _execute_steps(
    loaded: LoadedCampaign,
    out_dir: Path | None,
    workers: int,
    scheduler: str | None,
    plots: bool,
    keep_rows: list[dict[str, Any]] | None,
    progress: Steps,
    allow_mixed_cluster: bool,
) -> dict[str, Any]:
    campaign = loaded.campaign
    plan = Plan(campaign)
    paths = plan.paths
    aggregate = Aggregate(dict(campaign.vary))
    columns = header(paths)
    progress.step("starting")  # the kernels loaded, a run timed, the workers started
    interrupted = False
    stopped_by = "Ctrl-C"
    csv_stream = None
    if out_dir is not None:
        csv_stream = (out_dir / RUNS_FILE).open("w", encoding="utf-8", newline="")
    started = time.perf_counter()
    try:
        writer = csv.writer(csv_stream, lineterminator="\n") if csv_stream is not None else None
        if writer is not None:
            writer.writerow(columns)
        with StopFlag() as stop:
            seconds_per_run = warm_up(loaded)
            load_early = (
                plots
                and out_dir is not None
                and scheduler is None
                and workers > 1
                and len(plan) * seconds_per_run / workers > LOAD_EARLY_AFTER_SECONDS
            )
            runs_started = time.perf_counter()
            progress.step("runs", total=len(plan))
            try:
                for rows in execute(
                    loaded,
                    workers=workers,
                    scheduler=scheduler,
                    seconds_per_run=seconds_per_run,
                    stop=stop,
                    allow_mixed_cluster=allow_mixed_cluster,
                ):
                    if load_early:  # while the workers run: no core waits for it
                        _load_matplotlib()
                        load_early = False
                    _take(rows, aggregate, writer, keep_rows, columns)
                    if csv_stream is not None:
                        csv_stream.flush()
                    progress.update(
                        aggregate.runs, _runs_detail(aggregate, len(plan), runs_started)
                    )
            except (Interrupted, KeyboardInterrupt):  # a second Ctrl-C stops at once
                progress.say(INTERRUPTED_NOTICE)
                interrupted = True
            except SchedulerUnavailable:
                raise
            except Exception as error:  # a worker lost: keep what finished
                interrupted = True
                stopped_by = f"{type(error).__name__}: {error}"
            runs_seconds = time.perf_counter() - runs_started
    finally:
        if csv_stream is not None:
            csv_stream.close()
    record = _record(loaded, aggregate, interrupted, runs_seconds, len(plan))
    record["stopped_by"] = stopped_by if interrupted else None
    record["startup_seconds"] = runs_started - started
    record["workers"] = None if scheduler is not None else workers
    record["scheduler"] = scheduler
    if out_dir is not None:
        progress.step("worst runs and figures" if plots else "worst runs")
        # The statistics first: a Ctrl-C while the worst runs are drawn loses no number.
        write_bytes_atomic(out_dir / CAMPAIGN_FILE, json_text(record).encode("utf-8"))
        try:
            _write_worst(
                loaded, record, aggregate, out_dir, plots, workers if scheduler is None else 1
            )
        except KeyboardInterrupt:  # every run is in runs.csv; the worst runs' directories stop
            progress.say(INTERRUPTED_NOTICE)
            record["interrupted"] = True
            record["stopped_by"] = "Ctrl-C"
            write_bytes_atomic(out_dir / CAMPAIGN_FILE, json_text(record).encode("utf-8"))
    return record


def _take(
    rows: list[Row],
    aggregate: Aggregate,
    writer: Any,
    keep_rows: list[dict[str, Any]] | None,
    columns: list[str],
) -> None:
    paths = aggregate.paths
    for row in rows:
        aggregate.add(row)
        cells = row.cells()
        if writer is not None:
            writer.writerow(cells)
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
                    **dict(zip(columns[3 + len(row.values) : -1], row.metrics, strict=True)),
                    "reason": row.reason,
                }
            )


def _record(
    loaded: LoadedCampaign,
    aggregate: Aggregate,
    interrupted: bool,
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
            "replay": replay_command(loaded, plan.draw(run)),
        }
        for run, seed, outcome, reason in aggregate.worst_runs()
    ]
    expectations = []
    if campaign.expect.success_rate is not None:
        least = campaign.expect.success_rate.min
        rate = statistics["success_rate"]
        expectations.append(
            {
                "metric": "success_rate",
                "min": least,
                "value": rate,
                "met": rate is not None and rate >= least,
            }
        )
    return {
        "campaign": campaign.name,
        "interrupted": interrupted,
        "planned_runs": planned,
        **statistics,
        "expectations": expectations,
        "worst": worst,
        "wall_seconds": runs_seconds,
        "missions_per_second": aggregate.runs / runs_seconds if runs_seconds > 0 else None,
    }


def _regions(loaded: LoadedCampaign) -> dict[str, Any]:
    from wmr_mission.spec.loader import load_mission_text

    mission = load_mission_text(loaded.mission_text, str(loaded.mission_path))
    regions: dict[str, Any] = mission.model_dump(mode="json")["regions"]
    return regions


def _write_worst(
    loaded: LoadedCampaign,
    record: dict[str, Any],
    aggregate: Aggregate,
    out_dir: Path,
    plots: bool,
    workers: int,
) -> None:
    """Re-simulate each worst run (same values, same seed: the same run) into
    worst/RUN/, and draw the campaign's figures: with several workers, the runs
    on worker processes while this one draws."""
    runs = [entry["run"] for entry in record["worst"]]
    mission_sha256 = _sha256(loaded.mission_path)
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
        with local_pool(min(workers, len(pooled))) as pool:
            written = [
                pool.submit(_write_run_dir, loaded, run, out_dir, plots, mission_sha256)
                for run in pooled
            ]
            try:
                _draw(loaded, aggregate, out_dir, plots)
                for run in own:
                    _write_run_dir(loaded, run, out_dir, plots, mission_sha256)
                for future in written:
                    future.result()
            except KeyboardInterrupt:  # stop now: leave the runs not started
                pool.shutdown(wait=False, cancel_futures=True)
                raise
        return
    for run in runs:
        _write_run_dir(loaded, run, out_dir, plots, mission_sha256)
    _draw(loaded, aggregate, out_dir, plots)


def _load_matplotlib() -> None:
    """matplotlib's modules for the figures, loaded in this process (about 0.4 s
    of CPU): the worst runs' workers fork from it and find them loaded."""
    import matplotlib.backends.backend_agg
    import matplotlib.collections
    import matplotlib.figure  # noqa: F401


def _write_run_dir(
    loaded: LoadedCampaign, run: int, out_dir: Path, plots: bool, mission_sha256: str
) -> None:
    result, _ = simulate(loaded, Plan(loaded.campaign).draw(run))
    if result is None:  # the mission refused the drawn values: nothing to write
        return
    write_run(
        result,
        out_dir / WORST_DIR / str(run),
        mission_sha256=mission_sha256,
        mission_file=str(loaded.mission_path),
        plots=plots,
        animate=False,
    )


def _draw(loaded: LoadedCampaign, aggregate: Aggregate, out_dir: Path, plots: bool) -> None:
    if plots and aggregate.runs:
        from wmr_mission.campaign.figures import draw_campaign

        draw_campaign(aggregate, _regions(loaded), out_dir)


def _prepare(loaded: LoadedCampaign, out: Path, workers: int, scheduler: str | None) -> Path:
    """The campaign directory, made empty (refuses one holding files), with its manifest."""
    out_dir = prepare_run_dir(out)
    manifest = _manifest(loaded, None if scheduler else workers, scheduler)
    write_bytes_atomic(out_dir / MANIFEST_FILE, json_text(manifest).encode("utf-8"))
    return out_dir


def _manifest(loaded: LoadedCampaign, workers: int | None, scheduler: str | None) -> dict[str, Any]:
    return {
        "campaign_file": str(loaded.path),
        "campaign_sha256": _sha256(loaded.path),
        "mission_file": str(loaded.mission_path),
        "mission_sha256": _sha256(loaded.mission_path),
        "resolved_campaign": loaded.campaign.model_dump(mode="json"),
        "versions": package_versions(),
        "environment": environment(),
        "loop": loop_build(),
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
) -> CampaignResult:
    """Run a campaign file; return its rows and its aggregate (the content of campaign.json).

    ``out``: also write the campaign directory there (runs.csv, campaign.json,
    manifest.json, worst/, figures when ``plots``). ``workers`` defaults to
    every core; ``scheduler`` is the address of a Dask scheduler, refused when
    its workers differ from this process in what decides the bytes unless
    ``allow_mixed_cluster``. Raises ``MissionError`` (with every problem and its
    position) for an invalid file.
    """
    loaded = load_campaign(campaign)
    workers = workers or default_workers()
    out_dir = None if out is None else _prepare(loaded, Path(out), workers, scheduler)
    rows: list[dict[str, Any]] = []
    summary = _execute(
        loaded,
        out_dir=out_dir,
        workers=workers,
        scheduler=scheduler,
        plots=plots,
        progress_stream=None,
        keep_rows=rows,
        allow_mixed_cluster=allow_mixed_cluster,
    )
    table: Any = rows
    try:
        import pandas

        table = pandas.DataFrame(rows, columns=header(Plan(loaded.campaign).paths))
    except ImportError:
        pass
    return CampaignResult(table, summary, out_dir)


def sweep_command(
    campaign_path: Path,
    *,
    out: Path | None,
    workers: int | None,
    scheduler: str | None,
    plots: bool,
    allow_mixed_cluster: bool = False,
) -> int:
    """Exit code: 0 the campaign ran and its expect holds, 1 invalid or expect not met,
    2 unusable output directory or scheduler (or a mixed cluster), 130 interrupted."""
    loaded, diagnostics = check_campaign(campaign_path)
    for diagnostic in diagnostics:
        print(diagnostic, file=sys.stderr)
    if loaded is None:
        return 1
    workers = workers or default_workers()
    out_dir = out if out is not None else default_run_dir(loaded.campaign.name, datetime.now())
    try:
        out_dir = _prepare(loaded, out_dir, workers, scheduler)
    except (RunDirExistsError, OSError) as error:
        print(f"{out_dir}: {error}", file=sys.stderr)
        return 2
    try:
        record = _execute(
            loaded,
            out_dir=out_dir,
            workers=workers,
            scheduler=scheduler,
            plots=plots,
            progress_stream=sys.stderr,
            keep_rows=None,
            allow_mixed_cluster=allow_mixed_cluster,
        )
    except SchedulerUnavailable as error:
        print(f"{campaign_path}: {error}", file=sys.stderr)
        return 2
    print(_report(record, out_dir))
    if record["interrupted"]:
        print(
            f"{campaign_path}: interrupted ({record['stopped_by']}); "
            f"finished runs kept in {out_dir}",
            file=sys.stderr,
        )
        return INTERRUPTED_EXIT if record["stopped_by"] == "Ctrl-C" else 1
    failed = [e for e in record["expectations"] if not e["met"]]
    for expectation in failed:
        print(
            f"{campaign_path}: expectation not met: success_rate = "
            f"{expectation['value']:.4g} (min {expectation['min']:.4g})",
            file=sys.stderr,
        )
    return 1 if failed else 0


def _report(record: dict[str, Any], out_dir: Path) -> str:
    lo, hi = record["success_interval"]
    rate = record["success_rate"]
    lines = [
        f"campaign {record['campaign']}: {record['runs']} runs, {record['succeeded']} succeeded"
        + (f" ({rate:.2%}, 95 % interval {lo:.2%} .. {hi:.2%})" if rate is not None else ""),
        "outcomes: " + ", ".join(f"{k} {v}" for k, v in record["outcomes"].items()),
        f"{record['missions_per_second'] or 0:.1f} missions/s over {record['wall_seconds']:.1f} s"
        f" (start-up {record['startup_seconds']:.1f} s)",
    ]
    if record["worst"]:
        lines.append("worst runs (replay):")
        lines += [f"  {w['run']}: {w['outcome']}: {w['replay']}" for w in record["worst"]]
    lines.append(f"written to {out_dir}")
    return "\n".join(lines)
