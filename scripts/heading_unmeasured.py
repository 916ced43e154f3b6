"""Users' missions with and without a heading measurement, judged by the
default verdicts (docs/paper-notes.md, "Eqs. (6)-(7) under position noise").

    python scripts/heading_unmeasured.py            # the table: missed verdicts per case
    python scripts/heading_unmeasured.py --runs     # and every run that is not a success
    python scripts/heading_unmeasured.py --json F   # also each run's missed checks, to F
    python scripts/heading_unmeasured.py --initial-estimate-off   # estimates that start off
    python scripts/heading_unmeasured.py --route    # tests/data/gps-route.yaml's estimate

The missions: a line, a polyline (a square's three legs), a circle and a park
(drive 3 m and turn to a heading), tracked at 0.3, 0.6 and 1.0 m/s (the park's
regulator at its own pace), limits 1 m/s and 1.5 rad/s, sampled at 0.05 s and
0.01 s, with the positions measured alone (a GPS) or with the heading, at 0,
0.5, 1 and 2 cm of position noise (and as many mrad of heading noise), by the
paper's observer and by the EKF, seed 0: 576 runs, the park's speeds one.
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
from collections import Counter
from concurrent.futures import ProcessPoolExecutor
from typing import Any

PATHS = ("line", "polyline", "circle", "park")
SPEEDS = (0.3, 0.6, 1.0)
NOISES = (0.0, 0.005, 0.01, 0.02)
DTS = (0.05, 0.01)
SENSORS = ("gps", "pose")
ESTIMATORS = ("constrained-observer", "ekf")


def phase(path: str, speed: float) -> dict[str, Any]:
    if path == "line":
        return {
            "name": "go",
            "track": {"path": {"type": "line", "heading": 0.5, "speed": speed}},
            "until": {"elapsed": 15},
        }
    if path == "polyline":
        points = [[0, 0], [5, 0], [5, 4], [0, 4]]
        return {
            "name": "go",
            "track": {"path": {"type": "polyline", "points": points, "speed": speed}},
            "until": {"elapsed": 13.0 / speed + 3.0},
        }
    if path == "circle":
        return {
            "name": "go",
            "track": {
                "path": {
                    "type": "circle",
                    "center": [0, 2],
                    "radius": 2,
                    "angular_rate": speed / 2,
                    "start": "current",
                }
            },
            "until": {"elapsed": 20},
        }
    return {
        "name": "go",
        "regulate": {"target": {"x": 3, "y": 1, "theta": 1.0}},
        "until": {"settled": {"position": 0.03, "heading": 0.03}},
        "timeout": 30,
    }


def mission(
    path: str, speed: float, noise: float, dt: float, sensors: str, estimator: str
) -> dict[str, Any]:
    measure = ["x", "y"] if sensors == "gps" else ["x", "y", "theta"]
    std = {"x": noise, "y": noise, **({"theta": noise} if sensors == "pose" else {})}
    return {
        "version": 1,
        "name": "user",
        "robot": {
            "dt": dt,
            "initial_state": {"x": 0, "y": 0, "theta": 0},
            "limits": {"v": 1, "omega": 1.5},
        },
        "sensors": {"measure": measure, "noise_std": std, "seed": 0},
        "estimator": {"type": estimator},
        "phases": [phase(path, speed)],
    }


OFF = {"x": 0.1, "y": -0.1, "theta": 0.3}


def case(
    key: tuple[str, float, float, float, str, str], off: bool = False
) -> tuple[Any, str, list[str]]:
    from wmr_mission import mission_from_dict, run_mission

    data = mission(*key)
    if off:
        data["estimator"]["initial_estimate"] = OFF
    result = run_mission(mission_from_dict(data))
    missed = [c["metric"] for c in result.summary()["expectations"] if not c["met"]]
    return key, result.outcome, missed


def route() -> None:
    """tests/data/gps-route.yaml by each estimator at 0.05 s and 0.01 s: the
    heading's and the cross-track position's estimation error (std from 2 s
    on) and the turn rate's jitter and reversals."""
    from pathlib import Path

    import numpy as np

    from wmr_mission import load_mission, run_mission

    path = Path(__file__).resolve().parents[1] / "tests" / "data" / "gps-route.yaml"
    print(
        "| estimator | dt [s] | heading error std [rad] | cross-track error std [m] "
        "| jitter [rad/s] | reversals | outcome |"
    )
    print("|---|---|---|---|---|---|---|")
    for estimator, dt in itertools.product(ESTIMATORS, DTS):
        result = run_mission(
            load_mission(path, overrides={"estimator.type": estimator, "robot.dt": dt})
        )
        judged = result.t > 2.0
        heading = np.angle(np.exp(1j * (result.theta - result.theta_est)))[judged]
        theta = result.theta[judged]
        across = (
            -np.sin(theta) * (result.x - result.x_est)[judged]
            + np.cos(theta) * (result.y - result.y_est)[judged]
        )
        inputs = result.summary()["phases"][0]["inputs"]
        print(
            f"| {estimator} | {dt} | {heading.std():.2g} | {across.std():.2g} | "
            f"{inputs['turn_rate_jitter']:.3g} | {inputs['turn_rate_reversals']} | "
            f"{result.outcome} |"
        )


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", action="store_true", help="list every run not a success")
    parser.add_argument("--json", metavar="FILE", help="write each run's missed checks")
    parser.add_argument(
        "--initial-estimate-off", action="store_true", help="start each estimate off the robot"
    )
    parser.add_argument("--route", action="store_true", help="tests/data/gps-route.yaml alone")
    args = parser.parse_args(argv)
    if args.route:
        route()
        return 0
    keys = [
        k
        for k in itertools.product(PATHS, SPEEDS, NOISES, DTS, SENSORS, ESTIMATORS)
        if k[0] != "park" or k[1] == SPEEDS[0]
    ]
    with ProcessPoolExecutor(2) as pool:
        offs = [args.initial_estimate_off] * len(keys)
        results = list(pool.map(case, keys, offs, chunksize=4))
    table: Counter[tuple[str, str, str]] = Counter()
    failed: Counter[tuple[str, str]] = Counter()
    runs: Counter[tuple[str, str]] = Counter()
    for (*_, sensors, estimator), outcome, missed in results:
        runs[sensors, estimator] += 1
        failed[sensors, estimator] += outcome != "success"
        for metric in missed:
            table[sensors, estimator, metric] += 1
    print("| measured | estimator | runs | not a success | missed verdicts |")
    print("|---|---|---|---|---|")
    for sensors, estimator in itertools.product(SENSORS, ESTIMATORS):
        misses = {m: n for (s, e, m), n in sorted(table.items()) if (s, e) == (sensors, estimator)}
        words = ", ".join(f"{m} {n}" for m, n in misses.items()) or "none"
        print(
            f"| {'x, y' if sensors == 'gps' else 'x, y, theta'} | {estimator} | "
            f"{runs[sensors, estimator]} | {failed[sensors, estimator]} | "
            f"{sum(misses.values())}: {words} |"
        )
    if args.runs:
        for key, outcome, missed in results:
            if outcome != "success":
                print(*key, outcome, *missed)
    if args.json:
        with open(args.json, "w") as out:
            json.dump([[list(k), o, m] for k, o, m in results], out)
    return 0


if __name__ == "__main__":
    sys.exit(main())
