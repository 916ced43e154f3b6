"""Robots that stop at a keep-out zone's edge: a rock on a straight line met
under acceleration limits, and a box just ahead of a robot at rest
(docs/paper-notes.md, eq. (28), "An aim beyond a zone").

    python scripts/zone_stops.py

The rocks: a circle or a box turned 0.4 rad (radius or half-side 0.2 and
0.4 m) on the line y = 0 at x = 4 m, or 0.15 m off it, the line at 0.5, 1
and 1.5 m/s (the speed limit twice that, the turn-rate limit 3 rad/s), the
turn-rate acceleration 3, 6 or 12 rad/s^2 with the speed's 1 or 3 m/s^2 (or
none: 24 runs), 1 cm and 5 mrad of noise, for 8 m / speed + 4 s. Prints the
runs that succeed, with and without acceleration limits, and each other run
with how far behind its reference it ended. Then the box ahead: centred 0.4 m from
the start, with and without acceleration limits, to (8, 0) within 30 s."""

from __future__ import annotations

import collections
import itertools

from wmr_mission import mission_from_text, run_mission

ROCK = """
version: 1
name: rock
robot:
  dt: 0.01
  initial_state: {{x: 0, y: 0, theta: 0}}
  limits: {{v: {v_limit}, omega: 3{acceleration}}}
sensors: {{measure: [x, y, theta], noise_std: {{x: 0.01, y: 0.01, theta: 0.005}}, seed: 1}}
regions:
  rock: {rock}
phases:
  - name: go
    track: {{path: {{type: line, towards: [8, 0], speed: {speed}}}}}
    constraints: [{{stay_outside: rock}}]
    until: {{elapsed: {duration}}}
"""

BOX_AHEAD = """
version: 1
name: box-ahead
robot:
  dt: 0.01
  initial_state: {{x: 0, y: 0, theta: 0}}
  limits: {{v: 2, omega: 3{acceleration}}}
regions:
  box: {{type: box, center: [0.4, 0], size: [0.4, 0.4]}}
phases:
  - name: go
    track: {{path: {{type: line, towards: [8, 0], speed: 1.0}}}}
    constraints: [{{stay_outside: box}}]
    until: {{near: {{point: [8, 0], tolerance: 0.1}}}}
    timeout: 30
"""


def _failed(run: object) -> list[tuple[str, float | None, float]]:
    checks = run.judged["expectations"]  # type: ignore[attr-defined]
    return [
        (c["metric"], None if c["value"] is None else round(c["value"], 3), round(c["max"], 3))
        for c in checks
        if not c["met"]
    ]


def rocks() -> None:
    counts: collections.Counter[tuple[str, bool]] = collections.Counter()
    others = []
    grid = itertools.product(
        [0.5, 1.0, 1.5], [None, 3, 6, 12], [1.0, 3.0], [0.2, 0.4], [0.0, 0.15], ["circle", "box"]
    )
    for speed, a_omega, a_v, size, off, shape in grid:
        if a_omega is None and a_v == 3.0:
            continue
        acceleration = "" if a_omega is None else f", acceleration: {{v: {a_v}, omega: {a_omega}}}"
        rock = (
            f"{{type: circle, center: [4, {off}], radius: {size}}}"
            if shape == "circle"
            else f"{{type: box, center: [4, {off}], size: [{2 * size}, {2 * size}], heading: 0.4}}"
        )
        text = ROCK.format(
            v_limit=2 * speed, acceleration=acceleration, rock=rock, speed=speed,
            duration=8 / speed + 4,
        )  # fmt: skip
        run = run_mission(mission_from_text(text))
        limited = a_omega is not None
        counts[("with" if limited else "without", run.succeeded)] += 1
        if not run.succeeded:
            behind = float(run.x_ref[-2] - run.x[-2])
            others.append((speed, a_omega, a_v, size, off, shape, round(behind, 2), _failed(run)))
    for limited in ("without", "with"):
        total = counts[(limited, True)] + counts[(limited, False)]
        print(f"{limited} acceleration limits: {counts[(limited, True)]} of {total} succeed")
    print("the others (speed, a_omega, a_v, size, off, shape, m behind at the end, failed):")
    for other in others:
        print(" ", other)


def box_ahead() -> None:
    for acceleration in ("", ", acceleration: {v: 2, omega: 6}"):
        run = run_mission(mission_from_text(BOX_AHEAD.format(acceleration=acceleration)))
        words = "with" if acceleration else "without"
        print(
            f"box ahead, {words} acceleration limits: {run.outcome.value} at t = {run.t[-1]:.2f} s"
        )


if __name__ == "__main__":
    rocks()
    box_ahead()
