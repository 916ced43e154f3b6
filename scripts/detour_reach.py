"""Whether a detour round gen-124-line's rock within the allowance is one its
robot can drive under its limits (docs/soundness.md, the misses).

    python scripts/detour_reach.py

The robot is on its line at the line's speed, heading along it, from where
the run has it joined (along 6.46 m, 1.8 s). Noise-free, at that speed
throughout, it turns away from the rock, holds a heading ``phi`` off the
line, turns back onto it (each turn at the turn-rate acceleration limit,
rest to rest, within the turn-rate limit), holds the offset and turns back
in after the rock. Over the start of the turn and ``phi``, the script prints
the detours that keep the rock's edge at least three noise std off (what
the controller keeps off a zone for the estimate) and stay within the
product's allowance (``detour_offset_max``: the rock's reach into the line,
three noise std, the look-ahead and the 0.1 m tolerance), and the narrowest.
"""

from __future__ import annotations

import math
from pathlib import Path

import yaml

MISSION = Path(__file__).resolve().parents[1] / "tests/data/generated/gen-124-line.yaml"
JOINED_ALONG = 6.46  # [m] where the run is on its line (trajectory.csv, t = 1.8 s)
STEP = 0.001  # [s]
TOLERANCE = 0.1  # [m]


def turn(phi: float, rate_limit: float, acceleration: float) -> list[float]:
    """The turn rates, per STEP, of a rest-to-rest turn by ``phi`` at the limits."""
    sign = math.copysign(1.0, phi)
    top = min(rate_limit, math.sqrt(abs(phi) * acceleration))
    ramp = top / acceleration
    cruise = (abs(phi) - top * ramp) / top
    rates: list[float] = []
    t = 0.0
    total = 2 * ramp + cruise
    while t < total:
        w = min(acceleration * t, top, acceleration * (total - t))
        rates.append(sign * w)
        t += STEP
    done = sum(rates) * STEP
    return [w * phi / done for w in rates] if done else rates  # exactly phi


def drive(
    start: float, phi: float, hold: float, speed: float, limits: tuple[float, float]
) -> tuple[list[float], list[float]]:
    """(along, across) of the robot: out by phi and back, the offset held ``hold`` s,
    in again (across negative: the right of travel)."""
    out = turn(-phi, *limits) + turn(phi, *limits)
    back = turn(phi, *limits) + turn(-phi, *limits)
    rates = out + [0.0] * round(hold / STEP) + back
    along, across, heading = [start], [0.0], 0.0
    for w in rates:
        heading += w * STEP
        along.append(along[-1] + speed * STEP * math.cos(heading))
        across.append(across[-1] + speed * STEP * math.sin(heading))
    return along, across


def main() -> int:
    mission = yaml.safe_load(MISSION.read_text())
    robot = mission["robot"]
    x0, y0 = robot["initial_state"]["x"], robot["initial_state"]["y"]
    path = mission["phases"][0]["track"]["path"]
    h, speed = path["heading"], path["speed"]
    rock = mission["regions"]["rock"]
    cx, cy, radius = *rock["center"], rock["radius"]
    c, s = math.cos(h), math.sin(h)
    centre_along = c * (cx - x0) + s * (cy - y0)
    centre_across = -s * (cx - x0) + c * (cy - y0)
    reach = radius - abs(centre_across)
    sigma = mission["sensors"]["noise_std"]["x"]
    look_ahead = max(0.05, robot["limits"]["v"] * robot["dt"])
    allowance = reach + 3 * sigma + look_ahead + TOLERANCE
    limits = (robot["limits"]["omega"], robot["limits"]["acceleration"]["omega"])
    print(
        f"rock: centre {centre_along:.3f} m along, {centre_across:.3f} m across; "
        f"reach {reach:.3f} m; allowed {allowance:.3f} m; speed {speed} m/s; "
        f"turn rate {limits[0]} rad/s, {limits[1]} rad/s^2"
    )
    print("| start along [m] | phi [rad] | peak off [m] | clearance [m] | turned out by [m] |")
    print("|---|---|---|---|---|")
    best = None
    for start_cm in range(round(JOINED_ALONG * 100), round(centre_along * 100), 10):
        start = start_cm / 100
        for phi_mrad in range(50, 1500, 25):
            phi = phi_mrad / 1000
            along, across = drive(start, phi, 0.0, speed, limits)
            peak = -min(across)
            k = across.index(-peak)
            hold = max(0.0, (centre_along + 1.2 - along[k]) / speed)
            along, across = drive(start, phi, hold, speed, limits)
            clearance = min(
                math.hypot(a - centre_along, b - centre_across) - radius
                for a, b in zip(along, across, strict=True)
            )
            if clearance >= 3 * sigma and peak <= allowance:
                if best is None or peak < best[2]:
                    best = (start, phi, peak, clearance, along[k])
                break  # the least phi from this start
    if best is None:
        print("none")
        return 1
    print(f"| {best[0]:.2f} | {best[1]:.3f} | {best[2]:.3f} | {best[3]:.3f} | {best[4]:.2f} |")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
