"""A straight path at a share of the speed limit, a robot with an acceleration
limit that starts at rest: whether its run fails along_track_lag_max, and
whether `validate` warned that it would (docs/mission-format.md, "What
`validate` checks": a path too near the speed limit to catch up with).

    python scripts/top_speed_lag.py
    python scripts/top_speed_lag.py --shares 0.9 0.95 1 --accelerations 0.5 --lengths 40

Each mission is run as the first phase (from rest at the initial state) and
after a one-second hold (`start: current`), for a path at constant speed (a
`line`) and one that ramps up to it at the robot's own acceleration (an
`expression`), which leaves nothing to catch up. The table lists every run;
the last lines count them by warned or silent and failed or passed.
"""

from __future__ import annotations

import argparse
from collections import Counter
from typing import Any

from wmr_mission import mission_from_text, run_mission
from wmr_mission.spec.loader import check_mission_text

LIMIT = 1.0  # [m/s] limits.v

MISSION = """\
version: 1
name: top-speed
robot:
  initial_state: {{x: 0, y: 0, theta: 0}}
  limits: {{v: {limit}, omega: 2, acceleration: {{v: {acceleration}, omega: 2}}}}
phases:
{hold}  - name: line
    track: {{path: {path}}}
    until: {{elapsed: {length}}}
"""
HOLD = """\
  - name: wait
    hold: {}
    until: {elapsed: 1}
"""
WARNINGS = ("runs at", "before the robot can catch its path")


def path_text(speed: float, acceleration: float, ramped: bool) -> str:
    """A line at ``speed``, or a path along x that reaches it at ``acceleration``."""
    if not ramped:
        return f"{{type: line, heading: 0, speed: {speed:g}}}"
    ramp = speed / acceleration  # [s] to reach the speed
    x = f"0.5 * {acceleration:g} * min(t, {ramp:g})**2 + {speed:g} * max(t - {ramp:g}, 0)"
    return f'{{type: expression, x: "{x}", y: "0", start: current}}'


def judge(
    share: float, acceleration: float, ramped: bool, held: bool, length: float
) -> tuple[bool, dict[str, Any]]:
    """Whether `validate` warns of the mission, and its run's along_track_lag_max
    expectation (``met``, ``value``, ``max``)."""
    text = MISSION.format(
        limit=LIMIT,
        acceleration=acceleration,
        hold=HOLD if held else "",
        path=path_text(share * LIMIT, acceleration, ramped),
        length=length,
    )
    findings = check_mission_text(text, "top-speed.yaml")[1]
    warned = any(w in f.message for f in findings for w in WARNINGS)
    summary = run_mission(mission_from_text(text)).summary()
    lag = next(
        e
        for e in summary["expectations"]
        if e["metric"] == "along_track_lag_max" and e["phase"] == "line"
    )
    return warned, lag


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--shares",
        type=float,
        nargs="+",
        default=[0.5, 0.6, 0.7, 0.8, 0.85, 0.9, 0.95, 0.97, 0.99, 1.0],
        help="the path's speed as a share of limits.v",
    )
    parser.add_argument(
        "--accelerations", type=float, nargs="+", default=[0.25, 0.5, 1.0, 2.0, 4.0]
    )
    parser.add_argument("--lengths", type=float, nargs="+", default=[8.0, 40.0])
    args = parser.parse_args()
    counts: Counter[tuple[str, str]] = Counter()
    print("| speed [m/s] | a [m/s^2] | path | after | length [s] | lag [m] | max [m] | warned |")
    print("|---|---|---|---|---|---|---|---|")
    for share in args.shares:
        for acceleration in args.accelerations:
            for ramped in (False, True):
                for held in (False, True):
                    for length in args.lengths:
                        warned, lag = judge(share, acceleration, ramped, held, length)
                        failed = not lag["met"]
                        counts[
                            "warned" if warned else "silent", "failed" if failed else "passed"
                        ] += 1
                        print(
                            f"| {share * LIMIT:g} | {acceleration:g} | "
                            f"{'ramp' if ramped else 'line'} | {'hold' if held else 'start'} | "
                            f"{length:g} | {lag['value']:.3f} | {lag['max']:.3f} | "
                            f"{'yes' if warned else 'no'}{' (FAILED)' if failed else ''} |",
                            flush=True,
                        )
    for said in ("warned", "silent"):
        print(f"{said}: failed {counts[said, 'failed']}, passed {counts[said, 'passed']}")


if __name__ == "__main__":
    main()
