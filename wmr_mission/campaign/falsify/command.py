"""``wmr-mission falsify`` and :func:`falsify_campaign`: search a campaign's axes
for failing runs, write what was evaluated.

A directory (``--out``, default ``runs/<campaign-name>-falsify-<timestamp>``)
holds ``evaluations.csv`` (written batch by batch), ``falsify.json``,
``manifest.json``, ``failing/N.yaml`` and the figures. A signal (Ctrl-C,
SIGTERM) stops the search after the runs under way: every finished run is in
``evaluations.csv`` and ``falsify.json`` says ``"interrupted": true``; after
the search, it stops the figures at once.

A write that fails (a full disk) stops the search at the last complete row
of ``evaluations.csv``; ``falsify.json`` is written before ``failing/`` and
the figures, so that a fault there costs only them. Either way the fault is
said in one line, exit 2.
"""

from __future__ import annotations

import contextlib
import math
import shlex
import sys
import time
from dataclasses import dataclass
from datetime import datetime
from pathlib import Path
from typing import IO, Any, Final

from wmr_mission.campaign.engine import (
    DASK_LOGS,
    SchedulerUnavailable,
    check_cluster,
    one_line,
    reach_scheduler,
    silence,
    usable_workers,
)
from wmr_mission.campaign.falsify import DEFAULT_METHOD, METHODS
from wmr_mission.campaign.falsify.evaluate import Evaluation, Evaluator, check_names, evaluate
from wmr_mission.campaign.falsify.files import (
    BEST,
    EVALUATIONS_FILE,
    FAILING_DIR,
    FALSIFY_FILE,
    cells,
    columns,
    mission_text,
    replay,
)
from wmr_mission.campaign.falsify.loop import Search, draws_of, run_search
from wmr_mission.campaign.falsify.search import make_method
from wmr_mission.campaign.falsify.space import Space
from wmr_mission.campaign.load import LoadedCampaign, check_campaign, load_campaign
from wmr_mission.campaign.stops import stoppable
from wmr_mission.kernels import jit
from wmr_mission.output.environment import environment, package_versions
from wmr_mission.output.files import RowsFile, json_text, write_bytes_atomic
from wmr_mission.output.progress import Steps
from wmr_mission.output.rundir import (
    RunDirExistsError,
    default_run_dir,
    drop_claim,
    loop_build,
    prepare_run_dir,
)
from wmr_mission.spec.checks import importing_entries
from wmr_mission.stopping import GENTLE, HOLD, RAISE, StopSignals, mode, stop_owed

__all__ = ["DEFAULT_BUDGET", "FalsifyResult", "UsageError", "falsify_campaign", "falsify_command"]

DEFAULT_BUDGET: Final = 300
MAX_BUDGET: Final = 1_000_000
EXIT_FALSIFIED: Final = 1  # a failing run found (the controller falsified), or an invalid file
EXIT_USAGE: Final = 2  # a bad flag, an unusable --out or scheduler, a write that fails
MANIFEST_FILE: Final = "manifest.json"
INTERRUPTED_NOTICE: Final = "interrupted: stopping; the finished runs are kept"


class UsageError(ValueError):
    """A setting the search cannot take (an --objective no check has, a campaign
    without axes): said in one line, exit 2."""


@dataclass(repr=False)
class FalsifyResult:
    """What :func:`falsify_campaign` returns: every evaluation, in order, and
    falsify.json's record."""

    evaluations: list[Evaluation]
    record: dict[str, Any]
    out_dir: Path | None

    @property
    def falsified(self) -> bool:
        return bool(self.record["falsified"])

    def __repr__(self) -> str:
        return (
            f"FalsifyResult(campaign={self.record['campaign']!r}, "
            f"evaluations={len(self.evaluations)}, falsified={self.falsified}, "
            f"out_dir={self.out_dir!r})"
        )


@dataclass(frozen=True)
class Settings:
    method: str
    budget: int
    seed: int
    objective: str | None
    first: bool


