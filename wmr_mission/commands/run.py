"""``wmr-mission run``: load, simulate, judge, write, report.

What can fail is checked before the simulation (the mission, the run
directory: created, claimed and writable, the free space), and what was
simulated is written even when the run stops early: on SIGINT or SIGTERM the
samples up to the stop are written with the outcome ``interrupted`` and the
command exits 128 + the signal's number (130, 143).

A signal is held from the start (wmr_mission.stopping) and honoured at the
next point where nothing is lost: before the run directory is claimed (the
loop loaded or compiled: a compile stops at once), between chunks of
samples, after the record is written. The directory is claimed just before
the first sample, so a stop before it leaves no directory. A stop answered
by writing the record is said at once (a long record takes seconds to
write), with the rows written on a terminal.
"""

from __future__ import annotations

import hashlib
import json
import shutil
import signal
import sys
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

from wmr_mission.output.result import RunResult
from wmr_mission.record import Outcome

if TYPE_CHECKING:
    from wmr_mission.output.progress import Steps
    from wmr_mission.sim.plan import MissionPlan
    from wmr_mission.sim.plant_side import PlantSide
    from wmr_mission.spec.loader import Override
    from wmr_mission.spec.models import Mission

# Exit codes (README, docs/reliability.md).
EXIT_FAILED = 1  # invalid mission, or the run failed
EXIT_RUN_DIR = 2  # the run directory cannot be made or written
EXIT_UNREADABLE = 2  # the mission file cannot be read (a device, a read error)
STOP_SIGNALS = (signal.SIGINT, signal.SIGTERM)
# Samples from which simulating or writing them lasts more than a moment: a
# progress bar on a terminal.
LONG_RUN_SAMPLES = 20_000


def _overrides(texts: Sequence[str]) -> list[Override] | int:
    """Each ``--set PATH=VALUE``; the exit code (the problems printed) when one
    is malformed: 2 when it is not PATH=VALUE, 1 when its VALUE is not one."""
    from wmr_mission.spec.loader import overrides_of_texts

    parsed, problems, code = overrides_of_texts(texts)
    for problem in problems:
        print(problem, file=sys.stderr)
    return code if problems else parsed


@contextmanager
def _stop_signals() -> Iterator[list[int]]:
    """SIGTERM stops the run the way Ctrl-C does, held until a point where
    nothing is lost (see the module); yields the signals received."""
    from wmr_mission.stopping import HOLD, StopSignals

    with StopSignals(STOP_SIGNALS, HOLD) as stop:
        yield stop.received


def _honour_stop() -> None:
    from wmr_mission.stopping import stop_owed

    if stop_owed():
        raise KeyboardInterrupt


def _signal_exit(received: list[int]) -> int:
    return 128 + (received[0] if received else signal.SIGINT)


def _signal_name(received: list[int]) -> str:
    return signal.Signals(received[0]).name if received else "SIGINT"


