"""Command line: ``wmr-mission run|validate|schema|plot|bench``.

Thin by design: each command parses its flags and calls one function of the
package. Imports are lazy so that ``validate`` and ``--help`` start fast and
never load matplotlib or scipy.
"""

from __future__ import annotations

import io
import os
import sys
import warnings
from enum import StrEnum
from pathlib import Path
from typing import Annotated, Any, TextIO

import typer

app = typer.Typer(
    name="wmr-mission",
    help="Run declarative YAML missions for wheeled non-holonomic mobile robots.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


# Timed runs of `bench`: each keeps its per-sample times in memory.
MAX_REPEAT = 100


class OutputFormat(StrEnum):
    text = "text"
    json = "json"


ExistingFile = Annotated[
    Path,
    typer.Argument(
        exists=True, dir_okay=False, readable=True, metavar="MISSION", help="Mission YAML file."
    ),
]


@app.command()
def run(
    mission: ExistingFile,
    out: Annotated[
        Path | None,
        typer.Option("--out", help="Run directory (default: runs/<mission-name>-<timestamp>)."),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option(
            "--seed",
            min=0,
            max=2**32 - 1,
            help="Sensor-noise seed, 0..2^32-1; overrides the mission's.",
        ),
    ] = None,
    no_plots: Annotated[bool, typer.Option("--no-plots", help="Write data only.")] = False,
    animate: Annotated[
        bool, typer.Option("--animate", help="Also write animation.gif of the robot.")
    ] = False,
) -> None:
    """Simulate MISSION and write trajectory, metrics and plots to a run directory."""
    from wmr_mission.run_command import run_command

    raise typer.Exit(run_command(mission, out=out, seed=seed, plots=not no_plots, animate=animate))


@app.command()
def validate(
    files: Annotated[
        list[Path],
        typer.Argument(exists=True, dir_okay=False, metavar="FILE", help="Mission YAML files."),
    ],
    format: Annotated[
        OutputFormat, typer.Option("--format", help="Report format.")
    ] = OutputFormat.text,
) -> None:
    """Check mission files without running them (exit 0 all valid, 1 any invalid)."""
    from wmr_mission.spec.validate import validate_files

    raise typer.Exit(validate_files(files, fmt=format.value))


@app.command()
def schema() -> None:
    """Print the mission JSON Schema."""
    from wmr_mission.spec.schema import schema_text

    sys.stdout.write(schema_text())


@app.command()
def plot(
    run_dir: Annotated[
        Path,
        typer.Argument(exists=True, file_okay=False, metavar="RUN_DIR", help="A run directory."),
    ],
) -> None:
    """Re-draw the figures of RUN_DIR from its saved data."""
    from wmr_mission.output.plots import replot_command

    raise typer.Exit(replot_command(run_dir))


@app.command()
def bench(
    mission: ExistingFile,
    repeat: Annotated[
        int, typer.Option("--repeat", min=1, max=MAX_REPEAT, help="Runs of the mission to time.")
    ] = 3,
) -> None:
    """Time the estimator + controller step per sample against the reference step."""
    from wmr_mission.bench import bench_command

    raise typer.Exit(bench_command(mission, repeat=repeat))


class _QuietPipe:
    """A standard stream that a closed pipe (``| head -1``) silences instead of
    failing: the rest of the output goes to the null device and the command
    ends with its own exit code."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream

    def write(self, text: str) -> int:
        try:
            return self._stream.write(text)
        except BrokenPipeError:
            self._discard()
            return len(text)

    def flush(self) -> None:
        try:
            self._stream.flush()
        except BrokenPipeError:
            self._discard()

    def _discard(self) -> None:
        null = os.open(os.devnull, os.O_WRONLY)
        os.dup2(null, self._stream.fileno())
        os.close(null)

    def __getattr__(self, name: str) -> Any:
        return getattr(self._stream, name)


def main() -> None:
    if not sys.warnoptions:
        # Numerical warnings (overflow in a diverging run, ...) are reported by
        # the run itself as its outcome; library warnings are not for users.
        warnings.simplefilter("ignore")
    for name in ("stdout", "stderr"):
        stream = getattr(sys, name)
        if isinstance(stream, io.TextIOWrapper):
            # A path that is not UTF-8 is shown escaped rather than failing.
            stream.reconfigure(errors="backslashreplace")
            setattr(sys, name, _QuietPipe(stream))
    app()