def _settings(
    loaded: LoadedCampaign,
    method: str,
    budget: int,
    seed: int | None,
    objective: str | None,
    first: bool,
) -> Settings:
    if method not in METHODS:
        raise UsageError(f"--method {method}: one of {', '.join(METHODS)}")
    if isinstance(budget, bool) or not isinstance(budget, int) or not 1 <= budget <= MAX_BUDGET:
        raise UsageError(f"--budget {budget}: a whole number of runs, 1 .. {MAX_BUDGET}")
    if not loaded.campaign.vary:
        raise UsageError(
            f"{loaded.path}: the campaign varies no field: falsify searches its `vary` axes"
        )
    return Settings(
        method, budget, loaded.campaign.seed if seed is None else seed, objective, first
    )


def _centre(space: Space, seed: int) -> Any:
    """The run at the box's centre: the warm-up (it compiles the kernels once,
    before any worker starts) and the checks an --objective may name."""
    point = [(lo + hi) / 2 for lo, hi in zip(space.lower(), space.upper(), strict=True)]
    return draws_of(space, seed, 0, [point])[0]


def _warm_up(loaded: LoadedCampaign, space: Space, settings: Settings) -> bool | None:
    """The kernels loaded by a run of the space's centre, and ``--objective``
    checked; whether that run's loop ran compiled (the manifest says so)."""
    draw = _centre(space, settings.seed)
    compiled = evaluate(loaded, draw, None).loop_compiled
    if settings.objective is None:
        return compiled
    names = check_names(loaded, draw)
    metrics = {name.rpartition(": ")[2] for name in names}
    if settings.objective not in names and settings.objective not in metrics:
        raise UsageError(
            f"--objective {settings.objective}: the mission has no such check; its checks: "
            + (", ".join(names) or "none")
        )
    return compiled


def _record(
    loaded: LoadedCampaign,
    settings: Settings,
    method_settings: dict[str, Any],
    found: Search,
    stopped_by: str | None,
    seconds: float,
    workers: int | None,
    scheduler: str | None,
    out_dir: Path | None,
) -> dict[str, Any]:
    evaluations = found.evaluations
    ran = [e for e in evaluations if e.ran]
    best = sorted(ran, key=lambda e: (e.objective, e.index))[:BEST]
    failing = [e for e in evaluations if e.falsified]
    lowest = best[0] if best else None
    return {
        "campaign": loaded.campaign.name,
        "campaign_file": str(loaded.path),
        "mission_file": str(loaded.mission_path),
        "method": settings.method,
        "settings": {
            "budget": settings.budget,
            "seed": settings.seed,
            "objective": settings.objective,
            "first": settings.first,
            **method_settings,
        },
        "objective": settings.objective or "margin",
        "evaluations": len(evaluations),
        "falsified": bool(failing),
        "runs_to_first_failure": found.first_failure,
        "failing_runs": len(failing),
        "not_run": len(evaluations) - len(ran),
        "lowest": None if lowest is None else _finite(lowest.objective),
        "best": [_entry(loaded, e, out_dir) for e in best],
        "failing": [
            {"evaluation": e.index, "mission": f"{FAILING_DIR}/{e.index}.yaml"} for e in failing
        ],
        "interrupted": stopped_by is not None,
        "stopped_by": stopped_by,
        "wall_seconds": seconds,
        "workers": workers,
        "scheduler": scheduler,
    }


def _finite(value: float) -> float | str:
    return value if math.isfinite(value) else ("inf" if value > 0 else "-inf")


def _entry(loaded: LoadedCampaign, evaluation: Evaluation, out_dir: Path | None) -> dict[str, Any]:
    entry: dict[str, Any] = {
        "evaluation": evaluation.index,
        "seed": evaluation.seed,
        "values": evaluation.values,
        "outcome": evaluation.outcome,
        "objective": _finite(evaluation.objective),
        "margin": _finite(evaluation.margin),
        "margin_check": evaluation.margin_check,
        "replay": replay(loaded, evaluation),
    }
    if evaluation.falsified:
        entry["mission"] = f"{FAILING_DIR}/{evaluation.index}.yaml"
        mission = Path(FAILING_DIR) / f"{evaluation.index}.yaml"
        where = mission if out_dir is None else (out_dir / mission).resolve()
        entry["run"] = shlex.join(["wmr-mission", "run", str(where)])
    return entry


