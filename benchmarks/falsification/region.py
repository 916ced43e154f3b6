"""The failing share of a benchmark's space, on a dense grid of its box.

    python benchmarks/falsification/region.py CAMPAIGN.yaml [--points N ...] [--workers N]

Each continuous axis is cut into N cells (a number per axis, the last
repeated), each point at its cell's centre, a discrete axis at each of its
values; each point is run as `falsify` runs
an evaluation (its sensor seed from the search seed 0 and the point's index)
and judged failing as `falsify` judges it. The share of failing points
estimates the share of the box (under the campaign's distribution) where a
run fails: what a uniform random search finds with each run.
"""

from __future__ import annotations

import argparse
import itertools
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from wmr_mission.campaign.falsify.evaluate import evaluate_draws
from wmr_mission.campaign.falsify.loop import draws_of
from wmr_mission.campaign.falsify.space import Space
from wmr_mission.campaign.load import load_campaign


def grid(space: Space, points: list[int]) -> list[list[float]]:
    """Cell centres: ``points[i]`` cells on continuous axis i (the last number
    repeated for the axes after it), every value of a discrete axis."""
    axes = []
    bounds = zip(space.counts(), space.lower(), space.upper(), strict=True)
    for i, (count, lo, hi) in enumerate(bounds):
        n = points[min(i, len(points) - 1)]
        if count:
            axes.append([float(v) for v in range(count)])
        else:
            axes.append([lo + (hi - lo) * (k + 0.5) / n for k in range(n)])
    return [list(p) for p in itertools.product(*axes)]


def _share(args: tuple[str, list[list[float]], int]) -> list[tuple[int, bool, float]]:
    path, points, start = args
    loaded = load_campaign(path)
    space = Space(loaded.campaign)
    draws = draws_of(space, 0, start, points)
    return [(e.index, e.falsified, e.objective) for e in evaluate_draws(loaded, draws, None)]


def failing_share(path: str, points: list[int], workers: int) -> tuple[int, int]:
    space = Space(load_campaign(path).campaign)
    cells = grid(space, points)
    size = 200
    tasks = [(path, cells[i : i + size], i) for i in range(0, len(cells), size)]
    with ProcessPoolExecutor(workers) as pool:
        results = [r for chunk in pool.map(_share, tasks) for r in chunk]
    return sum(failing for _, failing, _ in results), len(results)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path)
    parser.add_argument(
        "--points",
        type=int,
        nargs="+",
        default=[100],
        help="cells of each continuous axis in campaign order (the last repeats)",
    )
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    failing, total = failing_share(str(args.campaign), args.points, args.workers)
    print(f"{args.campaign}: {failing} of {total} grid points fail ({failing / total:.3%})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
