"""Command line: ``wmr-mission run|sweep|falsify|validate|schema|plot|view|export|bench|compile``,
``--version``.

Thin by design: each command parses its flags and calls one function of the
package. Imports are lazy so that ``validate`` and ``--help`` start fast and
never load matplotlib or scipy.
"""

from __future__ import annotations

import atexit
import gc
import io
import os
import re
import sys
import warnings
from collections.abc import Sequence
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, TextIO

import typer
from typer.core import TyperCommand

from wmr_mission.campaign.falsify import DEFAULT_METHOD, METHODS
from wmr_mission.terminal import shown

if TYPE_CHECKING:
    from wmr_mission.stopping import StopSignals


class _Command(TyperCommand):
    """Help that names each argument alone: ``MISSION``, not ``{MISSION}`` in
    the usage line nor ``MISSION <file>`` under Arguments."""

    def collect_usage_pieces(self, ctx: Any) -> list[str]:
        return [
            piece.replace("{", "").replace("}", "") for piece in super().collect_usage_pieces(ctx)
        ]

    def format_options(self, ctx: Any, formatter: Any) -> None:
        parameters = [p for p in self.get_params(ctx) if not getattr(p, "hidden", False)]
        arguments = [
            (f"{p.metavar}{'...' if p.nargs != 1 else ''}", getattr(p, "help", None) or "")
            for p in parameters
            if p.param_type_name == "argument"
        ]
        options = [p.get_help_record(ctx) for p in parameters if p.param_type_name == "option"]
        for title, records in (("Arguments", arguments), ("Options", options)):
            if records:
                with formatter.section(title):
                    formatter.write_dl([record for record in records if record is not None])


_SETTINGS: dict[str, Any] = {
    "name": "wmr-mission",
    "help": "Run declarative YAML missions for wheeled non-holonomic mobile robots.",
    "no_args_is_help": True,
    "add_completion": False,
    "pretty_exceptions_enable": False,
    # Plain help: flags show as flags (`--animate`), not as `--animate <bool>`.
    "rich_markup_mode": None,
    "context_settings": {"help_option_names": ["-h", "--help"]},
}
app = typer.Typer(**_SETTINGS)
command = app.command(cls=_Command)


def _command_line(arguments: Sequence[str]) -> typer.Typer:
    """The command line with the command named first alone, else the whole
    (help, ``--version``, a name mistyped): typer builds the options of every
    command it holds as it starts, a hundredth of a second of CPU for all
    (docs/performance.md, Start-up); the one named says the same either way."""
    from typer.main import get_command_name

    name = arguments[0] if arguments else ""
    for info in app.registered_commands:
        if info.callback is not None and name == (
            info.name or get_command_name(info.callback.__name__)
        ):
            alone = typer.Typer(**_SETTINGS)
            alone.registered_callback = app.registered_callback
            alone.registered_commands = [info]
            return alone
    return app


# The signals main() holds until the command starts (_main).
_STARTING: list[StopSignals] = []
# The commands that catch the signals themselves and honour one held before.
_TAKE_SIGNALS = frozenset({"run", "sweep", "falsify", "bench"})
# The commands that turn Python's cyclic collector on themselves once they have
# started up (wmr_mission.commands.start_up_done); for the others it is on as
# they begin.
_SHORT = frozenset({"run", "validate"})
# Timed runs of `bench`: each keeps its per-sample times in memory.
MAX_REPEAT = 100
# `sweep --runs`: at most a campaign's own `runs` (wmr_mission.campaign.models.MAX_RUNS),
# written here so that `--help` loads no model.
MAX_SWEEP_RUNS = 10_000_000
# `plot --dpi`: wmr_mission.output.figures.DPI_RANGE, written here for the same reason.
DPI_RANGE = (50, 600)


def _version(value: bool) -> None:
    if value:
        from wmr_mission.version import __version__

        print(f"wmr-mission {__version__}")
        raise typer.Exit(0)