def _manifest(loaded: LoadedCampaign, compiled: bool | None = None) -> dict[str, Any]:
    """manifest.json; ``compiled``: how the search's runs ran the loop, if known."""
    return {
        "campaign_file": str(loaded.path),
        "campaign_sha256": loaded.campaign_sha256,
        "mission_file": str(loaded.mission_path),
        "mission_sha256": loaded.mission_sha256,
        "resolved_campaign": loaded.campaign.model_dump(mode="json"),
        "versions": package_versions(),
        "environment": environment(compiled),
        "loop": loop_build(compiled),
    }


@dataclass
class Fault:
    """What could not be written: one line for stderr, exit 2, and the error,
    which :func:`falsify_campaign` raises once what was evaluated is kept."""

    message: str
    error: OSError


class _RowsUnwritable(Exception):
    """evaluations.csv took no more rows: the search stops, its rows so far kept."""


def _cannot_write(error: OSError, where: Path) -> str:
    return f"{error.filename or where}: cannot write: {error.strerror or error}"


def _falsify(
    loaded: LoadedCampaign,
    settings: Settings,
    *,
    out_dir: Path | None,
    workers: int,
    scheduler: str | None,
    plots: bool,
    stop: StopSignals,
    progress_stream: IO[str] | None,
    campaign_text: str,
) -> tuple[Search, dict[str, Any], Fault | None]:
    """Search, writing the directory as it goes (none when ``out_dir`` is None).

    A write that fails before the first run raises its OSError (nothing to
    keep); after it, what was evaluated is kept and the fault returned."""
    started = time.perf_counter()
    progress = Steps(progress_stream)
    stop.notify = lambda: progress.say(INTERRUPTED_NOTICE)
    space = Space(loaded.campaign)
    method = make_method(settings.method, space, settings.seed)
    try:
        progress.step("starting")  # the kernels loaded, the objective's check found
        notice = jit.foreground_notice()  # a compile of a minute or more: said before it
        if notice is not None:
            progress.note(notice)
        compiled = _warm_up(loaded, space, settings)
        if stop_owed():  # raised inside numba's compiler, where it could not propagate
            raise KeyboardInterrupt  # before the first run: nothing to keep
        if out_dir is not None:
            manifest = json_text(_manifest(loaded, compiled))
            write_bytes_atomic(out_dir / MANIFEST_FILE, manifest.encode())
        rows = (
            None if out_dir is None else RowsFile(out_dir / EVALUATIONS_FILE, columns(space.paths))
        )
        progress.step("runs", total=settings.budget)
        seen: list[Evaluation] = []
        fault: Fault | None = None

        def on_batch(batch: list[Evaluation]) -> None:
            nonlocal fault
            if rows is not None:
                try:
                    rows.append([cells(e) for e in batch])
                except OSError as error:  # the complete rows so far are kept; stop
                    seen.extend(batch[: rows.kept])
                    fault = Fault(_cannot_write(error, rows.path), error)
                    raise _RowsUnwritable from error
            seen.extend(batch)  # only what evaluations.csv holds
            progress.update(len(seen), _detail(seen))

        try:
            with _client(scheduler) as client:
                stop.mode = GENTLE
                with Evaluator(
                    loaded, settings.objective, workers=workers, client=client, stop=stop
                ) as evaluator:
                    found = run_search(
                        space,
                        method,
                        evaluator,
                        budget=settings.budget,
                        seed=settings.seed,
                        first=settings.first,
                        on_batch=on_batch,
                    )
        except KeyboardInterrupt:  # a second signal: stop at once, keep what was written
            found = Search(list(seen), stopped=True)
        except _RowsUnwritable:
            found = Search(list(seen), stopped=True)
        finally:
            stop.mode = HOLD  # what was evaluated is written whole, whatever signal comes
            if rows is not None:
                try:
                    rows.finish()  # synced (written again if removed meanwhile)
                except OSError as error:
                    fault = fault or Fault(_cannot_write(error, rows.path), error)
                finally:
                    rows.close()
        if fault is not None:
            stopped_by: str | None = fault.message
        else:
            stopped_by = stop.name if (found.stopped or stop.stopped) else None
        record = _record(
            loaded,
            settings,
            method.settings(),
            found,
            stopped_by,
            time.perf_counter() - started,
            None if scheduler else workers,
            scheduler,
            out_dir,
        )
        if out_dir is not None:
            fault = _write(
                loaded, record, found, space, settings, out_dir, plots, stop, progress,
                campaign_text, fault,
            )  # fmt: skip
        return found, record, fault
    finally:
        stop.notify = None
        progress.close()
        if out_dir is not None:
            drop_claim(out_dir)


