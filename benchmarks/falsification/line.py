"""A run's margin along one axis of a benchmark's box, the other axes held.

    python benchmarks/falsification/line.py CAMPAIGN.yaml --at U ... --axis I
        [--from A --to B --points N]

``--at`` is a point of the box (each coordinate in [0, 1] for a continuous
axis, as `falsify` searches it); axis ``I`` is swept from A to B in N points,
each run as `falsify` runs an evaluation (its sensor seed from the search
seed 0 and the point's index). Prints the coordinate, the axis's value, the
margin and the check that sets it: the landscape the search walks on.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

from wmr_mission.campaign.falsify.evaluate import evaluate_draws
from wmr_mission.campaign.falsify.loop import draws_of
from wmr_mission.campaign.falsify.space import Space
from wmr_mission.campaign.load import load_campaign


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("campaign", type=Path)
    parser.add_argument("--at", type=float, nargs="+", required=True)
    parser.add_argument("--axis", type=int, required=True)
    parser.add_argument("--from", dest="start", type=float, default=0.0)
    parser.add_argument("--to", dest="stop", type=float, default=1.0)
    parser.add_argument("--points", type=int, default=21)
    args = parser.parse_args()
    loaded = load_campaign(args.campaign)
    space = Space(loaded.campaign)
    points = []
    for k in range(args.points):
        point = list(args.at)
        point[args.axis] = args.start + (args.stop - args.start) * k / max(args.points - 1, 1)
        points.append(point)
    path = space.paths[args.axis]
    for point, run in zip(
        points, evaluate_draws(loaded, draws_of(space, 0, 0, points), None), strict=True
    ):
        print(
            f"{point[args.axis]:.4f}  {path} = {run.values[path]:.4f}  "
            f"margin {run.objective:+.4f}  ({run.margin_check})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