@app.callback()
def _main(
    ctx: typer.Context,
    version: Annotated[
        bool,
        typer.Option(
            "--version", callback=_version, is_eager=True, help="Print the version and exit."
        ),
    ] = False,
) -> None:
    """Run declarative YAML missions for wheeled non-holonomic mobile robots."""
    from wmr_mission.stopping import RAISE

    # The command starts: a stop held since main() is raised now. From now on
    # a stop acts at once, but for the commands that take the signals
    # themselves: they are held until then, never raised inside the imports
    # on the way (a KeyboardInterrupt in a compiled module's import marks the
    # interpreter to exit by SIGINT whatever the command returns).
    for early in _STARTING:
        if early.owed:
            raise KeyboardInterrupt
        if ctx.invoked_subcommand not in _TAKE_SIGNALS:
            early.mode = RAISE
    if ctx.invoked_subcommand not in _SHORT:
        from wmr_mission.commands import start_up_done

        start_up_done()


class OutputFormat(StrEnum):
    text = "text"
    json = "json"


class FigureFormat(StrEnum):
    png = "png"
    svg = "svg"
    pdf = "pdf"


class FigureStyle(StrEnum):
    screen = "screen"
    one_column = "one-column"
    two_column = "two-column"


FigureFormats = Annotated[
    list[FigureFormat] | None,
    typer.Option(
        "--format",
        metavar="FORMAT",
        help="Figure file format: png, svg or pdf; repeat for several (default: png).",
    ),
]


# The options the campaign commands (sweep, falsify) and run share.
Workers = Annotated[
    int | None,
    typer.Option(
        "--workers",
        metavar="N",
        min=1,
        help="Local worker processes (default: every core this process may use, "
        "by its CPU affinity and quota).",
    ),
]
Scheduler = Annotated[
    str | None,
    typer.Option(
        "--scheduler",
        metavar="ADDRESS",
        help="Run on this Dask scheduler (tcp://host:8786); needs wmr-mission[dask].",
    ),
]
NoPlots = Annotated[bool, typer.Option("--no-plots", help="Write data only.")]


def _formats(chosen: list[FigureFormat] | None) -> tuple[str, ...]:
    return tuple(dict.fromkeys(f.value for f in chosen)) if chosen else ("png",)


class BackendName(StrEnum):
    sim = "sim"
    irsim = "irsim"
    ros2 = "ros2"


ExistingFile = Annotated[
    Path,
    typer.Argument(
        exists=True, dir_okay=False, readable=True, metavar="MISSION", help="Mission YAML file."
    ),
]


@command
def run(
    mission: ExistingFile,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            metavar="DIR",
            help="Run directory (default: runs/<mission-name>-<timestamp>).",
        ),
    ] = None,
    seed: Annotated[
        int | None,
        typer.Option(
            "--seed",
            metavar="N",
            min=0,
            max=2**32 - 1,
            help="Seed of every random draw (noise and disturbances); overrides the mission's.",
        ),
    ] = None,
    set_: Annotated[
        list[str] | None,
        typer.Option(
            "--set",
            metavar="PATH=VALUE",
            help="Override a mission field by its dotted path, VALUE read as YAML "
            "(--set robot.dt=0.02, --set controller.Q=[1,1,2]); repeatable.",
        ),
    ] = None,
    no_plots: NoPlots = False,
    animate: Annotated[
        bool, typer.Option("--animate", help="Also write animation.gif of the robot.")
    ] = False,
    format: FigureFormats = None,
    expect_environment: Annotated[
        str | None,
        typer.Option(
            "--expect-environment",
            metavar="FINGERPRINT",
            help="The environment fingerprint the command was recorded in (a campaign's "
            "replay commands carry it); a one-line warning when this one differs.",
        ),
    ] = None,
    expect_mission: Annotated[
        str | None,
        typer.Option(
            "--expect-mission",
            metavar="DIGEST",
            help="The first hexadecimal digits of the sha256 of the mission file the command "
            "was recorded with (a campaign's replay commands carry them); a one-line warning "
            "when MISSION's differ.",
        ),
    ] = None,
    backend: Annotated[
        BackendName | None,
        typer.Option(
            "--backend",
            metavar="NAME",
            help="The plant: sim (our simulator), irsim (IR-SIM), ros2 (a robot over ROS 2, "
            "in real time); default: the mission's backend.type, else sim.",
        ),
    ] = None,
) -> None:
    """Simulate MISSION and write trajectory, metrics and plots to a run directory."""
    from wmr_mission.commands.run import run_command

    if expect_environment is not None:
        _check_fingerprint(expect_environment)
    if expect_mission is not None:
        _check_mission_digest(expect_mission)

    raise typer.Exit(
        run_command(
            mission,
            out=out,
            seed=seed,
            plots=not no_plots,
            animate=animate,
            overrides=set_ or (),
            formats=_formats(format),
            expected_environment=expect_environment,
            expected_mission=expect_mission,
            backend=None if backend is None else backend.value,
        )
    )