def _write(
    loaded: LoadedCampaign,
    record: dict[str, Any],
    found: Search,
    space: Space,
    settings: Settings,
    out_dir: Path,
    plots: bool,
    stop: StopSignals,
    progress: Steps,
    campaign_text: str,
    fault: Fault | None,
) -> Fault | None:
    """falsify.json first (the smallest file that makes the directory a record
    ``view`` reads), then failing/N.yaml, then the figures: a fault or a signal
    after falsify.json costs only what comes after it."""
    runs = record["evaluations"]
    before = "" if fault is None else f"{fault.message}; "
    try:
        _write_record(out_dir, record)
    except OSError as error:
        message = (
            f"{before}{_cannot_write(error, out_dir)}; "
            f"{EVALUATIONS_FILE} holds the {runs} runs done"
        )
        return Fault(message, error)
    kept = f"{EVALUATIONS_FILE} and {FALSIFY_FILE} are in {out_dir}"
    try:
        for evaluation in found.evaluations:
            if evaluation.falsified:
                path = out_dir / FAILING_DIR / f"{evaluation.index}.yaml"
                path.parent.mkdir(exist_ok=True)
                text = mission_text(loaded, evaluation, campaign_text)
                write_bytes_atomic(path, text.encode("utf-8"))
    except OSError as error:
        return Fault(f"{before}{_cannot_write(error, out_dir)}; {kept}", error)
    if fault is not None:  # nothing more is written to a full disk
        message = (
            f"{fault.message}; the search stopped after {runs} runs, "
            f"which {EVALUATIONS_FILE} and {FALSIFY_FILE} hold"
        )
        return Fault(message, fault.error)
    if stop.stopped or stop_owed():  # a signal while the record was written: no figures
        if not record["interrupted"]:
            _stopped(record, stop, out_dir)
        return None
    if plots and found.evaluations:
        progress.step("figures")
        # Imported while stops are held: one raised inside an import becomes an
        # ImportError that libraries may swallow.
        from wmr_mission.campaign.falsify.figures import draw_falsification

        try:
            if stop_owed():
                raise KeyboardInterrupt
            with mode(RAISE):  # the record is written: a stop ends the drawing at once
                draw_falsification(found.evaluations, space, settings.objective, out_dir)
        except KeyboardInterrupt:
            _stopped(record, stop, out_dir)
        except OSError as error:
            if not stop_owed():
                return Fault(f"{_cannot_write(error, out_dir)}; {kept}", error)
        except Exception:
            if not stop_owed():  # a fault in drawing, not a stop turned into another error
                raise
        if stop_owed() and not record["interrupted"]:  # a stop swallowed inside the drawing
            _stopped(record, stop, out_dir)
    return None


def _write_record(out_dir: Path, record: dict[str, Any]) -> None:
    write_bytes_atomic(out_dir / FALSIFY_FILE, json_text(record).encode("utf-8"))


def _stopped(record: dict[str, Any], stop: StopSignals, out_dir: Path) -> None:
    """Mark the record stopped by a signal that came after the search, and write it."""
    stop.mode = HOLD
    record["interrupted"] = True
    record["stopped_by"] = stop.name
    with contextlib.suppress(OSError):  # the record as first written stands
        _write_record(out_dir, record)


def _detail(seen: list[Evaluation]) -> str:
    ran = [e.objective for e in seen if e.ran]
    failing = sum(e.falsified for e in seen)
    lowest = f"lowest {min(ran):.3g}" if ran else "none ran"
    return f"{len(seen)} runs, {lowest}, {failing} failing"


