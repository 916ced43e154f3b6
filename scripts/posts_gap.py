"""Two round keep-out posts (radius 0.35 m) either side of a straight track,
a round body of radius 0.25 m: which gaps between the posts the robot passes,
with and without 1 cm of sensor noise and acceleration limits, and what
`validate` says (docs/mission-format.md, "validate": a path between two
keep-out zones).

    python scripts/posts_gap.py
    python scripts/posts_gap.py --dt 0.05 --v 2 --gaps 0.75 0.78 0.79 0.8 0.81
    python scripts/posts_gap.py --tracking "output: axle" --gaps 0.58 0.6 0.62

The zone filter holds the zones at a point ``paper.rows_ahead`` ahead of the
axle, kept that much further off than the band round each zone (the body's
reach and the estimate's margin, the run's ``constraint_margin``): the
header prints twice the band and twice the band and that distance, the gap
below which the held point cannot pass between the posts.
"""

from __future__ import annotations

import argparse

import numpy as np

from wmr_mission import RunResult, mission_from_text, run_mission
from wmr_mission.controllers import paper
from wmr_mission.spec.loader import check_mission_text

RADIUS = 0.35  # [m] of each post
BODY = 0.25  # [m] the body's radius

POSTS = """\
version: 1
name: two-posts
robot:
  dt: {dt}
  initial_state: {{x: 0, y: 0, theta: 0}}
  limits: {{v: {v}, omega: 2{acceleration}}}
  footprint: {{radius: 0.25}}
sensors: {{measure: [x, y, theta], noise_std: {{x: {noise}, y: {noise}, theta: {noise}}}, seed: 0}}
{controller}regions:
  a: {{type: circle, center: [3, {half}], radius: 0.35}}
  b: {{type: circle, center: [3, -{half}], radius: 0.35}}
phases:
  - name: go
    track: {{path: {{type: line, heading: 0, speed: 0.6}}}}
    constraints: [{{stay_outside: a}}, {{stay_outside: b}}]
    until: {{near: {{point: [6, 0], tolerance: 0.1}}}}
    timeout: 25
"""


def mission_text(
    gap: float, noise: float, limited: bool, dt: float, v: float, tracking: str
) -> str:
    """The mission with the posts ``gap`` apart, edge to edge."""
    return POSTS.format(
        half=round(0.5 * gap + RADIUS, 6),
        noise=noise,
        acceleration=", acceleration: {v: 1, omega: 3}" if limited else "",
        dt=dt,
        v=v,
        controller=f"controller: {{type: paper, tracking: {{{tracking}}}}}\n" if tracking else "",
    )


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument(
        "--gaps", type=float, nargs="+", default=[0.4 + 0.05 * i for i in range(13)]
    )
    parser.add_argument("--dt", type=float, default=0.02)
    parser.add_argument("--v", type=float, default=1.0, help="limits.v [m/s]")
    parser.add_argument("--tracking", default="", help='controller.tracking, e.g. "output: axle"')
    args = parser.parse_args()

    def run(gap: float, noise: float, limited: bool) -> tuple[str, RunResult]:
        text = mission_text(gap, noise, limited, args.dt, args.v, args.tracking)
        return text, run_mission(mission_from_text(text))

    text, first = run(args.gaps[0], 0.0, False)
    controller = mission_from_text(text).controller
    assert isinstance(controller, paper.PaperController)
    ahead = paper.look_ahead(controller, args.dt, args.v)
    held = paper.rows_ahead(ahead, args.dt, args.v)
    band = first.constraint_margin  # the body's reach and the estimate's margin
    print(
        f"band {band:.3g} m, zones held {held:.3g} m ahead: 2 band = {2 * band:.3g} m, "
        f"2 (band + held) = {2 * (band + held):.3g} m"
    )
    print("| gap [m] | noise [m] | acceleration | outcome | end (x, y) | clearance [m] | warned |")
    print("|---|---|---|---|---|---|---|")
    for gap in args.gaps:
        for noise in (0.0, 0.01):
            for limited in (False, True):
                text, result = run(gap, noise, limited)
                warned = any(
                    "runs between keep-out zones" in finding.message
                    for finding in check_mission_text(text, "posts.yaml")[1]
                )
                half = 0.5 * gap + RADIUS
                clearance = (
                    min(
                        np.hypot(result.x - 3, result.y - half).min(),
                        np.hypot(result.x - 3, result.y + half).min(),
                    )
                    - RADIUS
                    - BODY
                )
                end = f"({result.x[-1]:.2f}, {result.y[-1]:.2f})"
                said = "yes" if warned else "no"
                print(
                    f"| {gap:.2f} | {noise:g} | {'1 m/s^2, 3 rad/s^2' if limited else '-'} | "
                    f"{result.outcome.value} | {end} | {clearance:.3f} | {said} |",
                    flush=True,
                )


if __name__ == "__main__":
    main()
