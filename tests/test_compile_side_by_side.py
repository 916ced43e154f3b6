"""`wmr-mission compile` on every core: the variants of the loop compiled in
processes side by side keep every entry in numba's cache, a share that fails
or a Ctrl-C leaves no ready marker; and the suite's set-up (tests/conftest.py)
names its own files."""

from __future__ import annotations

import io
import os
import re
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path

import conftest
import pytest
from test_start_up import _cache_of_this_session, _env

from wmr_mission.commands import compile as compile_loop
from wmr_mission.kernels import jit

TESTS = Path(__file__).resolve().parent

pytestmark = pytest.mark.skipif(
    not jit.compiling() or not jit._numba_as_read(),
    reason="the compiled build, with the numba whose saves jit.save_one_at_a_time wraps",
)

# Saves one entry, under the key argv[1], of a function's cache in the
# kernels' directory (NUMBA_CACHE_DIR's) once told to go (a line on stdin,
# given to both processes when both are ready), the index's write slowed as a
# long compile's save could be while the other process reads it. Nothing but
# numba loaded for the kernels, as in any process that compiles: a `run`, a
# sweep's worker, one of `wmr-mission compile`'s processes.
SAVE = """
import sys, time

from wmr_mission.kernels import cache, jit

assert jit.load()
from numba.core.caching import IndexDataCacheFile

key = sys.argv[1]
write_index = IndexDataCacheFile._save_index


def slowly(self, overloads):
    time.sleep(1.0)
    write_index(self, overloads)


IndexDataCacheFile._save_index = slowly
print("ready", flush=True)
sys.stdin.readline()
IndexDataCacheFile(str(cache.cache_directory()), "run_segment", "sources").save(key, key.encode())
"""


# Prints the entries of the cache in the kernels' directory, in the order of
# their keys, and the names of their files.
READ = """
from wmr_mission.kernels import cache, jit

assert jit.load()
from numba.core.caching import IndexDataCacheFile

index = IndexDataCacheFile(str(cache.cache_directory()), "run_segment", "sources")
for key in ("ekf-paper", "observer-paper"):
    print(index.load(key))
print(*sorted(index._load_index().values()))
"""


