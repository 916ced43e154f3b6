"""Falsification rate and runs to the first failure, per benchmark and method.

    nice -n 5 python benchmarks/falsification/table.py [CAMPAIGN ...] [--seeds 20] [--seeds-from 0]
        [--budget 300] [--methods gp cmaes random]

(The campaigns before ``--methods``, which takes every word after it.)
Each benchmark campaign is searched by each method with seeds S .. S+N-1 (0 .. 19 by default)
(`falsify --first --budget B --seed S`); a row gives, as the ARCH-COMP
falsification tables do, the falsification rate (FR: seeds that found a
failing run within the budget), and the mean and median of the runs to the
first failure over the seeds that found one. `median (all)` counts a seed
that found none as needing more than the budget (">B" when that is the
median), so that a method that falsifies less often does not look faster.
"""

from __future__ import annotations

import argparse
import statistics
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from wmr_mission.campaign.falsify import METHODS
from wmr_mission.campaign.falsify.command import falsify_campaign

HERE = Path(__file__).parent
BENCHMARKS = sorted(str(p) for p in HERE.glob("*-campaign.yaml"))


def runs_to_failure(args: tuple[str, str, int, int]) -> int | None:
    campaign, method, seed, budget = args
    result = falsify_campaign(
        campaign, budget=budget, method=method, seed=seed, first=True, workers=1
    )
    found: int | None = result.record["runs_to_first_failure"]
    return found


def median_all(found: list[int | None], budget: int) -> str:
    """The median with a seed that found nothing counted as more than the budget."""
    ordered = sorted(budget + 1 if f is None else f for f in found)
    middle = statistics.median(ordered)
    return f">{budget}" if middle > budget else f"{middle:g}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaigns", nargs="*", default=BENCHMARKS)
    parser.add_argument("--seeds", type=int, default=20)
    parser.add_argument("--seeds-from", type=int, default=0)
    parser.add_argument("--budget", type=int, default=300)
    parser.add_argument("--workers", type=int, default=2)
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    args = parser.parse_args()
    print("| benchmark | method | FR | mean | median | median (all) |")
    print("|---|---|---|---|---|---|")
    with ProcessPoolExecutor(args.workers) as pool:
        for campaign in args.campaigns:
            for method in args.methods:
                tasks = [
                    (campaign, method, seed, args.budget)
                    for seed in range(args.seeds_from, args.seeds_from + args.seeds)
                ]
                found = list(pool.map(runs_to_failure, tasks))
                hits = [f for f in found if f is not None]
                mean = f"{statistics.mean(hits):.1f}" if hits else "-"
                median = f"{statistics.median(hits):g}" if hits else "-"
                name = Path(campaign).name.removesuffix("-campaign.yaml")
                print(
                    f"| {name} | {method} | {len(hits)}/{len(found)} | {mean} | {median} | "
                    f"{median_all(found, args.budget)} |",
                    flush=True,
                )
    return 0


if __name__ == "__main__":
    sys.exit(main())
