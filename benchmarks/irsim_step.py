"""One step of IR-SIM, for the side-by-side table of docs/performance.md.

    pip install ir-sim          # in a separate environment: not a dependency
    python benchmarks/irsim_step.py

One differential-drive robot in an empty 20 m x 20 m world, headless, at
dt = 0.01 s, driven with a constant (v, omega): the cost of IR-SIM's own step
(kinematics, geometry update, collision and arrival checks), which is what a
user pays per sample before adding any estimator or controller. Prints the
median over 5 blocks of 2000 steps of the thread's CPU time and of wall time.
"""

from __future__ import annotations

import os
import statistics
import tempfile
import time
from pathlib import Path

WORLD = """\
world: {height: 20, width: 20, step_time: 0.01}
robot:
  - kinematics: {name: diff}
    shape: {name: circle, radius: 0.2}
    state: [1, 1, 0]
    goal: [9, 9, 0]
"""


def main() -> None:
    import irsim
    import numpy as np

    with tempfile.TemporaryDirectory() as directory:
        world = Path(directory) / "world.yaml"
        world.write_text(WORLD)
        env = irsim.make(str(world), headless=True, log_level="WARNING")
    action = np.array([[0.5], [0.2]])
    for _ in range(200):  # warm up
        env.step(action)
    cpu_us, wall_us = [], []
    for _ in range(5):
        cpu, wall = time.thread_time_ns(), time.perf_counter_ns()
        for _ in range(2000):
            env.step(action)
        cpu_us.append((time.thread_time_ns() - cpu) / 2000 / 1000)
        wall_us.append((time.perf_counter_ns() - wall) / 2000 / 1000)
    print(
        f"IR-SIM {irsim.__version__}: one step of one headless diff-drive robot: "
        f"median {statistics.median(cpu_us):.0f} us CPU, {statistics.median(wall_us):.0f} us wall "
        f"(load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs)"
    )


if __name__ == "__main__":
    main()
