"""The cost of watching a geofence: loop_us_per_sample of patrol-detour's route
with a geofence that is never breached (the state saved before each call of
the loop, the recorded rows checked after it) against the same mission
without it. The two runs give the same samples
(tests/test_reactions.py); pairs alternate, the ratio is the median of the
pairs' ratios.

    python benchmarks/geofence.py [PAIRS]
"""

from __future__ import annotations

import statistics
import sys
from pathlib import Path

from wmr_mission.api import mission_from_dict
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    pairs = int(sys.argv[1]) if len(sys.argv) > 1 else 9
    written = load_mission(ROOT / "missions" / "patrol-detour.yaml").model_dump(mode="json")
    written["regions"]["pond"]["center"] = [5, 30]  # far off the route: never breached
    watched = mission_from_dict(written)
    del written["geofence"]
    written["contingencies"] = {}
    for phase in written["phases"]:
        phase["on_breach"] = None
    plain = mission_from_dict(written)
    run_mission(plain), run_mission(watched)  # compiled, cached
    ratios, times = [], {"plain": [], "watched": []}
    for _ in range(pairs):
        us = {}
        for name, mission in (("plain", plain), ("watched", watched)):
            result = run_mission(mission)
            us[name] = result.loop_ns / 1e3 / result.samples
            times[name].append(us[name])
        ratios.append(us["watched"] / us["plain"])
    for name, values in times.items():
        print(f"{name}: loop_us_per_sample median {statistics.median(values):.3f}")
    print(f"watched / plain: median of {pairs} paired ratios {statistics.median(ratios):.2f}")


if __name__ == "__main__":
    main()