def run_command(
    mission_path: Path,
    *,
    out: Path | None,
    seed: int | None,
    plots: bool,
    animate: bool,
    overrides: Sequence[str] = (),
    formats: Sequence[str] = ("png",),
    expected_environment: str | None = None,
    expected_mission: str | None = None,
    backend: str | None = None,
) -> int:
    """Exit code: 0 success; 1 invalid mission or failed run; 2 unreadable
    mission file or unusable run directory; 130 or 143 stopped by SIGINT or
    SIGTERM (its record is written).

    ``overrides``: ``PATH=VALUE`` texts of ``--set``; ``formats``: figure formats;
    ``expected_environment``: the fingerprint of ``--expect-environment``;
    ``expected_mission``: the start of the sha256 of ``--expect-mission``;
    ``backend``: the plant (``--backend``), else the mission's ``backend.type``.
    """
    with _stop_signals() as received:
        if expected_environment is not None:
            _check_environment(expected_environment)
        from wmr_mission.spec.checks import importing_entries
        from wmr_mission.spec.loader import check_mission_bytes, read_source, unreadable

        try:
            parsed = _overrides(overrides)
            if isinstance(parsed, int):
                return parsed
            # The file is read once: the bytes hashed are the bytes run.
            source, diagnostics = read_source(mission_path)
            mission = None
            if source is not None:
                with importing_entries():  # a run imports its plug-ins
                    mission, diagnostics = check_mission_bytes(source, str(mission_path), parsed)
                if mission is None and _is_campaign(source):
                    diagnostics = []
                    print(
                        f"{mission_path}: this is a campaign: run it with "
                        f"`wmr-mission sweep {mission_path}`",
                        file=sys.stderr,
                    )
            for diagnostic in diagnostics:  # warnings too, as `validate` prints them
                print(diagnostic, file=sys.stderr)
            _honour_stop()
            if source is None and unreadable(diagnostics):
                return EXIT_UNREADABLE
            if mission is None or source is None:
                return EXIT_FAILED
            sha256 = hashlib.sha256(source).hexdigest()
            if expected_mission is not None and not sha256.startswith(expected_mission):
                print(
                    f"wmr-mission: warning: {mission_path} is not the file the command was "
                    f"recorded with (its sha256 begins {sha256[: len(expected_mission)]}, not "
                    f"{expected_mission}): this run does not replay the recorded one",
                    file=sys.stderr,
                )
            written = Written(source, sha256, tuple(parsed))
            args = (mission, written, mission_path, out, seed, plots, animate, formats, received)
            name = backend or mission.backend.type
            code = _run(*args) if name == "sim" else _run_on_backend(name, *args)
            if received and code != _signal_exit(received):  # it came as the run ended
                print(
                    f"{mission_path}: {_signal_name(received)} as the run ended; "
                    "its record is complete",
                    file=sys.stderr,
                )
                return _signal_exit(received)
            return code
        except KeyboardInterrupt:
            print(f"{mission_path}: interrupted before the simulation", file=sys.stderr)
            return _signal_exit(received)


def _run_on_backend(
    name: str, mission: Mission, written: Written, mission_path: Path, out: Path | None,
    seed: int | None, *args: Any,
) -> int:  # fmt: skip
    """``_run`` with another plant than our simulator (wmr_mission.backends):
    one line and exit 1 when it cannot be used (its extra missing, no robot)."""
    from wmr_mission.backends import BackendError, open_backend
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.stopping import RAISE, mode

    settings = mission.backend.model_copy(update={"type": name})
    plan = plan_mission(mission, seed)
    try:
        with ExitStack() as stack:
            with mode(RAISE):  # waiting for a robot: a stop ends the wait at once
                plant = stack.enter_context(open_backend(name, plan, settings))
            return _run(mission, written, mission_path, out, seed, *args, plant=plant, plan=plan)
    except BackendError as error:
        print(f"{mission_path}: {error}", file=sys.stderr)
        return EXIT_FAILED


class Written(NamedTuple):
    """The mission as run: the bytes read once (hashed, checked and run), and
    the fields ``--set`` set in it."""

    source: bytes
    sha256: str
    overrides: tuple[Override, ...]


def _located(mission_path: Path, written: Written, result: RunResult) -> str:
    """``FILE:LINE:COL`` of what a failed run failed on, as the mission wrote
    it (wmr_mission.spec.located); the ``--set`` that set it; ``FILE`` alone
    where nothing written names it."""
    from wmr_mission.spec.loader import apply_override, read_document
    from wmr_mission.spec.located import failure_path

    # the phase of the run's last sample, the one it ended in
    phase = result.phases[int(result.phase[-1])].name if result.samples else None
    metric = None
    missed = [c for c in (result.judged or {}).get("expectations") or () if not c.get("met")]
    if result.outcome is Outcome.expect_failed and missed:
        phase, metric = missed[0].get("phase"), str(missed[0].get("metric"))
    document, _ = read_document(written.source.decode("utf-8", "replace"))
    if document is None:
        return str(mission_path)
    for setting in written.overrides:  # checked with the mission: each lands
        apply_override(document, setting)
    path = failure_path(document.data, result.outcome, phase, metric)
    if path is None:
        return str(mission_path)
    said = document.override_of(path)
    if said is not None:  # not the file's value: how the command line wrote it
        return said
    line, column = document.position(path, at_key=True)
    return f"{mission_path}:{line}:{column}" if line else str(mission_path)


