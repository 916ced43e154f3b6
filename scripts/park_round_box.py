"""Parks to a target behind a keep-out box or polygon, over a grid: two start
headings, with and without acceleration limits, a box, a turned box and a
polygon, three targets behind them, two target headings and two sampling
periods; the count of each outcome (docs/paper-notes.md, eq. (28), "A park
round a box or a polygon").

    python scripts/park_round_box.py
"""

from __future__ import annotations

import itertools
from collections import Counter

from wmr_mission import mission_from_text, run_mission

MISSION = """
version: 1
name: park-round-a-box
robot:
  dt: {dt}
  initial_state: {{x: 0, y: 0, theta: {heading}}}
  limits: {{v: 0.8, omega: 1.5{acceleration}}}
regions:
  wall: {zone}
phases:
  - name: park
    regulate: {{target: {{x: {x}, y: {y}, theta: {target_heading}}}}}
    constraints: [{{stay_outside: wall}}]
    until: {{settled: {{position: 0.03, heading: 0.03}}}}
    timeout: 40
"""

ZONES = [
    "{type: box, min: [-1.6, -0.8], max: [-1.3, 0.6]}",
    "{type: box, center: [-1.5, 0.1], size: [0.5, 1.2], heading: 0.5}",
    "{type: polygon, vertices: [[-1.2, -0.5], [-1.8, -0.7], [-2.0, 0.2], [-1.4, 0.6]]}",
]


def main() -> None:
    outcomes: Counter[str] = Counter()
    for heading, acceleration, zone, (x, y), target_heading, dt in itertools.product(
        [0.0, 2.5],
        ["", ", acceleration: {v: 1.0, omega: 3.0}"],
        ZONES,
        [(-3.0, 0.0), (-3.0, 0.8), (-2.6, -0.4)],
        [0.0, 1.57],
        [0.01, 0.04],
    ):
        text = MISSION.format(
            dt=dt,
            heading=heading,
            acceleration=acceleration,
            zone=zone,
            x=x,
            y=y,
            target_heading=target_heading,
        )
        outcomes[run_mission(mission_from_text(text)).outcome.value] += 1
    print(", ".join(f"{outcome} {count}" for outcome, count in sorted(outcomes.items())))


if __name__ == "__main__":
    main()
