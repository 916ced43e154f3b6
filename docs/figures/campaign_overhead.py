"""Per-run cost of a campaign besides the simulation loop, for docs/campaigns.md.

    python docs/figures/campaign_overhead.py [CAMPAIGN] [REPEAT]

Times, on one core, each step a campaign takes per run of the campaign's
first draws: checking the mission with the run's values, the whole
``run_mission`` (which checks the mission again, simulates and judges it) and
the metrics of the row. Medians of REPEAT runs (default 20).
"""

from __future__ import annotations

import statistics
import sys
import time
from collections.abc import Callable
from typing import Any

from wmr_mission.campaign.load import load_campaign, override
from wmr_mission.campaign.plan import Plan
from wmr_mission.output.metrics import summarize
from wmr_mission.runner import run_mission
from wmr_mission.spec.loader import validate_mission


def _median_ms(step: Callable[[], Any], repeat: int) -> float:
    step()  # warm
    times = []
    for _ in range(repeat):
        started = time.perf_counter()
        step()
        times.append(time.perf_counter() - started)
    return 1000 * statistics.median(times)


def main() -> None:
    path = sys.argv[1] if len(sys.argv) > 1 else "missions/campaigns/case2-headings.yaml"
    repeat = int(sys.argv[2]) if len(sys.argv) > 2 else 20
    loaded = load_campaign(path)
    draw = Plan(loaded.campaign).draw(0)
    overrides = [override(p, v) for p, v in draw.values.items()]
    mission, _ = loaded.mission_with(overrides)
    assert mission is not None
    result = run_mission(mission, seed=draw.seed)
    steps = {
        "check the mission with the run's values": lambda: loaded.mission_with(overrides),
        "run_mission: check it again": lambda: validate_mission(mission),
        "run_mission: whole (check, loop, judge)": lambda: run_mission(mission, seed=draw.seed),
        "metrics of the row (summarize)": lambda: summarize(result, result.mission),
    }
    for name, step in steps.items():
        print(f"{name:45s} {_median_ms(step, repeat):8.2f} ms")


if __name__ == "__main__":
    main()