def _is_campaign(source: bytes) -> bool:
    from wmr_mission.spec.loader import document_kind

    try:
        return document_kind(source.decode("utf-8")) == "campaign"
    except UnicodeDecodeError:
        return False


def _check_environment(expected: str) -> None:
    """One line on stderr when this environment is not the one a command was
    recorded in: the run may then differ from the recorded one in the last digits."""
    from wmr_mission.output.environment import own_fingerprint

    mine = own_fingerprint()
    if mine != expected:
        print(
            f"wmr-mission: warning: this environment's fingerprint is {mine}, not {expected} "
            "as where the command was recorded: the results may differ in the last digits "
            '(manifest.json\'s "versions" and "environment" say what this one is)',
            file=sys.stderr,
        )


def _run(
    mission: Mission,
    written: Written,
    mission_path: Path,
    out: Path | None,
    seed: int | None,
    plots: bool,
    animate: bool,
    formats: Sequence[str],
    received: list[int],
    *,
    plant: PlantSide | None = None,
    plan: MissionPlan | None = None,
) -> int:
    """Simulate ``mission`` (``plan``: as planned already, for another plant),
    judge it, write its run directory and print its table; the exit code."""
    from wmr_mission.commands import start_up_done
    from wmr_mission.commands.compile import choose_loop
    from wmr_mission.output.report import format_table
    from wmr_mission.output.rundir import (
        RunDirExistsError,
        default_run_dir,
        prepare_run_dir,
        release_run_dir,
        space_needed,
        summary_record,
        write_run,
    )
    from wmr_mission.sim.plan import plan_mission, sample_budget
    from wmr_mission.verdicts.metrics import judge_mission

    # Before the loop is loaded: plain Python where loading it would cost more.
    # Another plant runs the loop as plain Python: nothing to compile.
    notice = choose_loop(sample_budget(mission)) if plant is None else None
    if notice is not None:
        print(notice, file=sys.stderr)
    compiled = plan if plan is not None else plan_mission(mission, seed)
    wanted = out if out is not None else default_run_dir(mission.name, datetime.now())
    claimed: list[Path] = []

    def claim() -> None:
        """The run directory, claimed once the loop is loaded (a compile can
        take a minute), just before the first sample."""
        start_up_done()
        try:
            run_dir = prepare_run_dir(wanted, suffix_on_collision=out is None)
        except (RunDirExistsError, OSError) as error:
            print(f"{wanted}: {getattr(error, 'strerror', None) or error}", file=sys.stderr)
            raise _Unclaimed from error
        claimed.append(run_dir)
        needed = space_needed(compiled.max_samples)
        free = shutil.disk_usage(run_dir).free
        if free < needed:
            print(
                f"{run_dir}: warning: {free / 1e6:.3g} MB free; this run may write up to "
                f"{needed / 1e6:.3g} MB",
                file=sys.stderr,
            )

    try:
        started = time.perf_counter()
        result = _simulate(compiled, plant, claim)
        saving = _Saving(mission_path, result, claimed, received)
        if result.outcome is Outcome.interrupted and result.samples > 0:
            saving.say()  # before the judge: judging and writing a long record take seconds
        judge_mission(result, mission)  # a success that misses an `expect` is not one
        wall_seconds = time.perf_counter() - started
    except _Unclaimed:
        return EXIT_RUN_DIR
    except MemoryError:
        for run_dir in claimed:
            release_run_dir(run_dir)
        print(
            f"{mission_path}: not enough memory to simulate {compiled.max_samples} samples; "
            "shorten the phases' time bounds or raise dt",
            file=sys.stderr,
        )
        return EXIT_FAILED
    except BaseException:
        for run_dir in claimed:
            release_run_dir(run_dir)
        raise
    # judged by the mission's `expect` above (verdicts.metrics.judge_mission).
    stopped = result.outcome is Outcome.interrupted
    if stopped and result.samples == 0:  # stopped before the first sample: nothing to keep
        for run_dir in claimed:
            release_run_dir(run_dir)
        raise KeyboardInterrupt
    try:
        if not claimed:  # a plug-in that failed before the first sample
            claim()
    except _Unclaimed:
        return EXIT_RUN_DIR
    run_dir = claimed[0]
    if stopped:
        result.message = f"{result.message} by {_signal_name(received)}"
    try:  # the data and summary.json first: a figure that fails never loses them
        with saving:
            write_run(
                result,
                run_dir,
                mission_sha256=written.sha256,
                mission_file=str(mission_path),
                plots=False,
                animate=False,
                progress=saving.rows,
            )
    except OSError as error:
        print(
            f"{error.filename or run_dir}: cannot write: {error.strerror or error}; "
            f"{run_dir} holds only the files written before (no summary.json)",
            file=sys.stderr,
        )
        return EXIT_RUN_DIR
    if plant is not None:
        _confirm_stop(plant, result, run_dir)
    print(
        format_table(summary_record(result), run_dir, wall_seconds=wall_seconds, result=result),
        end="",
    )
    if received and not stopped:  # the stop came once every sample was simulated
        undrawn = (
            f"; no figure was drawn: `wmr-mission plot {run_dir}` draws them"
            if plots or animate
            else ""
        )
        print(
            f"{mission_path}: {_signal_name(received)} after the simulation ended; "
            f"the run is written whole in {run_dir}{undrawn}",
            file=sys.stderr,
        )
        return _signal_exit(received)
    # A stopped run writes its data at once; `wmr-mission plot` draws it.
    drawn = _draw(
        result, run_dir, plots and not stopped, animate and not stopped, formats, received
    )
    if stopped:
        print(
            f"{mission_path}: {result.message}; the samples up to the stop are in {run_dir}",
            file=sys.stderr,
        )
        return _signal_exit(received)
    if result.outcome is not Outcome.success:
        # Every failure message names what happened: "diverged in phase ...",
        # "phase ... timed out ...", "expectation not met: ...", and where
        # the mission wrote what failed.
        print(f"{_located(mission_path, written, result)}: {result.message}", file=sys.stderr)
        return EXIT_FAILED
    return drawn