class _client:
    """A Dask client on ``scheduler`` (None: no client), its workers checked
    against this machine as a sweep checks them."""

    def __init__(self, scheduler: str | None) -> None:
        self.scheduler = scheduler
        self.client: Any = None

    def __enter__(self) -> Any:
        if self.scheduler is None:
            return None
        from distributed import Client

        try:
            self.client = Client(self.scheduler, timeout=10)  # type: ignore[no-untyped-call]
        except Exception as error:
            raise SchedulerUnavailable(
                f"cannot use the Dask scheduler {self.scheduler}: {one_line(error)}"
            ) from None
        check_cluster(self.client, False)
        return self.client

    def __exit__(self, *exc: Any) -> None:
        if self.client is not None:
            self.client.close()


def falsify_campaign(
    campaign: str | Path,
    *,
    budget: int = DEFAULT_BUDGET,
    method: str = DEFAULT_METHOD,
    seed: int | None = None,
    objective: str | None = None,
    first: bool = False,
    workers: int | None = None,
    scheduler: str | None = None,
    out: str | Path | None = None,
    plots: bool = False,
) -> FalsifyResult:
    """Search a campaign's axes for failing runs (docs/falsification.md).

    ``method``: ``gp``, ``cmaes`` or ``random``; ``seed`` (default: the campaign's)
    seeds the search and each run's sensors; ``objective``: a check
    (``phase: metric``, or a metric for each of its checks) whose margin is
    minimised instead of the run's; ``first``: stop after the batch holding
    the first failing run. ``out``: also write the directory (figures when
    ``plots``). Raises ``MissionError`` for an invalid file, ValueError for a
    bad setting, ``SchedulerUnavailable`` when no Dask scheduler answers,
    and the OSError of a write that failed once what was evaluated is kept.
    """
    used = usable_workers(workers)
    with importing_entries():
        loaded = load_campaign(campaign)
    settings = _settings(loaded, method, budget, seed, objective, first)
    if scheduler is not None:
        reach_scheduler(scheduler)
    out_dir = None if out is None else prepare_run_dir(Path(out))
    try:
        with StopSignals() as stop:
            found, record, fault = _falsify(
                loaded, settings, out_dir=out_dir, workers=used, scheduler=scheduler,
                plots=plots, stop=stop, progress_stream=None, campaign_text=str(campaign),
            )  # fmt: skip
    except (UsageError, KeyboardInterrupt, OSError):  # before the first run: nothing to keep
        if out_dir is not None:
            _discard(out_dir)
        raise
    if fault is not None:  # what was evaluated is kept (fault.message says where)
        raise fault.error
    return FalsifyResult(found.evaluations, record, out_dir)


def falsify_command(
    campaign_path: Path,
    *,
    budget: int,
    method: str,
    seed: int | None,
    objective: str | None,
    first: bool,
    workers: int | None,
    scheduler: str | None,
    out: Path | None,
    plots: bool,
) -> int:
    """Exit code: 1 a failing run found (or an invalid file), 0 none within the
    budget, 2 a usage error (a bad flag, an unusable --out or scheduler) or a
    write that failed (a full disk: what was evaluated is kept, said in one
    line), 130 or 143 stopped by SIGINT or SIGTERM (what ran is kept), also
    while the record was written or the figures drawn."""
    return stoppable(
        campaign_path,
        lambda stop: _command(
            campaign_path,
            budget,
            method,
            seed,
            objective,
            first,
            workers,
            scheduler,
            out,
            plots,
            stop,
        ),
    )


