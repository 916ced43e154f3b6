"""``wmr-mission run``: load, simulate, judge, write, report."""

from __future__ import annotations

import hashlib
import sys
from datetime import datetime
from pathlib import Path
from typing import Any

from wmr_mission.result import Outcome, RunResult


def run_command(
    mission_path: Path, *, out: Path | None, seed: int | None, plots: bool, animate: bool
) -> int:
    """Exit code: 0 success, 1 invalid mission or failed run, 2 unusable run directory."""
    from wmr_mission.spec.loader import MissionError, load_mission

    try:
        mission = load_mission(mission_path)
    except MissionError as error:
        print(error, file=sys.stderr)
        return 1

    from wmr_mission.compiled import compile_mission
    from wmr_mission.output.metrics import judge
    from wmr_mission.output.report import format_table
    from wmr_mission.output.rundir import (
        RunDirExistsError,
        default_run_dir,
        prepare_run_dir,
        write_run,
    )

    run_dir = out if out is not None else default_run_dir(mission.name, datetime.now())
    try:
        run_dir = prepare_run_dir(run_dir)
    except (RunDirExistsError, OSError) as error:
        print(f"{run_dir}: {error}", file=sys.stderr)
        return 2

    compiled = compile_mission(mission, seed)
    result = _simulate(compiled, mission.name)
    resolved = mission.model_dump(mode="json")
    if seed is not None:  # the manifest records the mission as run
        resolved["sensors"]["seed"] = seed
    summary = judge(result, resolved)  # a success that misses an `expect` is not one
    write_run(
        result,
        run_dir,
        mission_sha256=hashlib.sha256(mission_path.read_bytes()).hexdigest(),
        resolved_mission=resolved,
        mission_file=str(mission_path),
        plots=plots,
        animate=animate,
    )
    print(format_table(summary, run_dir))
    if result.outcome is not Outcome.success:
        # Every failure message names what happened: "diverged in phase ...",
        # "phase ... timed out ...", "expectation not met: ...".
        print(f"{mission_path}: {result.message}", file=sys.stderr)
        return 1
    return 0


def _simulate(compiled: Any, name: str) -> RunResult:
    """Run with a progress bar on stderr when the run is longer than a moment."""
    import typer

    from wmr_mission.runner import run_mission

    if compiled.max_samples < 20_000 or not sys.stderr.isatty():
        return run_mission(compiled)
    with typer.progressbar(length=1000, label=f"{name}", file=sys.stderr) as bar:
        done = [0]

        def progress(t: float, budget: float, phase: str) -> None:
            step = int(1000 * min(t / budget, 1.0)) - done[0]
            if step > 0:
                bar.update(step)
                done[0] += step
            bar.label = f"{name} [{phase}] t = {t:8.2f} s"

        result = run_mission(compiled, progress=progress)
        bar.update(1000 - done[0])
    return result
