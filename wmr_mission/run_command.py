"""``wmr-mission run``: load, simulate, judge, write, report."""

from __future__ import annotations

import hashlib
import sys
import time
from collections.abc import Sequence
from datetime import datetime
from pathlib import Path
from typing import TYPE_CHECKING

from wmr_mission.result import Outcome, RunResult

if TYPE_CHECKING:
    from wmr_mission.spec.models import Mission


def _load(mission_path: Path, overrides: Sequence[str]) -> Mission | None:
    """The checked mission, every diagnostic (warnings too) printed to stderr first."""
    from wmr_mission.spec.loader import Diagnostic, MissionError, check_mission, parse_override

    parsed = []
    problems: list[Diagnostic] = []
    for text in overrides:
        try:
            parsed.append(parse_override(text))
        except MissionError as error:
            problems += error.diagnostics
    if problems:
        print("\n".join(str(d) for d in problems), file=sys.stderr)
        return None
    mission, diagnostics = check_mission(mission_path, parsed)
    for diagnostic in diagnostics:  # the warnings `validate` would print, before running
        print(diagnostic, file=sys.stderr)
    return mission


def run_command(
    mission_path: Path,
    *,
    out: Path | None,
    seed: int | None,
    plots: bool,
    animate: bool,
    overrides: Sequence[str] = (),
    formats: Sequence[str] = ("png",),
) -> int:
    """Exit code: 0 success, 1 invalid mission or failed run, 2 unusable run directory."""
    mission = _load(mission_path, overrides)
    if mission is None:
        return 1

    from wmr_mission.output.report import format_table
    from wmr_mission.output.rundir import (
        RunDirExistsError,
        default_run_dir,
        prepare_run_dir,
        summary_record,
        write_run,
    )

    run_dir = out if out is not None else default_run_dir(mission.name, datetime.now())
    try:
        run_dir = prepare_run_dir(run_dir)
    except (RunDirExistsError, OSError) as error:
        print(f"{run_dir}: {error}", file=sys.stderr)
        return 2

    started = time.perf_counter()
    result = _simulate(mission, seed)
    wall_seconds = time.perf_counter() - started
    write_run(
        result,
        run_dir,
        mission_sha256=hashlib.sha256(mission_path.read_bytes()).hexdigest(),
        mission_file=str(mission_path),
        plots=plots,
        animate=animate,
        formats=formats,
    )
    print(format_table(summary_record(result), run_dir, wall_seconds=wall_seconds, result=result))
    if result.outcome is not Outcome.success:
        # Every failure message names what happened: "diverged in phase ...",
        # "phase ... timed out ...", "expectation not met: ...".
        print(f"{mission_path}: {result.message}", file=sys.stderr)
        return 1
    return 0


def _simulate(mission: Mission, seed: int | None) -> RunResult:
    """Run with a progress bar on stderr when the run is longer than a moment."""
    import typer

    from wmr_mission.compiled import compile_mission
    from wmr_mission.runner import run_mission

    if compile_mission(mission).max_samples < 20_000 or not sys.stderr.isatty():
        return run_mission(mission, seed=seed)
    name = mission.name
    with typer.progressbar(length=1000, label=f"{name}", file=sys.stderr) as bar:
        done = [0]

        def progress(t: float, total: float, phase: str) -> None:
            step = int(1000 * min(t / total, 1.0)) - done[0]
            if step > 0:
                bar.update(step)
                done[0] += step
            bar.label = f"{name} [{phase}] t = {t:8.2f} s"

        result = run_mission(mission, seed=seed, progress=progress)
        bar.update(1000 - done[0])
    return result