def test_two_processes_saving_at_once_keep_both_entries(tmp_path: Path) -> None:
    """Left as numba saves, both read the index empty and the last to write it
    keeps only its own entry, and both entries' files are numbered 1: the
    index could name, for one variant, the file the other's machine code was
    written to last. The saves of every process that loads numba for the
    kernels take turns (jit.save_one_at_a_time), two `run`s side by side as
    much as `wmr-mission compile`'s processes."""
    env = {**conftest.the_tests_package(dict(os.environ)), "NUMBA_CACHE_DIR": str(tmp_path)}
    saving = [
        subprocess.Popen(
            [sys.executable, "-c", SAVE, key],
            env=env,
            cwd=tmp_path,
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        for key in ("observer-paper", "ekf-paper")
    ]
    for process in saving:
        assert process.stdout is not None
        assert process.stdout.readline() == "ready\n"
    for process in saving:  # both told before either is waited for
        assert process.stdin is not None
        process.stdin.write("go\n")
        process.stdin.flush()
    for process in saving:
        _, stderr = process.communicate(timeout=120)
        assert process.returncode == 0, stderr
    read = subprocess.run(
        [sys.executable, "-c", READ], env=env, cwd=tmp_path, capture_output=True, text=True
    )
    assert read.returncode == 0, read.stderr
    ekf, observer, files = read.stdout.splitlines()
    assert (ekf, observer) == ("b'ekf-paper'", "b'observer-paper'")
    assert len(set(files.split())) == 2  # each entry in a file of its own


def test_every_entry_of_the_session_s_kernels_is_in_a_file_of_its_own() -> None:
    """The suite's kernels, compiled by `wmr-mission compile` on every core as
    the session began (tests/conftest.py) and by whatever test compiled since:
    in each function's index, every entry names a file of its own, which is
    there, and the loop holds every built-in variant. Read holding the save
    lock, so that no save is half made."""
    import fcntl
    import pickle

    from wmr_mission.kernels import cache as kernel_cache
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.sim.runner import run_mission

    for warm_up in compile_loop.warm_up_missions():  # loaded (compiled if the compile failed)
        run_mission(plan_mission(warm_up))
    directory = kernel_cache.cache_directory()
    assert directory is not None
    loop_entries = 0
    with open(directory / jit.SAVE_LOCK, "a") as held:
        fcntl.flock(held, fcntl.LOCK_EX)
        indexes = sorted(directory.rglob("*.nbi"))
        for index in indexes:
            with open(index, "rb") as file:
                pickle.load(file)  # numba's version
                _, entries = pickle.loads(file.read())  # the source's stamp, the entries
            files = list(entries.values())
            assert len(set(files)) == len(files), index
            assert all((index.parent / name).is_file() for name in files), index
            if ".run_segment-" in index.name:
                loop_entries += len(files)
    assert len(indexes) > 10
    assert loop_entries >= len(compile_loop.warm_up_missions())


# `wmr-mission compile` on two cores, whatever this machine has; argv[1] says
# what each variant's run does in the compile's own processes (the command's
# first variant runs as it is): "as-it-is"; "fails", the EKF's variants end
# in an error at once (a loop that does not compile), the others wait;
# "dies", the process is killed; "waits", each waits, after saying so in the
# file argv[2].
COMPILE = """
import os, signal, sys, time

from wmr_mission.campaign import engine
from wmr_mission.cli import main
from wmr_mission.record import Outcome
from wmr_mission.sim import runner

engine.default_workers = lambda: 2
how = sys.argv.pop(1)
said = sys.argv.pop(1) if how == "waits" else None
command = os.getpid()
run_mission = runner.run_mission


def run_it(plan):
    if os.getpid() == command or how == "as-it-is":
        return run_mission(plan)
    if how == "fails" and plan.estimator.settings.__name__ == "Ekf":
        result = run_mission(plan)
        result.outcome, result.message = Outcome.error, "an error inside the loop: TypingError"
        return result
    if how == "dies":
        os.kill(os.getpid(), signal.SIGKILL)
    if said is not None:
        with open(said, "a") as saying:
            saying.write("compiling\\n")
    time.sleep(600)


runner.run_mission = run_it
sys.argv[0] = "wmr-mission"
main()
"""


@contextmanager
def _compiling(cache: Path, how: str, *more: str) -> Iterator[subprocess.Popen[str]]:
    """The command, running; killed with its processes if a test fails first."""
    command = subprocess.Popen(
        [sys.executable, "-c", COMPILE, how, *more, "compile"],
        env=_env(cache),
        cwd=cache.parent,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        start_new_session=True,
    )
    try:
        yield command
    finally:
        if command.poll() is None:
            os.killpg(command.pid, signal.SIGKILL)
            command.communicate()


def test_compile_side_by_side_marks_the_cache_ready(tmp_path: Path) -> None:
    """Two processes, here on a copy of this session's kernels so that each
    takes seconds, not a compile: the cache holds the marker. A variant whose
    loop does not compile, or a process killed, stops the compile at once
    (the other process waits 10 minutes), says so, and leaves no marker."""
    cache = _cache_of_this_session(tmp_path)
    (kernels,) = (cache / "wmr_mission").iterdir()
    for how, said in [
        ("fails", "failed to compile, nothing marked ready: an error inside the loop"),
        ("dies", "failed to compile, nothing marked ready: a process compiling a variant died"),
    ]:
        with _compiling(cache, how) as failing:
            out, err = failing.communicate(timeout=300)
        assert failing.returncode == 1, err
        assert "2 processes side by side" in out
        assert said in out
        assert "Traceback" not in err
        assert not (kernels / compile_loop.READY).exists()
    with _compiling(cache, "as-it-is") as compiling:
        out, err = compiling.communicate(timeout=600)
    assert compiling.returncode == 0, err
    assert "2 processes side by side" in out
    assert (kernels / compile_loop.READY).exists()


def test_ctrl_c_stops_every_process_of_the_compile(tmp_path: Path) -> None:
    """Ctrl-C (to the command alone: a terminal's reaches the processes too,
    which leave it to the command) stops the compile at once, exit 130, with
    a line that says so, no marker and no process of it left compiling: the
    judge's, started beside the first variant, and the two of the others."""
    cache = _cache_of_this_session(tmp_path)  # the first variant loaded, not compiled
    said = tmp_path / "said"
    with _compiling(cache, "waits", str(said)) as compiling:
        waited = time.monotonic()
        while said.read_text().count("compiling") < 3 if said.exists() else True:
            assert compiling.poll() is None, compiling.communicate()
            assert time.monotonic() - waited < 300, "the processes never started"
            time.sleep(0.05)
        shares = _children(compiling.pid)
        assert len(shares) == 3
        compiling.send_signal(signal.SIGINT)
        out, err = compiling.communicate(timeout=60)
    assert compiling.returncode == 130, err
    assert "compile stopped, nothing marked ready" in out
    assert "Traceback" not in err
    assert not list(cache.rglob(compile_loop.READY))
    for share in shares:
        assert not Path(f"/proc/{share}").exists() or _is_zombie(share)


def _children(pid: int) -> list[int]:
    found = Path(f"/proc/{pid}/task/{pid}/children").read_text().split()
    return [int(child) for child in found]


def _is_zombie(pid: int) -> bool:
    try:
        return Path(f"/proc/{pid}/stat").read_text().split(") ")[1].startswith("Z")
    except FileNotFoundError:
        return True


def test_another_numba_or_no_flock_compiles_in_one_process(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Another numba's saves may differ from those jit.save_one_at_a_time
    wraps, and a file system may refuse flock: one process then, as before;
    else at most one per variant after the first."""
    assert compile_loop.side_by_side(64) == len(compile_loop.warm_up_missions()) - 1
    assert compile_loop.side_by_side(1) == 1
    with monkeypatch.context() as patch:
        patch.setattr(jit, "_numba_as_read", lambda: False)
        assert compile_loop.side_by_side(2) == 1

    def refused(*_: object) -> None:
        raise OSError(95, "Operation not supported")

    monkeypatch.setattr("fcntl.flock", refused)
    assert compile_loop.side_by_side(2) == 1


def test_the_files_the_set_up_names_are_the_suites() -> None:
    """A file renamed or removed leaves neither the smoke subset nor the
    longest-first order naming a file that is not there."""
    files = {path.name for path in TESTS.glob("test_*.py")}
    assert files >= conftest.SMOKE
    assert set(conftest.LONGEST_FIRST) <= files
    assert len(set(conftest.LONGEST_FIRST)) == len(conftest.LONGEST_FIRST)


def test_the_judge_compiles_beside_the_first_variant(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The judge's passes need a run's record, not its loop: they compile in a
    process of their own from a run made as plain Python, while the first
    variant compiles (which leaves the other cores idle), not after it. Here
    the first variant waits for the judge (each compile left out: the
    processes run what the test hands them, forked)."""
    judged = tmp_path / "judged"
    seen: list[bool] = []

    def judge(result: object) -> None:
        assert result is not None  # the plain run's record
        judged.write_text("judged")

    def first_waits_for_the_judge(variant: int) -> None:
        if not seen:  # the first variant, in the command's process
            waited = time.monotonic()
            while not judged.exists() and time.monotonic() - waited < 60:
                time.sleep(0.05)
            seen.append(judged.exists())

    def plain_run(variant: int) -> object:
        assert not jit.loaded()  # inside jit.plain_python_meanwhile
        return object()

    monkeypatch.setattr(compile_loop, "_judge", judge)
    monkeypatch.setattr(compile_loop, "_compiled_run", first_waits_for_the_judge)
    monkeypatch.setattr(compile_loop, "_run", plain_run)
    compile_loop.compile_kernels(2)
    assert seen == [True]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


@pytest.mark.parametrize("processes", [1, 2])
def test_the_compile_shows_each_task_as_it_ends_on_a_terminal(
    monkeypatch: pytest.MonkeyPatch, processes: int
) -> None:
    """`wmr-mission compile` takes 40 s to 13 minutes: on a terminal it shows the
    first variant, then the count of the other tasks as each ends, and which;
    a log gets none of it. (Each task's compile is left out here: the
    processes run what the test hands them, forked.)"""
    from wmr_mission.output.progress import Steps

    monkeypatch.setattr(compile_loop, "_compiled_run", lambda variant: None)
    monkeypatch.setattr(compile_loop, "_run", lambda variant: None)
    monkeypatch.setattr(compile_loop, "_judge", lambda result: None)
    tasks = len(compile_loop.warm_up_missions())  # the variants after the first, and the judge
    shown = []
    for stream in (_Terminal(), io.StringIO()):
        steps = Steps(stream)
        compile_loop.compile_kernels(processes, steps)
        steps.close()
        shown.append(stream.getvalue())
    text = re.sub(r"\x1b\[[0-9;?]*[A-Za-z]", "", shown[0])  # the terminal's control codes
    said = [piece.strip() for piece in re.split(r"[\r\n]", text) if piece.startswith("compiled")]
    missions = compile_loop.warm_up_missions()
    first = compile_loop.first_variant()
    variants = {f"compiled {m.estimator.type} with {m.controller.type}" for m in missions}
    assert said[0] == (
        f"compiled {missions[first].estimator.type} with {missions[first].controller.type}, "
        "with what every variant shares"
    )
    assert sorted(said[1:]) == sorted(
        [*(variants - {said[0].partition(",")[0]}), "compiled the judge's passes"]
    )
    assert f"{tasks} of {tasks}" in text
    assert shown[1] == ""
