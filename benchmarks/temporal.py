"""The robustness of temporal `expect` formulas on a 1-hour phase (360 000
samples at 10 ms), per formula: the best of 5 evaluations of every sample's rho.

    python benchmarks/temporal.py

Timings depend on the machine and on what else runs on it.
"""

from __future__ import annotations

import time

import numpy as np

from wmr_mission.spec.temporal import parse_formula
from wmr_mission.verdicts.temporal import robustness

SAMPLES = 360_000
FORMULAS = (
    "always(cross_track <= 0.1)",
    "eventually[0, 10](always(cross_track <= 0.05))",
    "always[0, 3000](eventually[0, 60](speed >= 0.5))",
    "(speed <= 2) until[5, 600] (target_distance <= 0.05)",
    "(speed <= 2) until (target_distance <= 0.05)",
)


def main() -> None:
    rng = np.random.default_rng(0)
    signals = {
        "cross_track": np.abs(rng.normal(0.0, 0.02, SAMPLES)),
        "speed": np.abs(rng.normal(1.0, 0.3, SAMPLES)),
        "target_distance": np.abs(rng.normal(1.0, 1.0, SAMPLES)),
    }
    for text in FORMULAS:
        node = parse_formula(text)
        times = []
        for _ in range(5):
            start = time.perf_counter()
            robustness(node, signals, 0.01, {})
            times.append(time.perf_counter() - start)
        best = min(times)
        print(f"{text}: {best * 1e3:.1f} ms, {best / SAMPLES * 1e9:.0f} ns per sample")


if __name__ == "__main__":
    main()