def _check_fingerprint(text: str) -> None:
    """``--expect-environment`` takes a fingerprint as a campaign's replay line
    writes it, and nothing else (a usage error, exit 2)."""
    from wmr_mission.output.environment import FINGERPRINT_FORM

    if FINGERPRINT_FORM.fullmatch(text) is None:
        print(
            f"--expect-environment {shown(text)}: not a fingerprint: 8 hexadecimal digits "
            "(0-9, a-f), as a campaign's replay commands write it",
            file=sys.stderr,
        )
        raise typer.Exit(2)


def _check_mission_digest(text: str) -> None:
    """``--expect-mission`` takes the start of a sha256 as a campaign's replay
    line writes it (8 to 64 hexadecimal digits), and nothing else (exit 2)."""
    if re.fullmatch(r"[0-9a-f]{8,64}", text) is None:
        print(
            f"--expect-mission {shown(text)}: not the start of a sha256: 8 to 64 hexadecimal "
            "digits (0-9, a-f), as a campaign's replay commands write it",
            file=sys.stderr,
        )
        raise typer.Exit(2)


@app.command(name="serve-robot", cls=_Command)
def serve_robot(
    mission: ExistingFile,
    seed: Annotated[
        int | None,
        typer.Option(
            "--seed",
            metavar="N",
            min=0,
            max=2**32 - 1,
            help="Seed of every random draw (noise and disturbances); overrides the mission's.",
        ),
    ] = None,
    plan_from: Annotated[
        Path | None,
        typer.Option(
            "--plan-from",
            metavar="PLANS.yaml",
            exists=True,
            dir_okay=False,
            help="A stand-in planner too: publish the paths of this mission's updates "
            "written on time (mission_time, or elapsed in its first phase) as nav_msgs/Path "
            "on the plan topic, timed from the first command.",
        ),
    ] = None,
) -> None:
    """A stand-in robot over ROS 2: MISSION's plant, disturbances and sensors in real
    time, on cmd_vel and odom, until Ctrl-C (for `run --backend ros2`)."""
    from wmr_mission.commands.serve_robot import serve_robot_command

    raise typer.Exit(serve_robot_command(mission, seed=seed, plan_from=plan_from))


@command
def sweep(
    campaign: Annotated[
        Path,
        typer.Argument(
            exists=True,
            dir_okay=False,
            readable=True,
            metavar="CAMPAIGN",
            help="Campaign YAML file.",
        ),
    ],
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            metavar="DIR",
            help="Campaign directory (default: runs/<campaign-name>-<timestamp>).",
        ),
    ] = None,
    workers: Workers = None,
    scheduler: Scheduler = None,
    runs: Annotated[
        int | None,
        typer.Option(
            "--runs",
            metavar="N",
            min=1,
            max=MAX_SWEEP_RUNS,
            help="Runs per grid cell, instead of the campaign's `runs`.",
        ),
    ] = None,
    set_: Annotated[
        list[str] | None,
        typer.Option(
            "--set",
            metavar="PATH=VALUE",
            help="Set a field of the campaign's mission for every run, as run --set does "
            "(--set robot.dt=0.02); repeatable; carried into each replay command.",
        ),
    ] = None,
    no_plots: NoPlots = False,
    allow_mixed_cluster: Annotated[
        bool,
        typer.Option(
            "--allow-mixed-cluster",
            help="Run on a Dask cluster whose workers differ from this machine in what "
            "decides the bytes (versions, C math library); their rows may then differ in "
            "the last digits from a local run's. Refused by default.",
        ),
    ] = False,
) -> None:
    """Run CAMPAIGN: its mission many times with fields varied; write runs.csv, campaign.json."""
    from wmr_mission.campaign.sweep import sweep_command

    raise typer.Exit(
        sweep_command(
            campaign,
            out=out,
            workers=workers,
            scheduler=scheduler,
            plots=not no_plots,
            allow_mixed_cluster=allow_mixed_cluster,
            runs=runs,
            settings=set_ or (),
        )
    )


