"""Same mission and seed, same bytes, whatever SIMD level the machine's CPU offers.

A machine with another CPU is simulated on this one, in subprocesses:

* numpy: ``NPY_DISABLE_CPU_FEATURES`` names every SIMD level numpy would
  dispatch to above its baseline here (AVX-512 and AVX2 on this machine);
* numba: ``NUMBA_CPU_NAME=x86-64-v2`` compiles the loop for an x86-64-v2
  CPU (SSE4.2, no AVX), its kernels cached beside this CPU's (numba keys each
  cached entry by the CPU it was compiled for: a shared cache, warm after the
  first session);
* glibc: ``GLIBC_TUNABLES=glibc.cpu.hwcaps=-AVX512F,...`` (ld.so
  --list-diagnostics shows it taken: glibc-hwcaps x86-64-v4 inactive);
* OpenBLAS: ``OPENBLAS_CORETYPE=Nehalem``.

The outputs of runs and a campaign (tests/same_bytes_outputs.py) are then the
bytes this process writes. glibc is lowered to an AVX2 CPU with FMA only: its
math functions without FMA (``-FMA,-AVX2``, x86-64-v2 CPUs) differ in the last
bit, and there the runs agree within a tolerance instead
(test_without_fma_the_c_library_moves_the_last_digits_only; docs/reliability.md).

The short missions in tests/data/same-bytes/ run every kind of path, every
expression function, every region, estimator and disturbance; under the
``sweep`` marker every shipped mission runs too.
"""

from __future__ import annotations

import json
import os
import platform
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from pinned_trajectories import assert_close
from same_bytes_outputs import outputs

from wmr_mission.kernels import jit
from wmr_mission.output.environment import numpy_simd

TESTS = Path(__file__).resolve().parent
SAME_BYTES = TESTS / "data" / "same-bytes"
SHORT = [SAME_BYTES / "paths.yaml", SAME_BYTES / "noisy.yaml", SAME_BYTES / "campaign.yaml"]
MISSIONS = sorted((TESTS.parent / "missions").glob("*.yaml"))
# glibc 2.33 and later name the features so; 2.26 to 2.32 with "_Usable"; an
# unknown name is ignored.
AVX512 = ("AVX512F", "AVX512VL", "AVX512BW", "AVX512DQ", "AVX512CD")
NO_AVX512 = ",".join(f"-{name},-{name}_Usable" for name in AVX512)
NO_FMA = "-FMA,-AVX2,-FMA_Usable,-AVX2_Usable"

pytestmark = pytest.mark.skipif(
    platform.machine().lower() not in ("x86_64", "amd64") or not sys.platform.startswith("linux"),
    reason="the SIMD levels and the C library simulated are x86-64 Linux's",
)


def _with_hwcaps(env: dict[str, str], masked: str) -> dict[str, str]:
    """``env`` with glibc's hardware capabilities ``masked`` too (added to any
    the environment masks already: the suite may run in a lowered one)."""
    tunables = [t for t in env.get("GLIBC_TUNABLES", "").split(":") if t]
    hwcaps = [t for t in tunables if t.startswith("glibc.cpu.hwcaps=")]
    others = [t for t in tunables if not t.startswith("glibc.cpu.hwcaps=")]
    masks = [t.split("=", 1)[1] for t in hwcaps] + [masked]
    return {**env, "GLIBC_TUNABLES": ":".join([*others, "glibc.cpu.hwcaps=" + ",".join(masks)])}


def lowered(compiled: bool) -> dict[str, str]:
    """This environment, as on an x86-64-v2 CPU for numpy, numba and OpenBLAS,
    and an AVX2 CPU with FMA for glibc; compiled, or as plain Python."""
    env = _with_hwcaps(dict(os.environ), NO_AVX512)
    above_baseline = numpy_simd()
    if above_baseline:
        env["NPY_DISABLE_CPU_FEATURES"] = ",".join(above_baseline)
    env["OPENBLAS_CORETYPE"] = "Nehalem"
    if compiled:
        env["NUMBA_CPU_NAME"] = "x86-64-v2"
        env.pop("WMR_MISSION_NO_JIT", None)
    else:
        env["WMR_MISSION_NO_JIT"] = "1"
    return env


def start(env: dict[str, str], out: Path, files: list[Path]) -> subprocess.Popen[str]:
    """tests/same_bytes_outputs.py in ``env``, started (several run side by side)."""
    command = [sys.executable, str(TESTS / "same_bytes_outputs.py"), str(out), *map(str, files)]
    return subprocess.Popen(
        command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )


def finish(process: subprocess.Popen[str]) -> dict[str, str]:
    # the first session compiles the loop for x86-64-v2: about 30 s
    stdout, stderr = process.communicate(timeout=900)
    assert process.returncode == 0, stderr
    found: dict[str, str] = json.loads(stdout)
    return found


def outputs_in(env: dict[str, str], out: Path, files: list[Path]) -> dict[str, str]:
    return finish(start(env, out, files))


def assert_same(ours: dict[str, str], theirs: dict[str, str]) -> None:
    assert sorted(theirs) == sorted(ours)
    differing = [name for name in ours if theirs[name] != ours[name]]
    assert not differing, f"different bytes in {differing}"


