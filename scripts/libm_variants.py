"""How far apart numpy's SIMD levels and the C library's builds put two machines.

glibc picks, per CPU, one of several builds of sin, cos, exp, log, pow,
atan2 ...: with fused multiply-adds where the CPU has FMA and AVX2 (x86-64-v3
and up), without elsewhere. ``GLIBC_TUNABLES=glibc.cpu.hwcaps=-FMA,-AVX2``
makes this machine pick the latter, as an older CPU would (glibc 2.33 and
later spell the features so; an unknown name is silently ignored). This
script, in subprocesses:

1. evaluates numpy's float64 exp, log, power, arctan2, sin, cos and tanh on
   2 000 000 random arguments at numpy's SIMD levels found here and with
   ``NPY_DISABLE_CPU_FEATURES`` naming all of them (its baseline), and counts
   the results that differ: what the simulation no longer uses;
2. evaluates each function of Python's math (the C library's) on 2 000 000
   random arguments with and without ``-FMA,-AVX2``, and counts the results
   that differ, and by how many ulp at most;
3. runs every shipped mission (as plain Python, so that no compile is
   needed) with and without it and prints, per mission, whether outcome,
   sample count and phases agree, and the largest difference of the poses
   (x, y, theta and their estimates, references and measurements) and of the
   inputs (v, omega).

    python scripts/libm_variants.py                      # the figures in docs/reliability.md
    python scripts/libm_variants.py MISSION.yaml ...     # other missions in step 3
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parent.parent
WITHOUT_FMA = "glibc.cpu.hwcaps=-FMA,-AVX2"
ARGUMENTS = 2_000_000
FUNCTIONS = ("sin", "cos", "tan", "asin", "acos", "atan", "sinh", "cosh", "tanh", "exp", "log")
FUNCTIONS += ("log10", "expm1", "atan2", "pow", "hypot", "sqrt")
INPUTS = ("v", "omega")

CHILD = """
import json, math, sys
import numpy as np
from pathlib import Path
from wmr_mission.output.rundir import trajectory_csv_text
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission

out = Path(sys.argv[1])
rng = np.random.default_rng(1)
x = rng.uniform(-10.0, 10.0, {n})
y = rng.uniform(-4.0, 4.0, {n})
domain = {{"asin": x / 10.0, "acos": x / 10.0, "log": np.abs(x), "log10": np.abs(x),
          "sqrt": np.abs(x), "pow": np.abs(x)}}
values = {{}}
for name in {functions!r}:
    function = getattr(math, name)
    first = domain.get(name, x).tolist()
    if name in ("atan2", "pow", "hypot"):
        values[name] = [function(a, b) for a, b in zip(first, y.tolist())]
    else:
        values[name] = [function(a) for a in first]
np.savez(out / "functions.npz", **values)
for path in map(Path, sys.argv[2:]):
    result = run_mission(load_mission(path))
    (out / f"{{path.stem}}.csv").write_text(trajectory_csv_text(result))
    print(path.stem, result.outcome.value, result.samples)
"""


NUMPY_CHILD = """
import sys
import numpy as np
rng = np.random.default_rng(1)
x = rng.uniform(-10.0, 10.0, {n})
y = rng.uniform(-4.0, 4.0, {n})
np.savez(sys.argv[1], exp=np.exp(x), log=np.log(np.abs(x)), power=np.power(np.abs(x), y),
         arctan2=np.arctan2(x, y), sin=np.sin(x), cos=np.cos(x), tanh=np.tanh(x))
"""


def _numpy_levels(tmp: Path) -> None:
    from wmr_mission.output.environment import numpy_simd

    levels = numpy_simd()
    child = NUMPY_CHILD.format(n=ARGUMENTS)
    subprocess.run([sys.executable, "-c", child, str(tmp / "simd.npz")], check=True)
    env = {**os.environ, "NPY_DISABLE_CPU_FEATURES": ",".join(levels)}
    subprocess.run([sys.executable, "-c", child, str(tmp / "baseline.npz")], env=env, check=True)
    simd, baseline = np.load(tmp / "simd.npz"), np.load(tmp / "baseline.npz")
    print(f"numpy at {' '.join(levels) or 'its baseline'} against its baseline, {ARGUMENTS}")
    print("arguments each: results that differ")
    for name in simd.files:
        differ = int(np.sum(simd[name].view(np.int64) != baseline[name].view(np.int64)))
        print(f"  np.{name:8s} {differ:7d} ({100.0 * differ / ARGUMENTS:.2f} %)")


def _run(out: Path, tunables: str | None, missions: list[Path]) -> None:
    out.mkdir(parents=True, exist_ok=True)
    env = {**os.environ, "WMR_MISSION_NO_JIT": "1"}
    if tunables is not None:
        env["GLIBC_TUNABLES"] = tunables
    child = CHILD.format(n=ARGUMENTS, functions=FUNCTIONS)
    command = [sys.executable, "-c", child, str(out), *map(str, missions)]
    subprocess.run(command, env=env, check=True)


def _table(path: Path) -> tuple[list[str], list[str], np.ndarray]:
    lines = [line.split(",") for line in path.read_text().splitlines()]
    phase = lines[0].index("phase")
    names = [name for i, name in enumerate(lines[0]) if i != phase]
    numbers = np.array([[float(v) for i, v in enumerate(row) if i != phase] for row in lines[1:]])
    return names, [row[phase] for row in lines[1:]], numbers


def main(arguments: list[str]) -> None:
    import tempfile

    missions = [Path(a) for a in arguments] or sorted((ROOT / "missions").glob("*.yaml"))
    with tempfile.TemporaryDirectory() as tmp:
        _numpy_levels(Path(tmp))
        here, there = Path(tmp) / "fma", Path(tmp) / "no-fma"
        _run(here, None, missions)
        _run(there, WITHOUT_FMA, missions)
        ours, theirs = np.load(here / "functions.npz"), np.load(there / "functions.npz")
        print(f"\nfunctions, {ARGUMENTS} arguments each: results that differ (most ulp apart)")
        for name in FUNCTIONS:
            a, b = ours[name], theirs[name]
            differ = a.view(np.int64) != b.view(np.int64)
            ulps = int(np.max(np.abs(a.view(np.int64) - b.view(np.int64)))) if differ.any() else 0
            print(f"  {name:6s} {int(differ.sum()):6d} ({ulps} ulp)")
        print("\nmissions: same outcome, samples and phases; largest difference (poses, inputs)")
        report = {}
        for path in sorted(here.glob("*.csv")):
            names, phases, mine = _table(path)
            _, their_phases, other = _table(there / path.name)
            same = phases == their_phases and mine.shape == other.shape
            with np.errstate(invalid="ignore"):
                gap = np.where(np.isnan(mine) & np.isnan(other), 0.0, np.abs(mine - other))
            inputs = [i for i, n in enumerate(names) if n in INPUTS]
            poses = [i for i, n in enumerate(names) if n not in INPUTS]
            worst = (float(np.max(gap[:, poses])), float(np.max(gap[:, inputs])))
            report[path.stem] = (same, worst)
            print(f"  {path.stem:15s} {same!s:5s} {worst[0]:.2g} {worst[1]:.2g}")
        print(json.dumps(report))


if __name__ == "__main__":
    main(sys.argv[1:])
