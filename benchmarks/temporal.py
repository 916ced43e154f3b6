"""The robustness of temporal `expect` formulas on a 1-hour phase (360 000
samples at 10 ms), per formula: the best of 5 evaluations of every sample's rho;
and what case study 2's formulas add to judging its run (a campaign's judge,
with and without them in 30 alternating pairs: the least and the median).

    python benchmarks/temporal.py

Timings depend on the machine and on what else runs on it.
"""

from __future__ import annotations

import copy
import statistics
import time
from pathlib import Path

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
    case2()
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


def case2() -> None:
    from wmr_mission.api import load_mission, run_mission
    from wmr_mission.verdicts.metrics import judge_run_metrics

    result = run_mission(load_mission(Path(__file__).parent.parent / "missions" / "case2.yaml"))
    with_formulas = result.mission
    assert with_formulas is not None  # the mission as run, kept by the judge
    without = copy.deepcopy(with_formulas)
    for phase in without["phases"]:
        phase["expect"]["temporal"] = None
    times: dict[str, list[float]] = {"with": [], "without": []}
    for _ in range(30):
        for name, mission in (("with", with_formulas), ("without", without)):
            start = time.perf_counter()
            judge_run_metrics(result, mission)
            times[name].append(time.perf_counter() - start)
    for pick in (min, statistics.median):
        judged = {name: pick(found) * 1e3 for name, found in times.items()}
        print(
            f"judging case study 2's run ({pick.__name__} of 30 alternating pairs): "
            f"{judged['with']:.2f} ms with its two formulas, {judged['without']:.2f} ms without"
        )


if __name__ == "__main__":
    main()