# summary.json's realtime field that the wait for the plant's stop settles
ACKNOWLEDGED = "zero_command_acknowledged"


def _confirm_stop(plant: PlantSide, result: RunResult, run_dir: Path) -> None:
    """The plant's confirmation that it stopped (a robot's acknowledgement of
    the zero command, up to 5 s), waited for once the record is written: a
    robot killed mid-run makes the whole wait go by, and nothing may come
    between what was simulated and its record. summary.json's ``realtime``
    then says it (until then, and where it cannot be written, null)."""
    from wmr_mission.output.files import write_json
    from wmr_mission.output.rundir import SUMMARY_FILE

    plant.confirm_stop()
    # Only the acknowledgement is new: the rest of the report stays as the run
    # ended and was judged (a plan refused during the wait is not the run's).
    report = plant.report()
    if report is None or result.realtime is None or ACKNOWLEDGED not in result.realtime:
        return  # a plant without a stop to confirm
    acknowledged = report.get(ACKNOWLEDGED)
    if result.realtime[ACKNOWLEDGED] == acknowledged:
        return
    result.realtime = {**result.realtime, ACKNOWLEDGED: acknowledged}
    path = run_dir / SUMMARY_FILE
    try:
        summary = json.loads(path.read_text(encoding="utf-8"))
        summary["realtime"] = result.realtime
        write_json(path, summary)
    except (OSError, ValueError) as error:
        reason = error.strerror if isinstance(error, OSError) and error.strerror else error
        print(
            f"{path}: cannot update: {reason}; its realtime is as the run ended, "
            "before the plant confirmed its stop",
            file=sys.stderr,
        )


class _Unclaimed(Exception):
    """The run directory could not be claimed (said in one line)."""


