"""Today's zone filter against the one-sample filter it replaced, on a set of
zone geometries (docs/paper-notes.md, "A smooth filter for zones").

    python scripts/zone_filters.py

A robot tracks the line y = 0 eastwards at 1 m/s (limits 2 m/s, 3 rad/s,
dt = 0.01 s, the default tracking law: look-ahead 0.05 m, time constant
0.1 s) through a keep-out zone, with an exact estimate and no margin (the
filters alone). "one-sample": the path's point moved onto the zone's edge
along the ray from its centre, then eq. (28) putting the predicted output
onto the bound in one sample. "barrier": the aim moved across the path to
the nearer side (left at the centre), its move closed at the law's pace, and
eq. (28) as the barrier c(k+1) <= (1 - dt / 0.1 s) c(k).
"""

from __future__ import annotations

import math

import numpy as np

from wmr_mission.controllers.constrained_tracking import (
    aim_round_zones,
    keep_constraints,
    keep_reference,
    ways_round,
)
from wmr_mission.controllers.paper import BARRIER_TIME, PaperController, track_input, tuning_of
from wmr_mission.geometry.regions import CircleRegion, EllipseRegion, constraint_rows
from wmr_mission.kernels.model import step
from wmr_mission.kernels.records import Plant, scratch

DT = 0.01
LIMITS = np.array([2.0, 3.0, math.inf, math.inf])
SPEED = 1.0
SECONDS = 16.0

GEOMETRIES = {
    "circle r 1, path through its centre (saddle)": (
        CircleRegion(type="circle", center=(5.0, 0.0), radius=1.0),
        0.0,
    ),
    "circle r 1, path 0.02 m off its centre": (
        CircleRegion(type="circle", center=(5.0, 0.02), radius=1.0),
        0.0,
    ),
    "circle r 1, path 0.4 m off its centre": (
        CircleRegion(type="circle", center=(5.0, 0.4), radius=1.0),
        0.0,
    ),
    "circle r 1, path 0.9 m off its centre": (
        CircleRegion(type="circle", center=(5.0, 0.9), radius=1.0),
        0.0,
    ),
    "ellipse 1.5 x 0.6 at 30 deg, through its centre": (
        EllipseRegion(
            type="ellipse", center=(5.0, 0.0), semi_axes=(1.5, 0.6), rotation=math.pi / 6
        ),
        0.0,
    ),
    "circle r 1, start inside it 0.2 m off its centre": (
        CircleRegion(type="circle", center=(5.0, -0.2), radius=1.0),
        5.0,
    ),
}


def drive(region: object, start_x: float, barrier: bool) -> dict[str, float]:
    kinds, params = constraint_rows(region, "outside")
    plant = Plant(DT, LIMITS)
    tuning = tuning_of(PaperController(), plant)
    if not barrier:
        tuning = tuning._replace(barrier_rate=1.0)
    state = np.array([start_x, 0.0, 0.0])
    u_prev = np.array([SPEED, 0.0])
    u = np.zeros(2)
    work = scratch()
    rows = []
    # the straight path's way round the zone (the loop's, decided at the phase's entry)
    ways = ways_round(np.array([start_x, start_x + SPEED * SECONDS]), np.zeros(2), kinds, params)
    for k in range(round(SECONDS / DT)):
        aim_now = np.array([start_x + SPEED * k * DT, 0.0, 1.0, 0.0])
        aim = np.array([start_x + SPEED * (k + 1) * DT, 0.0, 1.0, 0.0])
        if barrier:
            path_x, path_y = aim_now[0], aim_now[1]
            if aim_round_zones(
                aim_now, kinds, params, ways, tuning.look_ahead, 0.0, tuning.look_ahead
            ):
                aim[0] += aim_now[0] - path_x
                aim[1] += aim_now[1] - path_y
        else:
            keep_reference(aim_now, kinds, params, tuning.look_ahead)
            keep_reference(aim, kinds, params, tuning.look_ahead)
        track_input(state, u_prev, aim_now, aim, tuning, plant, work, u)
        keep_constraints(
            state, u_prev, kinds, params, tuning.look_ahead, plant, work, u, tuning.barrier_rate
        )
        rows.append((state[0], state[1], u[0], u[1]))
        state[:] = step(state[0], state[1], state[2], u[0], u[1], DT)
        u_prev[:] = u
    x, y, v, w = np.array(rows).T
    depth = np.array(
        [max(0.0, -float(region_distance(region, xi, yi))) for xi, yi in zip(x, y, strict=True)]
    )
    outside = np.flatnonzero(depth == 0.0)
    left = int(outside[0]) if outside.size else len(depth)
    end = start_x + SPEED * SECONDS
    return {
        "through": float(abs(x[-1] - end) < 0.05 and abs(y[-1]) < 0.05),
        "min_v": float(v.min()),
        "jump_v": float(np.abs(np.diff(v)).max()),
        "jump_w": float(np.abs(np.diff(w)).max()),
        "at_limit": float(
            np.mean((np.abs(v) >= LIMITS[0] - 1e-9) | (np.abs(w) >= LIMITS[1] - 1e-9))
        ),
        "intrusion": float(depth[left:].max()) if outside.size else math.inf,
        "left": left * DT,
    }


def region_distance(region: object, x: float, y: float) -> float:
    """Signed distance [m] from a zone's edge, > 0 outside (a fine polygon of its outline)."""
    from wmr_mission.geometry.regions import region_outline, region_value

    ox, oy = region_outline(region, 4000)  # type: ignore[arg-type]
    gap = float(np.min(np.hypot(ox - x, oy - y)))
    inside = float(region_value(region, x, y)) <= 0.0  # type: ignore[arg-type]
    return -gap if inside else gap


def main() -> None:
    print(
        "| geometry | filter | goes through | min v [m/s] | largest jump of v [m/s] | "
        "of omega [rad/s] | samples at a limit | deepest intrusion [m] | left after [s] |"
    )
    print("|---|---|---|---|---|---|---|---|---|")
    for name, (region, start_x) in GEOMETRIES.items():
        for label, barrier in (("one-sample", False), ("barrier", True)):
            m = drive(region, start_x, barrier)
            print(
                f"| {name} | {label} | {'yes' if m['through'] else 'no'} | {m['min_v']:.2f} | "
                f"{m['jump_v']:.2f} | {m['jump_w']:.2f} | {100 * m['at_limit']:.1f} % | "
                f"{m['intrusion']:.3f} | {m['left']:.2f} |"
            )
    print(f"\nbarrier time constant {BARRIER_TIME} s, dt {DT} s")


if __name__ == "__main__":
    main()
