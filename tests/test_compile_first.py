"""The suite's set-up (tests/conftest.py, tests/compile_first.py): the loops
compiled first side by side keep every entry in numba's cache, and the files
the set-up names are the suite's."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import compile_first
import conftest
import pytest
from test_start_up import _cache_of_this_session

from wmr_mission.kernels import cache as kernel_cache
from wmr_mission.kernels import jit

TESTS = Path(__file__).resolve().parent

# Saves one entry of a function's cache in ``directory`` (argv[1]) under the
# key argv[2] once told to go (a line on stdin, given to both processes when
# both are ready), the index's write slowed as a long compile's save could be
# while the other process reads it; one at a time (compile_first's lock)
# when argv[3] is "locked".
SAVE = """
import sys, time
from pathlib import Path

from wmr_mission.kernels import jit

assert jit.load()
from numba.core.caching import IndexDataCacheFile

import compile_first

directory, key, locked = Path(sys.argv[1]), sys.argv[2], sys.argv[3]
write_index = IndexDataCacheFile._save_index


def slowly(self, overloads):
    time.sleep(1.0)
    write_index(self, overloads)


IndexDataCacheFile._save_index = slowly
if locked == "locked":
    compile_first._save_one_at_a_time(directory)
print("ready", flush=True)
sys.stdin.readline()
IndexDataCacheFile(str(directory), "run_segment", "sources").save(key, key.encode())
"""


# Prints the entries of the cache in argv[1], in the order of their keys.
READ = """
import sys

from wmr_mission.kernels import jit

assert jit.load()
from numba.core.caching import IndexDataCacheFile

index = IndexDataCacheFile(sys.argv[1], "run_segment", "sources")
for key in ("ekf-paper", "observer-paper"):
    print(index.load(key))
"""


@pytest.mark.skipif(not jit.compiling(), reason="the compiled build only")
def test_two_processes_saving_at_once_keep_both_entries(tmp_path: Path) -> None:
    """Unlocked, both read the index empty and the last to write it keeps
    only its own entry; compile_first saves one at a time."""
    env = {
        **os.environ,
        "PYTHONPATH": os.pathsep.join([str(TESTS), os.environ.get("PYTHONPATH", "")]),
    }
    saving = [
        subprocess.Popen(
            [sys.executable, "-c", SAVE, str(tmp_path), key, "locked"],
            env=env,
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
        [sys.executable, "-c", READ, str(tmp_path)], env=env, capture_output=True, text=True
    )
    assert read.returncode == 0, read.stderr
    assert read.stdout.split() == ["b'ekf-paper'", "b'observer-paper'"]


@pytest.mark.skipif(not jit.compiling(), reason="the compiled build only")
def test_the_loops_compiled_first_mark_the_cache_ready(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Every share compiled (here into a copy of this session's kernels, so
    that each takes seconds, not a compile): the cache holds the marker
    `wmr-mission compile` leaves. A share that fails leaves none."""
    cache = _cache_of_this_session(tmp_path)
    (kernels,) = (cache / "wmr_mission").iterdir()
    monkeypatch.setattr(kernel_cache, "cache_directory", lambda: kernels)
    env = {
        **{k: v for k, v in os.environ.items() if k != jit.NO_JIT},
        "NUMBA_CACHE_DIR": str(cache),
    }
    with monkeypatch.context() as patch:
        patch.setattr(compile_first, "__file__", str(tmp_path / "missing.py"))
        assert compile_first.compile_all(2, env)
    assert not kernel_cache.is_ready(kernels)
    assert compile_first.compile_all(2, env) == ""
    assert kernel_cache.is_ready(kernels)


def test_the_files_the_set_up_names_are_the_suites() -> None:
    """A file renamed or removed leaves neither the smoke subset nor the
    longest-first order naming a file that is not there."""
    files = {path.name for path in TESTS.glob("test_*.py")}
    assert files >= conftest.SMOKE
    assert set(conftest.LONGEST_FIRST) <= files
    assert len(set(conftest.LONGEST_FIRST)) == len(conftest.LONGEST_FIRST)