@command
def falsify(
    campaign: Annotated[
        Path,
        typer.Argument(
            exists=True,
            dir_okay=False,
            readable=True,
            metavar="CAMPAIGN",
            help="Campaign YAML file: its `vary` axes are searched.",
        ),
    ],
    budget: Annotated[
        int,
        typer.Option(
            "--budget", metavar="N", min=1, max=1_000_000, help="Most runs (default 300)."
        ),
    ] = 300,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            metavar="METHOD",
            help=f"One of {', '.join(METHODS)}.",
        ),
    ] = DEFAULT_METHOD,
    seed: Annotated[
        int | None,
        typer.Option(
            "--seed",
            metavar="N",
            min=0,
            max=2**32 - 1,
            help="Seed of the search and of each run's sensors (default: the campaign's).",
        ),
    ] = None,
    objective: Annotated[
        str | None,
        typer.Option(
            "--objective",
            metavar="CHECK",
            help="Minimise this check's margin ('phase: metric', or a metric for each of "
            "its checks) instead of the run's.",
        ),
    ] = None,
    first: Annotated[
        bool, typer.Option("--first", help="Stop after the batch holding the first failing run.")
    ] = False,
    workers: Workers = None,
    scheduler: Scheduler = None,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            metavar="DIR",
            help="Output directory (default: runs/<campaign-name>-falsify-<timestamp>).",
        ),
    ] = None,
    no_plots: NoPlots = False,
) -> None:
    """Search CAMPAIGN's axes for failing runs; exit 1 when one is found, 0 when none."""
    from wmr_mission.campaign.falsify.command import falsify_command

    raise typer.Exit(
        falsify_command(
            campaign,
            budget=budget,
            method=method,
            seed=seed,
            objective=objective,
            first=first,
            workers=workers,
            scheduler=scheduler,
            out=out,
            plots=not no_plots,
        )
    )


@command
def validate(
    files: Annotated[
        list[Path],
        typer.Argument(
            metavar="FILE",
            help="Mission or campaign YAML files; a directory stands for every *.yaml and "
            "*.yml below it.",
        ),
    ],
    format: Annotated[
        OutputFormat,
        typer.Option("--format", metavar="FORMAT", help="Report format: text or json."),
    ] = OutputFormat.text,
    check_entries: Annotated[
        bool,
        typer.Option(
            "--check-entries",
            help="Also import each `type: python` entry (runs its module's code, as a run does).",
        ),
    ] = False,
    strict: Annotated[
        bool,
        typer.Option("--strict", help="Warnings are errors (exit 1); notes are not."),
    ] = False,
) -> None:
    """Check mission and campaign files without running them (exit 0 all valid, 1 any invalid)."""
    from wmr_mission.commands.validate import validate_files

    raise typer.Exit(
        validate_files(files, fmt=format.value, check_entries=check_entries, strict=strict)
    )


@command
def schema(
    campaign: Annotated[
        bool, typer.Option("--campaign", help="Print the campaign schema instead.")
    ] = False,
) -> None:
    """Print the mission JSON Schema (for editors: wmr-mission schema > mission.schema.json)."""
    from wmr_mission.commands.schema import campaign_schema_text, schema_text

    sys.stdout.write(campaign_schema_text() if campaign else schema_text())


@command
def plot(
    run_dir: Annotated[
        Path,
        typer.Argument(exists=True, file_okay=False, metavar="RUN_DIR", help="A run directory."),
    ],
    format: FigureFormats = None,
    style: Annotated[
        FigureStyle,
        typer.Option(
            "--style",
            metavar="STYLE",
            help="Figure size: screen, one-column (3.5 in) or two-column (7.16 in).",
        ),
    ] = FigureStyle.screen,
    dpi: Annotated[
        int | None,
        typer.Option(
            "--dpi",
            metavar="N",
            min=DPI_RANGE[0],
            max=DPI_RANGE[1],
            help="Pixels per inch of a PNG (default: 120); 300 for print; at most 600.",
        ),
    ] = None,
) -> None:
    """Re-draw the figures of RUN_DIR from its saved data."""
    from wmr_mission.commands.plot import replot_command

    raise typer.Exit(replot_command(run_dir, _formats(format), style.value, dpi))