def test_the_lowered_environment_is_taken() -> None:
    """What each setting lowers, seen from inside the process it is given to."""
    check = (
        "import json, os\n"
        "from threadpoolctl import threadpool_info\n"
        "from wmr_mission.kernels import jit\nfrom wmr_mission.output import environment\n"
        "jit.load()\n"
        "blas = [i.get('architecture') for i in threadpool_info() if i['user_api'] == 'blas']\n"
        "loader = os.popen('/lib64/ld-linux-x86-64.so.2 --list-diagnostics').read()\n"
        "print(json.dumps([environment.numpy_simd(), environment.numba_cpu(), blas, loader]))\n"
    )
    env = lowered(compiled=jit.compiling())
    done = subprocess.run(
        [sys.executable, "-c", check], env=env, capture_output=True, text=True, timeout=900
    )
    assert done.returncode == 0, done.stderr
    numpy_levels, numba_cpu, blas, loader = json.loads(done.stdout)
    assert numpy_levels == []
    assert numba_cpu == ("x86-64-v2" if jit.compiling() else None)
    assert blas in ([], ["Nehalem"])  # numpy's OpenBLAS, when it is loaded
    if "dl_hwcaps_subdirs_active=" in loader:  # glibc 2.33 and later
        active = int(loader.split("dl_hwcaps_subdirs_active=")[1].split()[0], 16)
        assert not active & 1  # x86-64-v4, the first glibc-hwcaps subdirectory, is off


def test_the_bytes_do_not_depend_on_the_simd_level(tmp_path: Path) -> None:
    plain = start(lowered(compiled=False), tmp_path / "plain", SHORT)
    compiled = start(lowered(compiled=True), tmp_path / "compiled", SHORT)
    ours = outputs(tmp_path / "here", SHORT)
    assert any(name.endswith("runs.csv") for name in ours)
    assert_same(ours, finish(plain))
    if jit.compiling():
        assert_same(ours, finish(compiled))
    else:
        compiled.communicate(timeout=900)


@pytest.mark.sweep
def test_every_shipped_mission_gives_the_same_bytes_at_a_lower_simd_level(tmp_path: Path) -> None:
    ours = outputs(tmp_path / "here", MISSIONS)
    assert_same(ours, outputs_in(lowered(compiled=jit.compiling()), tmp_path / "there", MISSIONS))


def _trajectory(text: str) -> tuple[list[str], np.ndarray, list[str]]:
    """The phase column, the numbers and their columns' names of a trajectory.csv."""
    lines = [line.split(",") for line in text.splitlines()]  # no phase name holds a comma
    phase = lines[0].index("phase")
    numbers = [[float(v) for i, v in enumerate(row) if i != phase] for row in lines[1:]]
    names = [name for i, name in enumerate(lines[0]) if i != phase]
    return [row[phase] for row in lines[1:]], np.array(numbers), names


def _fma_in_glibc() -> bool:
    """Whether glibc picks its FMA variants here and takes GLIBC_TUNABLES'
    feature names as the test writes them (glibc 2.33 and later)."""
    from numpy._core._multiarray_umath import __cpu_features__ as features

    name, version = platform.libc_ver()
    major, minor = (int(part) for part in (version or "0.0").split(".")[:2])
    return name == "glibc" and (major, minor) >= (2, 33) and features["FMA3"] and features["AVX2"]


def _within_tolerance_without_fma(tmp_path: Path, files: list[Path]) -> None:
    """``files`` run here and in a subprocess given glibc's builds without FMA:
    the same phases, transitions and sample counts, every number within the
    pins' tolerances (tests/pinned_trajectories.py), and the fingerprints
    tell the two apart."""
    ours = outputs(tmp_path / "here", files)
    env = _with_hwcaps(dict(os.environ), NO_FMA)
    env["WMR_MISSION_NO_JIT"] = "1"
    theirs = outputs_in(env, tmp_path / "there", files)
    assert sorted(theirs) == sorted(ours)
    if _fma_in_glibc() and "-FMA" not in os.environ.get("GLIBC_TUNABLES", ""):
        manifest = f"{files[0].stem}/manifest.json"
        assert theirs[manifest] != ours[manifest]
    for name, text in ours.items():
        if name.endswith("trajectory.csv"):
            phases, numbers, columns = _trajectory(text)
            their_phases, their_numbers, _ = _trajectory(theirs[name])
            assert their_phases == phases
            assert_close(their_numbers, numbers, columns, name)
        elif name.endswith("transitions.json"):
            mine, other = json.loads(text), json.loads(theirs[name])
            assert [(t["time"], t["from"], t["to"]) for t in other] == [
                (t["time"], t["from"], t["to"]) for t in mine
            ]


def test_without_fma_the_c_library_moves_the_last_digits_only(tmp_path: Path) -> None:
    """glibc's math functions for CPUs without FMA and AVX2 differ from those
    with in the last bit on up to one argument in 1 300 (scripts/libm_variants.py):
    on such a CPU the runs agree within tolerances instead of to the byte."""
    _within_tolerance_without_fma(tmp_path, SHORT[:2])


@pytest.mark.sweep
def test_without_fma_every_shipped_mission_moves_the_last_digits_only(tmp_path: Path) -> None:
    _within_tolerance_without_fma(tmp_path, MISSIONS)
