"""A run's margin over a grid of two axes of a benchmark's box, the others held.

    python benchmarks/falsification/landscape.py CAMPAIGN.yaml --rows I A B N --cols J A B N
        [--at U ...] [--workers N]

Axis I is swept from A to B in N rows and axis J in N columns (coordinates of
the box, each in [0, 1] for a continuous axis, as `falsify` searches it); the
other axes stay at ``--at`` (default: the middle of the box). Each point is
run as `falsify` runs an evaluation (its sensor seed from the search seed 0
and the point's index) and printed as its margin in thousandths (``-inf``
where a run did not complete its phases): the landscape the search walks on.
"""

from __future__ import annotations

import argparse
import math
import sys
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

from region import _share

from wmr_mission.campaign.falsify.space import Space
from wmr_mission.campaign.load import load_campaign


def _cell(margin: float) -> str:
    return f"{round(1000 * margin):6d}" if math.isfinite(margin) else f"{margin:>6}"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path)
    parser.add_argument("--rows", nargs=4, type=float, required=True, metavar=("I", "A", "B", "N"))
    parser.add_argument("--cols", nargs=4, type=float, required=True, metavar=("J", "A", "B", "N"))
    parser.add_argument("--at", type=float, nargs="+")
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    space = Space(load_campaign(args.campaign).campaign)
    at = args.at or [(lo + hi) / 2 for lo, hi in zip(space.lower(), space.upper(), strict=True)]
    (i, a, b, n), (j, c, d, m) = args.rows, args.cols
    rows = [a + (b - a) * k / max(int(n) - 1, 1) for k in range(int(n))]
    cols = [c + (d - c) * k / max(int(m) - 1, 1) for k in range(int(m))]
    points = []
    for row in rows:
        for col in cols:
            point = list(at)
            point[int(i)], point[int(j)] = row, col
            points.append(point)
    size = 50
    tasks = [(str(args.campaign), points[k : k + size], k) for k in range(0, len(points), size)]
    with ProcessPoolExecutor(args.workers) as pool:
        margins = [margin for chunk in pool.map(_share, tasks) for _, _, margin in chunk]
    print(f"rows: {space.paths[int(i)]}, columns: {space.paths[int(j)]}; margin x 1000")
    print("       " + "".join(f"{col:6.3f}" for col in cols))
    for k, row in enumerate(rows):
        cells = margins[k * len(cols) : (k + 1) * len(cols)]
        print(f"{row:6.4f} " + "".join(_cell(margin) for margin in cells))
    return 0


if __name__ == "__main__":
    sys.exit(main())
