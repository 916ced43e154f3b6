"""What `validate` and `run --no-plots` load as they start: never the plotting,
scipy, numba, pandas or shapely they do not use; numpy's BLAS on one thread;
a mission file read once; nothing left for the collector as the process ends
(docs/performance.md, Start-up)."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from collections.abc import Mapping
from pathlib import Path

import pytest
from conftest import the_tests_package

from wmr_mission.campaign.load import check_file
from wmr_mission.controllers.paper import PaperController
from wmr_mission.estimators.observer import ConstrainedObserver
from wmr_mission.sim import reactions
from wmr_mission.spec import loader
from wmr_mission.spec.models import Settled

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
# Where the tests start their commands: not the checkout's root, whose package
# `python -c` would import first, not the tests' (conftest.the_tests_package).
TESTS = Path(__file__).resolve().parent


def _python(
    *args: str, env: Mapping[str, str] | None = None, timeout: float = 300
) -> subprocess.CompletedProcess[str]:
    """``python ARGS`` in ``env`` (None: this process's), started from TESTS
    with the tests' package on the path, as every command here starts."""
    return subprocess.run(
        [sys.executable, *args],
        env=the_tests_package(dict(os.environ if env is None else env)),
        cwd=TESTS,
        capture_output=True,
        text=True,
        timeout=timeout,
    )


# Runs the command line, then prints as it exits the top-level packages it
# imported and the threads of numpy's BLAS.
COMMAND = """
import atexit, gc, json, os, sys, traceback
names = sys.argv.pop(1).split(",")
class NumpysDepth:  # the depth of the stack where numpy is first imported
    depth = None
    metadata = None  # where importlib.metadata was first imported from, if it was
    def find_spec(self, name, path=None, target=None):
        if name == "numpy" and NumpysDepth.depth is None:
            NumpysDepth.depth = len(traceback.extract_stack())
        if name == "importlib.metadata" and NumpysDepth.metadata is None:
            NumpysDepth.metadata = "".join(traceback.format_stack(limit=25))
sys.meta_path.insert(0, NumpysDepth())
def loaded():
    modules = sorted({m.split(".")[0] for m in sys.modules})  # before threadpoolctl's
    blas = None
    if "numpy" in sys.modules:
        from threadpoolctl import threadpool_info
        blas = [i["num_threads"] for i in threadpool_info() if i["user_api"] == "blas"]
    print(json.dumps({
        "modules": modules,
        "blas_threads": blas,
        "frozen": gc.get_freeze_count(),
        "environment": {name: os.environ.get(name) for name in names},
        "numpy_depth": NumpysDepth.depth,
        "metadata": NumpysDepth.metadata,
    }), file=sys.__stderr__)
atexit.register(loaded)
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import program
program()
"""

# What the command line sets for itself unless the user did (wmr_mission.cli).
START_UP_ENVIRONMENT = {"OPENBLAS_NUM_THREADS": "1", "PYDANTIC_DISABLE_PLUGINS": "__all__"}
NEVER = ("matplotlib", "scipy", "numba", "llvmlite", "pandas", "shapely", "PIL")


def _start(args: list[str], **environment: str) -> dict[str, object]:
    """The command's report (see COMMAND), in a user's environment: none of
    the suite's settings of BLAS threads, the plain-Python switch, pydantic."""
    threads = ("OMP_NUM_THREADS", "GOTO_NUM_THREADS", "MKL_NUM_THREADS")  # OpenBLAS reads them
    env = {k: v for k, v in os.environ.items() if k not in (*START_UP_ENVIRONMENT, *threads)}
    env.pop("WMR_MISSION_NO_JIT", None)
    env.update(environment)
    names = ",".join(START_UP_ENVIRONMENT)
    done = _python("-c", COMMAND, names, *args, env=env)
    assert done.returncode == 0, done.stderr
    report: dict[str, object] = json.loads(done.stderr.strip().splitlines()[-1])
    return report


def test_validate_imports_nothing_it_does_not_use() -> None:
    report = _start(["validate", str(MISSIONS / "case2.yaml"), str(MISSIONS / "patrol.yaml")])
    modules = report["modules"]
    assert isinstance(modules, list)
    assert [m for m in (*NEVER, "rich", "email", "zipfile") if m in modules] == []
    assert "pydantic" in modules  # the probe sees what was imported
    # Every object alive is frozen as the command ends: Python's collections
    # as it shuts down would trace them all (docs/performance.md, Start-up).
    frozen = report["frozen"]
    assert isinstance(frozen, int)
    assert frozen > 10_000  # some 50 000 of them


def test_pydantic_looks_for_plug_ins_only_where_some_are_enabled() -> None:
    """With every pydantic plug-in disabled, as the command line sets unless
    the user did, pydantic's plug-in loader is not imported, nor
    importlib.metadata (the email parser, zipfile) with it; a user's own
    setting keeps pydantic's loader."""
    case2 = str(MISSIONS / "case2.yaml")
    assert "email" not in _modules(_start(["validate", case2])["modules"])
    one_disabled = _start(["validate", case2], PYDANTIC_DISABLE_PLUGINS="some-plug-in")
    assert "email" in _modules(one_disabled["modules"])


def test_pydantics_loader_stood_in_for_hands_over_what_it_lacks() -> None:
    """The stand-in answers get_plugins alone; any other name (a pydantic
    that imports more from its loader) comes from pydantic's own loader."""
    stood_in = """
import os, sys
os.environ["PYDANTIC_DISABLE_PLUGINS"] = "__all__"
from wmr_mission.cli import _no_pydantic_plugin_loader
_no_pydantic_plugin_loader()
from pydantic.plugin._loader import get_plugins, PYDANTIC_ENTRY_POINT_GROUP
print(list(get_plugins()), PYDANTIC_ENTRY_POINT_GROUP, "email" in sys.modules)
"""
    done = _python("-c", stood_in)
    assert done.returncode == 0, done.stderr
    assert done.stdout.split() == ["[]", "pydantic", "True"]


def _modules(report: object) -> list[str]:
    assert isinstance(report, list)
    return report


def test_a_run_without_plots_imports_nothing_it_does_not_use(tmp_path: Path) -> None:
    """figure-eight.yaml runs as plain Python (its budget, 4 515 samples, is
    under the bound, wmr_mission.commands.compile): no numba, no scipy, no
    figures; its table fits, laid out without rich (wmr_mission.output.report)."""
    out = tmp_path / "run"
    mission = MISSIONS / "figure-eight.yaml"
    report = _start(["run", str(mission), "--no-plots", "--out", str(out)], COLUMNS="100")
    modules = report["modules"]
    assert isinstance(modules, list)
    assert [m for m in (*NEVER, "rich") if m in modules] == []
    assert (out / "trajectory.csv").exists()


def test_a_run_of_the_cached_loop_imports_no_package_metadata(tmp_path: Path) -> None:
    """case1.yaml runs the compiled loop, loaded from the cache (its budget,
    5 349 samples, is over the bound of a ready cache): numba loaded, and
    importlib.metadata (the email parser, zipfile, csv: 0.014-0.017 s)
    imported neither by numba (jit._ExtensionsLater) nor for the manifest's
    versions (wmr_mission.version.installed_version)."""
    from wmr_mission.kernels import cache, jit

    out = tmp_path / "run"
    report = _start(["run", str(MISSIONS / "case1.yaml"), "--no-plots", "--out", str(out)])
    modules = _modules(report["modules"])
    directory = cache.cache_directory()
    if jit.compiling() and directory is not None and cache.is_ready(directory):
        assert "numba" in modules
    assert "email" not in modules, report["metadata"]
    assert report["metadata"] is None, report["metadata"]
    versions = json.loads((out / "manifest.json").read_text(encoding="utf-8"))["versions"]
    assert versions["numba"] is not None
    assert versions["numpy"] is not None


def test_run_and_validate_import_numpy_at_the_command_lines_depth(tmp_path: Path) -> None:
    """Not some twenty imports down, where the recursion of numpy's typing
    aliases crossed the end of one of the interpreter's 16 KiB frame chunks
    some 1 600 times as a run started, each crossing a chunk mapped and
    unmapped (wmr_mission.cli, docs/performance.md, Start-up); help imports
    no numpy."""
    out = tmp_path / "run"
    run = ["run", str(MISSIONS / "figure-eight.yaml"), "--no-plots", "--out", str(out)]
    for args in (run, ["validate", str(MISSIONS / "case2.yaml")]):
        depth = _start(args)["numpy_depth"]
        assert isinstance(depth, int)
        assert depth < 12, args[0]  # the program, the command line, the import's own frames
    assert _start(["--help"])["numpy_depth"] is None


# Checks a mission in a fresh process, then names the models of the sections
# it leaves out whose validators were built.
SECTIONS_LEFT_OUT = """
import sys
from pydantic._internal._mock_val_ser import MockValSer
from wmr_mission import fields
from wmr_mission.controllers import paper
from wmr_mission.estimators import observer
from wmr_mission.sim import reactions
from wmr_mission.spec import backend, models
from wmr_mission.spec.loader import load_mission
load_mission(sys.argv[1])
left_out = (models.Disturbances, models.Slip, fields.StateStd, fields.StateOffset,
            models.PhaseExpect, models.StateTolerance, paper.Tracking, paper.Regulation,
            observer.StatePoles, backend.Backend, models.Settled)
print(" ".join(m.__name__ for m in left_out
               if not isinstance(m.__pydantic_validator__, MockValSer)
               or not isinstance(m.__pydantic_serializer__, MockValSer)))
"""


def test_a_section_left_out_is_its_defaults_without_its_validator_built() -> None:
    """Case studies 1 and 2 write no disturbances, sensor noise or bias, phase
    expect, convergence tolerance, tracking or regulation form, observer poles
    nor backend: each is its model's defaults, as the model itself gives them,
    its validator and serializer not built for that (about 1 ms each,
    fields.Model.defaults); nor are they for the built-in contingencies'
    settling tolerances (wmr_mission.sim.reactions)."""
    for name in ("case1.yaml", "case2.yaml"):
        done = _python("-c", SECTIONS_LEFT_OUT, str(MISSIONS / name))
        assert done.returncode == 0, done.stderr
        assert done.stdout.split() == [], name
    mission = loader.load_mission(MISSIONS / "case1.yaml")
    written = (mission.robot.disturbances, mission.sensors.bias, mission.phases[0].expect)
    controller, estimator = mission.controller, mission.estimator
    assert isinstance(controller, PaperController)
    assert isinstance(estimator, ConstrainedObserver)
    left_out = (controller.tracking, controller.regulation, estimator.poles, mission.backend)
    for section in (*written, mission.expect.convergence_tolerance, *left_out):
        assert section == type(section)()
        assert section.model_dump() == type(section)().model_dump()
        assert section.model_fields_set == set()
    settled = Settled(position=0.05, heading=0.05)
    assert settled == reactions._SETTLED
    assert reactions._SETTLED.model_fields_set == settled.model_fields_set


# Runs the command line, then prints as it exits whether the formulas' grammar
# (wmr_mission.spec.temporal) was imported.
GRAMMAR_LOADED = """
import atexit, sys
atexit.register(lambda: print("wmr_mission.spec.temporal" in sys.modules, file=sys.__stderr__))
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import program
program()
"""


def test_the_formulas_grammar_is_imported_only_for_a_mission_that_writes_one(
    tmp_path: Path,
) -> None:
    """Case study 1 writes no temporal formula: neither its check nor its run
    imports their grammar (about 4 ms, docs/performance.md, Start-up); case
    study 2 writes two, and its check and run parse them."""
    loaded = {}
    for name in ("case1", "case2"):
        mission = str(MISSIONS / f"{name}.yaml")
        out = str(tmp_path / name)
        for args in (["validate", mission], ["run", mission, "--no-plots", "--out", out]):
            done = _python("-c", GRAMMAR_LOADED, *args)
            assert done.returncode == 0, done.stderr
            loaded[name, args[0]] = done.stderr.strip().splitlines()[-1]
    assert loaded == {
        ("case1", "validate"): "False",
        ("case1", "run"): "False",
        ("case2", "validate"): "True",
        ("case2", "run"): "True",
    }
    summary = json.loads((tmp_path / "case2" / "summary.json").read_text())
    assert [list(phase.get("temporal", {})) for phase in summary["phases"]] == [
        [],
        ["eventually[0, 10](always(cross_track <= 0.02))"],
        ["eventually[0, 10](always(target_distance <= 0.05))"],
    ]


# Prints, as the command exits, the package's classes made by @dataclass in
# the modules it imported.
DATACLASSES_MADE = """
import atexit, sys
def made():
    found = sorted(
        f"{name}.{value.__qualname__}"
        for name, module in list(sys.modules.items()) if name.startswith("wmr_mission")
        for value in list(vars(module).values())
        if isinstance(value, type) and value.__module__ == name
        and "__dataclass_fields__" in vars(value)
    )
    print(",".join(found), file=sys.__stderr__)
atexit.register(made)
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import program
program()
"""

# The dataclasses `validate` and `run` still make as they import, each for a
# reason: mutable, a field made by a factory or after __init__, or replaced by
# dataclasses.replace (the plans and the run's records, by the suite and by
# users of the results); the temporal formulas' nodes, whose equality must tell
# `and` from `or` (a NamedTuple's compares its fields alone).
STILL_DATACLASSES = {
    "wmr_mission.controllers.plugin.ControllerSetup",
    "wmr_mission.controllers.registry.ControllerType",
    "wmr_mission.estimators.plugin.EstimatorSetup",
    "wmr_mission.estimators.registry.EstimatorType",
    "wmr_mission.estimators.registry.Measurements",
    "wmr_mission.geometry.paths.expression.ExpressionTrajectory",
    "wmr_mission.geometry.paths.registry.Context",
    "wmr_mission.geometry.paths.waypoints.WaypointsTrajectory",
    "wmr_mission.geometry.routes.RouteTrajectory",
    "wmr_mission.spec.loader.Document",
}
RUN_STILL_DATACLASSES = {
    "wmr_mission.record.PhaseRecord",
    "wmr_mission.record.RunRecord",
    "wmr_mission.record.Transition",
    "wmr_mission.sim.draws.DisturbancePlan",
    "wmr_mission.sim.plan.Conditions",
    "wmr_mission.sim.plan.MissionPlan",
    "wmr_mission.sim.plan.PhasePlan",
    "wmr_mission.sim.plan.UpdatePlan",
    "wmr_mission.sim.reactions.Reactor",
    "wmr_mission.verdicts.check.Check",
    "wmr_mission.verdicts.signals.Check",
    "wmr_mission.verdicts.signals.Signals",
}
FORMULA_NODES = {
    f"wmr_mission.spec.temporal.{name}"
    for name in ("Atom", "Both", "Either", "Always", "Eventually", "Until")
}


def test_validate_and_run_make_no_other_dataclass_as_they_import(tmp_path: Path) -> None:
    """A frozen dataclass writes and compiles six methods as its module is
    imported, about 0.6 ms of CPU a class against 0.1 ms for a NamedTuple:
    the records `validate` and `run` make and never change are NamedTuples
    (docs/performance.md, Start-up). A new dataclass on their way is listed
    here with its reason, or made a NamedTuple."""
    made = {}
    mission = str(MISSIONS / "case2.yaml")
    out = str(tmp_path / "run")
    for args in (["validate", mission], ["run", mission, "--no-plots", "--out", out]):
        done = _python("-c", DATACLASSES_MADE, *args, env={**os.environ, "WMR_MISSION_NO_JIT": "1"})
        assert done.returncode == 0, done.stderr
        made[args[0]] = set(done.stderr.strip().splitlines()[-1].split(","))
    assert made["validate"] == STILL_DATACLASSES | FORMULA_NODES
    assert made["run"] == STILL_DATACLASSES | RUN_STILL_DATACLASSES | FORMULA_NODES


def test_the_command_line_runs_numpys_blas_on_one_thread_unless_told(tmp_path: Path) -> None:
    """Its threads spin as numpy loads (about 0.05 s of CPU a process) and
    nothing here multiplies matrices large enough to share; a user's own
    setting is kept."""
    run = ["run", str(MISSIONS / "fence.yaml"), "--no-plots", "--out"]
    report = _start([*run, str(tmp_path / "a")])
    assert report["blas_threads"] == [1]
    assert report["environment"] == START_UP_ENVIRONMENT
    told = _start([*run, str(tmp_path / "b")], OPENBLAS_NUM_THREADS="2")
    assert told["blas_threads"] == [2]
    environment = told["environment"]
    assert isinstance(environment, dict)
    assert environment["OPENBLAS_NUM_THREADS"] == "2"


# Runs the command line, then prints as it exits the collections of Python's
# cyclic collector made before the simulation started (or as the command
# ended, if it simulates nothing), and whether the collector is on.
COLLECTIONS = """
import atexit, gc, json, sys
made = []
before_simulating = []
if sys.argv[1] == "run":
    from wmr_mission.sim import runner
    run_mission = runner.run_mission
    def simulated(*args, **kwargs):
        before_simulating.append(len(made))
        return run_mission(*args, **kwargs)
    runner.run_mission = simulated
atexit.register(lambda: print(json.dumps({
    "before": before_simulating[0] if before_simulating else len(made),
    "on": gc.isenabled(),
}), file=sys.__stderr__))
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import main
gc.callbacks.append(lambda phase, info: phase == "start" and made.append(info["generation"]))
main()
"""


def _collections(args: list[str]) -> dict[str, object]:
    env = {k: v for k, v in os.environ.items() if k != "WMR_MISSION_NO_JIT"}
    done = _python("-c", COLLECTIONS, *args, env=env)
    assert done.returncode == 0, done.stderr
    report: dict[str, object] = json.loads(done.stderr.strip().splitlines()[-1])
    return report


def test_nothing_is_collected_while_a_command_starts(tmp_path: Path) -> None:
    """Python's cyclic collector is off while `validate` and `run` import and
    check (its collections traced the objects imported again and again: some
    90 of them as `validate` started), and on once the run starts: a long
    run and its figures are collected."""
    assert _collections(["validate", str(MISSIONS / "case2.yaml")])["before"] == 0
    out = str(tmp_path / "run")
    report = _collections(["run", str(MISSIONS / "figure-eight.yaml"), "--no-plots", "--out", out])
    assert report == {"before": 0, "on": True}


# Runs the command line with a module that says when Python unloads it, and
# an exit function that says when it runs.
ENDING = """
import atexit, os, sys
class Unloaded:
    def __del__(self, write=os.write):  # os itself may be unloaded first
        write(2, b"unloaded\\n")
sys.modules["witness"] = Unloaded()
atexit.register(lambda: print("exit function", file=sys.__stderr__, flush=True))
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import program
program()
"""


def _ending(args: list[str]) -> subprocess.CompletedProcess[str]:
    env = {k: v for k, v in os.environ.items() if k != "WMR_MISSION_NO_JIT"}
    return _python("-c", ENDING, *args, env=env)


def test_run_and_validate_end_without_unloading_their_modules(tmp_path: Path) -> None:
    """Once the command has written and flushed everything, its process ends
    after Python's exit functions, without unloading every module object by
    object (docs/performance.md, Start-up), with the command's exit code;
    other commands end as Python ends."""
    out = tmp_path / "run"
    run = _ending(["run", str(MISSIONS / "figure-eight.yaml"), "--no-plots", "--out", str(out)])
    assert run.returncode == 0, run.stderr
    assert run.stderr.splitlines()[-1:] == ["exit function"]
    assert "outcome: success" in run.stdout
    assert (out / "summary.json").exists()
    bad = tmp_path / "bad.yaml"
    bad.write_text("version: 1\nname: bad\n")
    invalid = _ending(["validate", str(bad)])
    assert invalid.returncode == 1
    assert "exit function" in invalid.stderr
    assert "unloaded" not in invalid.stderr
    schema = _ending(["schema"])
    assert schema.returncode == 0
    assert schema.stderr.splitlines() == ["exit function", "unloaded"]


# The command line run with typer's building of each command counted (its
# options read from the function's signature), printed as the process ends.
COMMANDS_BUILT = """
import atexit, sys
import typer.main
built = []
build = typer.main.get_command_from_info
def counted(command_info, **kwargs):
    built.append(command_info.name or command_info.callback.__name__)
    return build(command_info, **kwargs)
typer.main.get_command_from_info = counted
atexit.register(lambda: print(" ".join(built), file=sys.__stderr__))
sys.argv[0] = "wmr-mission"
from wmr_mission.cli import program
program()
"""


@pytest.mark.parametrize(
    ("args", "built"),
    [
        (["validate", str(MISSIONS / "case2.yaml")], ["validate"]),
        (["compile", "--help"], ["compile"]),
        (["serve-robot", "--help"], ["serve-robot"]),
        (["--version"], None),  # the whole command line
    ],
)
def test_the_command_line_builds_the_command_it_runs_alone(
    args: list[str], built: list[str] | None
) -> None:
    """typer reads the options of every command it holds as it starts (about
    0.01 s of CPU for all, docs/performance.md, Start-up): the command named
    first is built alone, the whole for anything else."""
    done = _python("-c", COMMANDS_BUILT, *args, timeout=120)
    assert done.returncode == 0, done.stderr
    names = done.stderr.strip().splitlines()[-1].split() if done.stderr.strip() else []
    if built is None:
        assert len(names) > 10
    else:
        assert names == built


def test_validate_of_a_mission_builds_no_campaign_model() -> None:
    """Telling a mission from a campaign reads its keys; the campaign's models
    are imported (about 5 ms of CPU) only to check a campaign."""
    probe = (
        "import sys; from pathlib import Path; from wmr_mission.campaign.load import check_file; "
        "assert check_file(Path(sys.argv[1])) == []; "
        "print('wmr_mission.campaign.models' in sys.modules)"
    )
    imported = {}
    for name in ("case2.yaml", "campaigns/case2-headings.yaml"):
        done = _python("-c", probe, str(MISSIONS / name))
        assert done.returncode == 0, done.stderr
        imported[name] = done.stdout.strip()
    assert imported == {"case2.yaml": "False", "campaigns/case2-headings.yaml": "True"}


def test_validate_reads_a_mission_file_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """Telling a mission from a campaign reads the YAML; the mission's check
    takes that reading rather than reading it again."""
    composed = []
    compose = loader._compose

    def counted(text: str) -> object:
        composed.append(text)
        return compose(text)

    monkeypatch.setattr(loader, "_compose", counted)
    assert check_file(MISSIONS / "case2.yaml") == []
    assert len(composed) == 1


def test_a_checkout_run_from_its_root_runs_as_the_installed_package(tmp_path: Path) -> None:
    """`python -m wmr_mission` from the root of a checkout imports the
    checkout's package, keeps its compiled kernels in the checkout's own
    `__pycache__`, and runs a short mission as the installed package does:
    plain Python, nothing said, the same bytes."""
    import shutil

    import wmr_mission

    package = Path(wmr_mission.__file__).parent
    shutil.copytree(package, tmp_path / "wmr_mission", ignore=shutil.ignore_patterns("__pycache__"))
    env = {
        k: v for k, v in os.environ.items() if k not in ("NUMBA_CACHE_DIR", "WMR_MISSION_NO_JIT")
    }
    probe = (
        "import wmr_mission; from wmr_mission.kernels import cache; "
        "print(wmr_mission.__file__); print(cache.cache_directory())"
    )
    done = subprocess.run(
        [sys.executable, "-c", probe], cwd=tmp_path, env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr
    imported, kernels = done.stdout.splitlines()
    assert Path(imported).parent == tmp_path / "wmr_mission"
    assert Path(kernels).parent == tmp_path / "wmr_mission" / "__pycache__"
    mission = str(MISSIONS / "fence.yaml")
    runs = {}
    for where, cwd in (("checkout", tmp_path), ("installed", tmp_path.parent)):
        out = tmp_path.parent / f"{tmp_path.name}-{where}"
        command = [sys.executable, "-m", "wmr_mission", "run", mission, "--no-plots"]
        done = subprocess.run(
            [*command, "--out", str(out)], cwd=cwd, env=env, capture_output=True, text=True
        )
        assert done.returncode == 0, done.stderr
        assert "wmr-mission:" not in done.stderr
        runs[where] = (out / "trajectory.csv").read_bytes()
        shutil.rmtree(out)
    assert runs["checkout"] == runs["installed"]


# The command line called as a function, twice, as a script of a user's may.
TWICE = """
import sys
from wmr_mission.cli import main
codes = []
for name in sys.argv[1:]:
    sys.argv = ["wmr-mission", "validate", name]
    try:
        main()
    except SystemExit as done:
        codes.append(done.code)
print("codes", codes)
"""


def test_main_comes_back_with_its_code_and_a_profiled_program_writes_its_profile(
    tmp_path: Path,
) -> None:
    """Only the program ends at once (wmr_mission.cli.program): main() raises
    SystemExit with the code, so a caller goes on; and a profiler sees the
    program end as Python ends, so it writes what it found."""
    bad = tmp_path / "bad.yaml"
    bad.write_text("version: 1\nname: bad\n")
    env = {k: v for k, v in os.environ.items() if k != "WMR_MISSION_NO_JIT"}
    twice = _python("-c", TWICE, str(MISSIONS / "case2.yaml"), str(bad), env=env)
    assert twice.returncode == 0, twice.stderr
    assert twice.stdout.splitlines()[-1] == "codes [0, 1]"
    profile = tmp_path / "validate.prof"
    command = ["-m", "cProfile", "-o", str(profile), "-m", "wmr_mission", "validate"]
    profiled = _python(*command, str(MISSIONS / "case2.yaml"), env=env)
    assert profiled.returncode == 0, profiled.stderr
    assert profile.stat().st_size > 0