OutputDirectory = Annotated[
    Path,
    typer.Argument(
        exists=True,
        file_okay=False,
        metavar="DIR",
        help="A run directory or a campaign directory.",
    ),
]


@command
def view(
    directory: Annotated[
        Path,
        typer.Argument(
            exists=True,
            file_okay=False,
            metavar="DIR",
            help="A run, campaign or falsification directory.",
        ),
    ],
    out: Annotated[
        Path | None,
        typer.Option("--out", metavar="FILE", help="The HTML report (default: DIR/report.html)."),
    ] = None,
) -> None:
    """Write a self-contained HTML report of DIR that opens offline; print its path."""
    from wmr_mission.review.view import view_command

    raise typer.Exit(view_command(directory, out))


class ExportFormat(StrEnum):
    mcap = "mcap"
    mcap_json = "mcap-json"
    parquet = "parquet"


@command
def export(
    directory: OutputDirectory,
    format: Annotated[
        ExportFormat,
        typer.Option(
            "--format",
            metavar="FORMAT",
            help=(
                "mcap (a run as ROS 2 messages: ros2 bag, Foxglove), mcap-json (a run "
                "under Foxglove's JSON schemas) or parquet (trajectory.csv or runs.csv)."
            ),
        ),
    ],
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            metavar="PATH",
            help=(
                "The file (default: DIR/run.mcap, DIR/run.json.mcap, DIR/trajectory.parquet "
                "or DIR/runs.parquet)."
            ),
        ),
    ] = None,
) -> None:
    """Write DIR's data as MCAP or Parquet (the export extra); print the file's path."""
    from wmr_mission.review.export import export_command

    raise typer.Exit(export_command(directory, format.value, out))


@command
def bench(
    mission: ExistingFile,
    repeat: Annotated[
        int,
        typer.Option(
            "--repeat", metavar="N", min=1, max=MAX_REPEAT, help="Runs of the mission to time."
        ),
    ] = 3,
) -> None:
    """Time the estimator + controller step per sample against the reference step."""
    from wmr_mission.commands.bench import bench_command

    raise typer.Exit(bench_command(mission, repeat=repeat))


@app.command(name="compile", cls=_Command)
def compile_loop() -> None:
    """Compile the simulation loop into the cache, on every core (40 s to 13 minutes by
    the machine's load, once per install)."""
    from wmr_mission.commands.compile import compile_command

    raise typer.Exit(compile_command())


class _QuietPipe:
    """A standard stream that shows every character a terminal would act on
    escaped (wmr_mission.terminal: whatever a message echoes of a mission, a file
    name, a value, it cannot retitle or clear the terminal), and that a closed
    pipe (``| head -1``) silences instead of failing: the rest of the output goes
    to the null device and the command ends with its own exit code. ``raw``: the
    stream itself, for the progress display's own control codes."""

    def __init__(self, stream: TextIO) -> None:
        self._stream = stream
        self.raw = stream

    def write(self, text: str) -> int:
        try:
            self._stream.write(shown(text, None, keep="\n\t"))
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


# Set for the command's process (and the processes it starts, a sweep's workers)
# before numpy or pydantic load, unless the user set them: numpy's BLAS on one
# thread (its threads spin as they start, about 0.05 s of CPU per process, and
# nothing here multiplies matrices large enough to share: a step works on 3x3
# ones); no pydantic plug-in scanned for among the installed packages, as the
# first model is built (they would instrument this tool's own models).
# docs/performance.md, Start-up.
START_UP_ENVIRONMENT = {"OPENBLAS_NUM_THREADS": "1", "PYDANTIC_DISABLE_PLUGINS": "__all__"}


