"""The time `wmr-mission run` takes from claiming its run directory to its
first simulated samples (docs/reliability.md), for a long mission:

    python benchmarks/first_sample.py [MISSION] [REPEAT]

MISSION defaults to tests/data/long-circle.yaml (1,000 s at dt 0.001). Each
repeat runs `run` in a fresh process (as a user does: numba and the compiled
loop loaded afresh), times the claim (``prepare_run_dir`` returning) and the
first return of the loop with samples recorded (the end of its first chunk:
an upper bound of the first sample), then stops the run there. The kernel
cache is warmed by a first run not counted.
"""

from __future__ import annotations

import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import wmr_mission.output.rundir as rundir
import wmr_mission.sim.runner as runner
from wmr_mission.commands.run import run_command

ROOT = Path(__file__).resolve().parents[1]
marks: dict[str, float] = {}
_claim = rundir.prepare_run_dir
_call = runner._Run._call


def timed_claim(*args: Any, **kwargs: Any) -> Path:
    claimed = _claim(*args, **kwargs)
    marks["claim"] = time.perf_counter()
    return claimed


def timed_call(self: runner._Run, *args: Any) -> int:
    status = _call(self, *args)
    if "first" not in marks and self.recorder.count > 0:
        marks["first"] = time.perf_counter()
        raise KeyboardInterrupt  # stopped there: the rest is not measured
    return status


def once(mission: Path, out: Path) -> float:
    marks.clear()
    shutil.rmtree(out, ignore_errors=True)
    run_command(mission, out=out, seed=None, plots=False, animate=False)
    return marks["first"] - marks["claim"]


def main(arguments: list[str]) -> None:
    if arguments[:1] == ["--one"]:  # one run, in this process
        rundir.prepare_run_dir = timed_claim
        runner._Run._call = timed_call  # type: ignore[method-assign]
        print(once(Path(arguments[1]), Path(arguments[2])))
        return
    mission = Path(arguments[0]) if arguments else ROOT / "tests" / "data" / "long-circle.yaml"
    repeat = int(arguments[1]) if len(arguments) > 1 else 5
    with tempfile.TemporaryDirectory() as directory:
        one = [sys.executable, __file__, "--one", str(mission), str(Path(directory) / "run")]
        runs = [subprocess.run(one, capture_output=True, text=True) for _ in range(repeat + 1)]
    times = [float(done.stdout.split()[-1]) for done in runs[1:]]  # the first warms the cache
    print(
        f"claim to first samples: median {statistics.median(times):.3f} s, "
        f"max {max(times):.3f} s ({', '.join(f'{t:.3f}' for t in times)})",
        file=sys.stderr,
    )


if __name__ == "__main__":
    main(sys.argv[1:])
