"""``wmr-mission plot RUN_DIR``: the figures of a run directory, drawn again from its data."""

from __future__ import annotations

import sys
from collections.abc import Sequence
from pathlib import Path

from wmr_mission.output.figures import draw_all
from wmr_mission.output.reader import RunDirError, load_run


def replot_command(
    run_dir: Path,
    formats: Sequence[str] = ("png",),
    style: str = "screen",
    dpi: int | None = None,
) -> int:
    """``wmr-mission plot RUN_DIR``: re-draw the figures from the saved data,
    sized by ``style`` (wmr_mission.output.figures.STYLES), PNGs at ``dpi``
    (default: wmr_mission.output.figures.DPI).

    Exit code: 0 drawn; 1 the run's files are damaged or cannot be drawn; 2 a
    campaign's or falsification's directory, a usage error (as ``view`` and
    ``export`` give for a directory they do not read), or a figure that cannot
    be written (as ``run`` gives)."""
    try:
        result = load_run(run_dir)
    except (RunDirError, OSError) as exc:
        many = _many_runs(run_dir)
        if many is not None:
            print(
                f"{run_dir}: {many}, not a run directory: plot draws one run's figures; "
                f"wmr-mission view {run_dir} reports it",
                file=sys.stderr,
            )
            return 2
        print(f"{run_dir}: {exc}", file=sys.stderr)
        return 1
    try:
        paths = draw_all(result, run_dir, formats, style, dpi)
    except OSError as error:  # a full disk, a directory made read-only: as `run` says it
        print(
            f"{error.filename or run_dir}: cannot write: {error.strerror or error}; "
            "the data are unchanged",
            file=sys.stderr,
        )
        return 2
    except Exception as error:  # a fault in drawing: one line, never a traceback
        print(
            f"{run_dir}: cannot draw the figures ({type(error).__name__}: {error}); "
            "the data are unchanged; please report it",
            file=sys.stderr,
        )
        return 1
    for path in paths:
        print(path)
    return 0


def _many_runs(directory: Path) -> str | None:
    """What a directory of many runs is (its manifest has no run to draw), or None."""
    from wmr_mission.campaign.falsify.files import EVALUATIONS_FILE, FALSIFY_FILE
    from wmr_mission.campaign.reader import is_campaign_dir

    if (directory / FALSIFY_FILE).is_file() and (directory / EVALUATIONS_FILE).is_file():
        return "a falsification directory"
    return "a campaign directory" if is_campaign_dir(directory) else None