def _no_pydantic_plugin_loader() -> None:
    """With every pydantic plug-in disabled, pydantic's plug-in loader, which
    its first validator imports, finds none; but its import loads
    importlib.metadata (the email parser, zipfile, csv: 0.015 s of
    `validate`'s CPU, docs/performance.md, Start-up) only to look them up.
    A module that finds none stands in for it; asked for anything else (a
    pydantic of other internals), it hands over to pydantic's own."""
    name = "pydantic.plugin._loader"
    if os.environ.get("PYDANTIC_DISABLE_PLUGINS") != "__all__" or name in sys.modules:
        return
    import types

    def pydantics(attribute: str) -> Any:
        if attribute.startswith("__"):  # a module's own (__file__, __path__): none here
            raise AttributeError(attribute)
        if sys.modules.get(name) is loader:
            del sys.modules[name]
        import importlib

        return getattr(importlib.import_module(name), attribute)

    loader = types.ModuleType(name, "No pydantic plug-in: all are disabled (wmr_mission.cli).")
    loader.get_plugins = lambda: ()  # type: ignore[attr-defined]
    loader.__getattr__ = pydantics  # type: ignore[method-assign]
    sys.modules[name] = loader


def main() -> None:
    """The command line as a function: runs the command ``sys.argv`` names and
    raises SystemExit with its exit code, whoever called it."""
    raise SystemExit(_command_line_run())


def program() -> None:
    """The ``wmr-mission`` program (and ``python -m wmr_mission``): :func:`main`,
    ending run and validate at once (:func:`_ends_at_once`)."""
    code = _command_line_run()
    if _ends_at_once(sys.argv[1:2], code):
        # What Python would still do as it exits, its exit functions, is done;
        # then the process ends without unloading every module, object by
        # object (docs/performance.md, Start-up): run and validate wrote and
        # closed what they made, and the streams are flushed.
        atexit._run_exitfuncs()
        for stream in (sys.stdout, sys.stderr):
            if stream is not None and not stream.closed:
                stream.flush()
        os._exit(code or 0)
    raise SystemExit(code)


def _command_line_run() -> Any:
    """The command ``sys.argv`` names, run: its exit code."""
    # No cyclic collection while the command starts: see
    # wmr_mission.commands.start_up_done, which turns it on.
    gc.disable()
    for name, value in START_UP_ENVIRONMENT.items():
        os.environ.setdefault(name, value)
    _no_pydantic_plugin_loader()
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
    import signal

    from wmr_mission.stopping import HOLD, STOP_SIGNALS, StopSignals

    # Outside the block below, a stop kills the process as the signal does by
    # default (a shell shows 130 or 143): before it, nothing was begun; after
    # it, everything is written and flushed. Python's own SIGINT handler would
    # raise a KeyboardInterrupt in the interpreter's teardown instead.
    signal.signal(signal.SIGINT, signal.SIG_DFL)
    # Until the command starts (_main): a stop is held, never raised inside an
    # import, and the command exits by it.
    with StopSignals(STOP_SIGNALS, HOLD) as early:
        _STARTING.append(early)
        code: Any = 0
        try:
            if sys.argv[1:2] and sys.argv[1] in _SHORT:
                # numpy, which run and validate import anyway, imported here, at the
                # command line's own depth, not some twenty imports down: the
                # interpreter (CPython 3.11) keeps its frames in 16 KiB chunks, mapped
                # as a call crosses into the next and unmapped as it returns, and the
                # recursion of numpy's typing aliases, at that depth, crossed a chunk's
                # end some 1 600 times, 0.02 s of a run (docs/performance.md, Start-up).
                import numpy  # noqa: F401
            _command_line(sys.argv[1:])()
        except SystemExit as done:
            code = done.code
        finally:
            for stream in (sys.stdout, sys.stderr):
                if stream is not None and not stream.closed:
                    stream.flush()
    # The process ends here, its objects with it. Python's collections as it
    # shuts down would trace every one still alive (0.1 s of `validate`'s
    # 0.45 s of CPU); frozen, they are left to reference counting alone
    # (docs/performance.md, Start-up).
    gc.freeze()
    if early.owed:  # a stop held while the command started: it ends as Python ends
        raise SystemExit(early.exit_code)
    return code


def _ends_at_once(arguments: list[str], code: Any) -> bool:
    """Whether the command's process may end without Python's teardown: run
    or validate (the short commands), a numeric exit code, no other thread
    left running (Python's exit would wait for it), and no profiler or
    tracer (cProfile and trace write what they found as Python exits)."""
    import threading

    numeric = code is None or isinstance(code, int)
    short = bool(arguments) and arguments[0] in _SHORT
    watched = sys.getprofile() is not None or sys.gettrace() is not None
    return short and numeric and not watched and threading.active_count() == 1