class _Saving:
    """What ``run`` says while it writes the record of a run a signal
    stopped, or that a signal came to as it ended: at once, one line that it
    is saving (seconds of silence over a long record made users press Ctrl-C
    again, or kill it, and lose the record); then, for a long record on a
    terminal, the rows of trajectory.csv written. Nothing for a run no
    signal came to."""

    def __init__(
        self, mission_path: Path, result: RunResult, claimed: list[Path], received: list[int]
    ) -> None:
        self._mission_path = mission_path
        self._result = result
        self._claimed = claimed  # the run directory, once claimed
        self._received = received
        self._said = False
        self._steps: Steps | None = None

    def say(self) -> None:
        """The line that the record of what was simulated is being saved."""
        self._said = True
        name, samples = _signal_name(self._received), self._result.samples
        if self._result.outcome is Outcome.interrupted:
            what = f"{self._result.message} by {name}; saving its {samples:,} samples"
        else:
            what = f"{name} after the simulation ended; saving the whole run, {samples:,} samples,"
        again = "Ctrl-C again" if name == "SIGINT" else "a second signal"
        where = f" to {self._claimed[0]}" if self._claimed else ""
        print(
            f"{self._mission_path}: {what}{where} ({again} is ignored until they are saved)",
            file=sys.stderr,
            flush=True,
        )

    def rows(self, written: int) -> None:
        """The write's progress: ``written`` rows of trajectory.csv so far."""
        if not self._said:
            if not self._received:  # the usual case: a run no signal came to
                return
            self.say()
        samples = self._result.samples
        if self._steps is None and samples >= LONG_RUN_SAMPLES:
            from wmr_mission.output.progress import Steps
            from wmr_mission.output.rundir import TRAJECTORY_FILE

            self._steps = Steps(sys.stderr)  # drawn on a terminal only
            self._steps.step(f"saving {TRAJECTORY_FILE}", total=samples)
        if self._steps is not None:
            self._steps.update(written, detail=f"{written:,} of {samples:,} rows")

    def __enter__(self) -> _Saving:
        return self

    def __exit__(self, *_: object) -> None:
        if self._steps is not None:  # the bar ends before what is printed next
            self._steps.close()


def _draw(
    result: RunResult,
    run_dir: Path,
    plots: bool,
    animate: bool,
    formats: Sequence[str],
    received: list[int],
) -> int:
    """Draw the figures of a written run: 0, or the exit code of a failure,
    said in one line (the data and summary.json stay)."""
    from wmr_mission.output.rundir import write_figures
    from wmr_mission.stopping import RAISE, mode

    kept = f"the data and summary.json are in {run_dir}; `wmr-mission plot {run_dir}` draws again"
    try:
        with mode(RAISE):  # the record is written: a stop ends the drawing at once
            write_figures(result, run_dir, plots=plots, animate=animate, formats=formats)
    except OSError as error:
        print(
            f"{error.filename or run_dir}: cannot write: {error.strerror or error}; {kept}",
            file=sys.stderr,
        )
        return EXIT_RUN_DIR
    except KeyboardInterrupt:
        print(f"{run_dir}: interrupted while drawing; {kept}", file=sys.stderr)
        return _signal_exit(received)
    except Exception as error:  # a fault in drawing must not look like a lost run
        print(
            f"{run_dir}: cannot draw the figures ({type(error).__name__}: {error}); {kept}; "
            "please report it",
            file=sys.stderr,
        )
        return EXIT_FAILED
    return 0


def _simulate(
    plan: MissionPlan,
    plant: PlantSide | None = None,
    ready: Callable[[], None] | None = None,
) -> RunResult:
    """Run the mission planned (checked when it was loaded, planned once) with a
    progress bar on stderr (a terminal) when the run is longer than a moment;
    ``ready()`` just before the first sample."""
    from wmr_mission.output.progress import Steps
    from wmr_mission.sim.runner import run_mission

    if plan.max_samples < LONG_RUN_SAMPLES or not sys.stderr.isatty():
        return run_mission(plan, plant=plant, ready=ready)
    name = plan.name
    steps = Steps(sys.stderr)
    steps.step(name, total=1000)

    def progress(t: float, budget: float, phase: str) -> None:
        steps.update(1000 * min(t / budget, 1.0), description=f"{name} [{phase}] t = {t:8.2f} s")

    try:
        result = run_mission(plan, progress=progress, plant=plant, ready=ready)
        steps.update(1000)
    finally:
        steps.close()
    return result