def _command(
    campaign_path: Path,
    budget: int,
    method: str,
    seed: int | None,
    objective: str | None,
    first: bool,
    workers: int | None,
    scheduler: str | None,
    out: Path | None,
    plots: bool,
    stop: StopSignals,
) -> int:
    started = time.perf_counter()
    loaded, diagnostics = check_campaign(campaign_path)
    for diagnostic in diagnostics:
        print(diagnostic, file=sys.stderr)
    if loaded is None:
        if not diagnostics:
            print(f"{campaign_path}:1:1: not a campaign file", file=sys.stderr)
        return EXIT_FALSIFIED
    try:
        settings = _settings(loaded, method, budget, seed, objective, first)
    except UsageError as error:
        print(error, file=sys.stderr)
        return EXIT_USAGE
    used = usable_workers(workers)
    if scheduler is not None:
        try:
            reach_scheduler(scheduler)
        except SchedulerUnavailable as error:
            print(f"{campaign_path}: {error}", file=sys.stderr)
            return EXIT_USAGE
        silence(*DASK_LOGS)
    name = f"{loaded.campaign.name}-falsify"
    out_dir = out if out is not None else default_run_dir(name, datetime.now())
    try:
        out_dir = prepare_run_dir(out_dir, suffix_on_collision=out is None)
    except (RunDirExistsError, OSError) as error:
        print(f"{out_dir}: {getattr(error, 'strerror', None) or error}", file=sys.stderr)
        return EXIT_USAGE
    try:
        _, record, fault = _falsify(
            loaded, settings, out_dir=out_dir, workers=used, scheduler=scheduler, plots=plots,
            stop=stop, progress_stream=sys.stderr, campaign_text=str(campaign_path),
        )  # fmt: skip
    except (UsageError, SchedulerUnavailable) as error:
        _discard(out_dir)
        print(error, file=sys.stderr)
        return EXIT_USAGE
    except OSError as error:  # before the first run (manifest.json): nothing to keep
        _discard(out_dir)
        print(f"{_cannot_write(error, out_dir)}; nothing was run", file=sys.stderr)
        return EXIT_USAGE
    except KeyboardInterrupt:  # stopped before its first run: "nothing was written"
        _discard(out_dir)
        raise
    print(_report(record, out_dir, time.perf_counter() - started))
    if fault is not None:
        print(fault.message, file=sys.stderr)
        return EXIT_USAGE
    # A stop held while the record was written or the figures drawn counts as
    # one during the search: the command ends as the signal asked.
    if record["interrupted"] or stop.stopped or stop_owed():
        print(
            f"{campaign_path}: interrupted ({stop.name}); "
            f"the {record['evaluations']} finished runs are kept in {out_dir}",
            file=sys.stderr,
        )
        return stop.exit_code
    return EXIT_FALSIFIED if record["falsified"] else 0


def _discard(out_dir: Path) -> None:
    """Leave no trace of a search that ran nothing: a retry may use the same --out."""
    from wmr_mission.output.rundir import release_run_dir

    for name in (MANIFEST_FILE, EVALUATIONS_FILE):
        (out_dir / name).unlink(missing_ok=True)
    release_run_dir(out_dir)


def _report(record: dict[str, Any], out_dir: Path, seconds: float) -> str:
    method, evaluations = record["method"], record["evaluations"]
    objective = record["objective"]
    # falsify.json's wall_seconds (the start-up and the search), then the whole
    # command's: one number for the search wherever it is read
    lines = [
        f"falsify {record['campaign']} ({method}): {evaluations} runs in "
        f"{record['wall_seconds']:.1f} s; the command took {seconds:.1f} s"
    ]
    best = record["best"]
    if record["falsified"]:
        failing, runs_in = record["failing_runs"], record["runs_to_first_failure"]
        # a run is named by its evaluation number, as its row, failing/N.yaml and
        # the lines below name it: the first is run runs_in - 1
        lines.append(
            f"falsified: {failing} failing run{'s' if failing != 1 else ''}, the first run "
            f"{runs_in - 1} ({runs_in} run{'s' if runs_in != 1 else ''} in); "
            f"lowest {objective} {_text(record['lowest'])}"
        )
        shown = [
            f"  {b['evaluation']}: {b['outcome']}, {objective} {_text(b['objective'])}: {b['run']}"
            for b in best
            if "run" in b
        ]
        if not shown:  # an --objective's lowest runs may all pass: name the failing ones
            shown = [
                f"  {f['evaluation']}: "
                + shlex.join(["wmr-mission", "run", str((out_dir / f["mission"]).resolve())])
                for f in record.get("failing", [])[:BEST]
            ]
        lines += shown
    else:
        lines.append(
            (
                f"no failing run found within the budget of {record['settings']['budget']} runs"
                if evaluations == record["settings"]["budget"]
                else f"no failing run found in the {evaluations} runs done "
                f"(of a budget of {record['settings']['budget']})"
            )
            + f"; lowest {objective} {_text(record['lowest'])}"
            + (f" (run {best[0]['evaluation']}: {best[0]['replay']})" if best else "")
        )
    lines.append(f"written to {out_dir}")
    return "\n".join(lines)


def _text(value: Any) -> str:
    return "none" if value is None else (value if isinstance(value, str) else f"{value:.4g}")
