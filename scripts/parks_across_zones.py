"""Parks whose straight way to the target crosses a keep-out zone, against
parks whose way is clear: how often each is not a success, and how
(docs/mission-format.md, "What `validate` checks": a park across a zone).

    python scripts/parks_across_zones.py              # 120 parks, seed 0
    python scripts/parks_across_zones.py --parks 40 --seed 3

Each park starts at the origin, at rest, and drives to a target 0.5-3 m away
at any bearing and heading, with one to three keep-out zones (circles, boxes,
turned boxes) about the way: half placed on it, half beside it. The robot is a
point or a disc of 0.1-0.4 m, at dt 0.05 or 0.01, with acceleration limits in
a third of the parks. A way "crosses" a zone where a point of the straight
segment from the start to the target is nearer a zone than the band the
controller keeps round it (the body's reach and the estimate's margin): where
`validate` notes it. A park `validate` warns of (a target within the band of
a zone, a start inside one, ...) is not drawn.
"""

from __future__ import annotations

import argparse
import math
from collections import Counter
from collections.abc import Iterator

import numpy as np

from wmr_mission import RunResult, mission_from_text, run_mission
from wmr_mission.spec.checks import check
from wmr_mission.spec.loader import MissionError

PARK = """\
version: 1
name: park-{number}
robot:
  dt: {dt}
  initial_state: {{x: 0, y: 0, theta: {heading}}}
  limits: {{v: 1.0, omega: 2.0{acceleration}}}
{footprint}regions:
{regions}
phases:
  - name: park
    regulate: {{target: {{x: {tx}, y: {ty}, theta: {ttheta}}}}}
    until: {{settled: {{position: 0.05, heading: 0.05}}}}
    timeout: 40
    constraints: [{constraints}]
"""


def _zone(rng: np.random.Generator, cx: float, cy: float) -> str:
    size = rng.uniform(0.2, 0.6)
    kind = rng.integers(3)
    if kind == 0:
        return f"{{type: circle, center: [{cx:.3f}, {cy:.3f}], radius: {size / 2:.3f}}}"
    turned = f", heading: {rng.uniform(-math.pi, math.pi):.3f}" if kind == 2 else ""
    w, h = size * rng.uniform(0.6, 1.4), size * rng.uniform(0.6, 1.4)
    return f"{{type: box, center: [{cx:.3f}, {cy:.3f}], size: [{w:.3f}, {h:.3f}]{turned}}}"


def _park(rng: np.random.Generator, number: int) -> str:
    distance, bearing = rng.uniform(0.5, 3.0), rng.uniform(-math.pi, math.pi)
    tx, ty = distance * math.cos(bearing), distance * math.sin(bearing)
    across = rng.random() < 0.5
    zones = []
    for _ in range(int(rng.integers(1, 4))):
        along = rng.uniform(0.25, 0.75)
        off = rng.uniform(-0.15, 0.15) if across else rng.choice([-1, 1]) * rng.uniform(0.5, 1.2)
        cx = along * tx - off * math.sin(bearing)
        cy = along * ty + off * math.cos(bearing)
        zones.append(_zone(rng, cx, cy))
    body = rng.choice([0.0, rng.uniform(0.1, 0.4)])
    return PARK.format(
        number=number,
        dt=rng.choice([0.05, 0.01]),
        heading=f"{rng.uniform(-math.pi, math.pi):.3f}",
        acceleration=", acceleration: {v: 1, omega: 3}" if rng.random() < 1 / 3 else "",
        footprint=f"  footprint: {{radius: {body:.3f}}}\n" if body else "",
        regions="\n".join(f"  z{i}: {zone}" for i, zone in enumerate(zones)),
        tx=f"{tx:.3f}",
        ty=f"{ty:.3f}",
        ttheta=f"{rng.uniform(-math.pi, math.pi):.3f}",
        constraints=", ".join(f"{{stay_outside: z{i}}}" for i in range(len(zones))),
    )


def parks(count: int, seed: int) -> Iterator[tuple[bool, RunResult]]:
    """``count`` parks `validate` does not warn of, run: whether it notes their
    straight way crossing a zone, and the run."""
    rng = np.random.default_rng(seed)
    drawn = 0
    while drawn < count:
        text = _park(rng, drawn)
        try:
            mission = mission_from_text(text)
        except MissionError:  # a start inside a zone: refused
            continue
        findings = check(mission)
        if any(f.severity != "note" for f in findings):  # warned of already
            continue
        drawn += 1
        yield any("plans no way round a zone" in f.message for f in findings), run_mission(mission)


def outcomes(count: int, seed: int) -> dict[bool, Counter[str]]:
    """The outcomes of :func:`parks`, by whether `validate` notes the park."""
    found: dict[bool, Counter[str]] = {True: Counter(), False: Counter()}
    for crossing, result in parks(count, seed):
        found[crossing][result.outcome.value] += 1
    return found


# Speed reversals beyond which a park shakes (the box-and-pentagon park: 1,188).
SHAKING = 20


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--parks", type=int, default=120)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    found: dict[bool, Counter[str]] = {True: Counter(), False: Counter()}
    shaking: Counter[bool] = Counter()
    for crossing, result in parks(args.parks, args.seed):
        found[crossing][result.outcome.value] += 1
        v = result.v  # a park that shakes: its speed's sign turned round again and again
        shaking[crossing] += int(np.count_nonzero(np.sign(v[1:]) * np.sign(v[:-1]) < 0)) > SHAKING
    for crossing, outcome in found.items():
        total = sum(outcome.values())
        missed = total - outcome["success"]
        way = "crosses a zone" if crossing else "is clear"
        print(
            f"straight way {way}: {missed} of {total} not a success ({dict(outcome)}); "
            f"{shaking[crossing]} with more than {SHAKING} speed reversals"
        )


if __name__ == "__main__":
    main()
