"""How far behind its line each generated dash that failed driving forwards
ends, at best, for a robot that turns round first and for one that drives
backwards (docs/soundness.md, the misses; docs/paper-notes.md, "Eq. (27)
driving backwards").

    python scripts/dash_reach.py

Each dash is a line from the robot's start at a heading 2.7-3.2 rad off the
robot's, for 1-2 s. The robot, noise-free and from rest, turns its
direction of travel onto the line's as fast as its turn-rate limit and
acceleration allow (the turn stopped in time), and speeds up along it at its
speed acceleration once within 0.5 rad of it (forwards; backwards from the
start). Prints where it ends: metres along the line, off it, and behind the
reference, beside the tolerances of scripts/soundness.py (cross-track
0.1 m + sigma_p, lag 0.1 m + sigma_p + 3 tau v_ref, tau 0.1 s).
"""

from __future__ import annotations

import math
from pathlib import Path

import yaml

GENERATED = Path(__file__).resolve().parents[1] / "tests" / "data" / "generated"
DASHES = ("gen-098-dash", "gen-120-dash", "gen-129-dash")


def reach(mission: dict, backwards: bool) -> tuple[float, float, float]:
    """(along, across, behind) at the dash's end [m]."""
    robot = mission["robot"]
    limits = robot["limits"]
    dt = float(robot["dt"])
    v_max, w_max = float(limits["v"]), float(limits["omega"])
    a_v, a_w = float(limits["acceleration"]["v"]), float(limits["acceleration"]["omega"])
    dash = mission["phases"][0]
    path = dash["track"]["path"]
    heading, speed = float(path["heading"]), float(path["speed"])
    duration = float(dash["until"]["elapsed"])
    theta = float(robot["initial_state"]["theta"])
    x = y = v = w = 0.0
    for _ in range(round(duration / dt)):
        travel = theta + (math.pi if backwards else 0.0)
        error = math.atan2(math.sin(heading - travel), math.cos(heading - travel))
        wanted = math.copysign(min(w_max, math.sqrt(2.0 * a_w * abs(error))), error)
        w = min(max(wanted, w - a_w * dt), w + a_w * dt)
        if backwards or abs(error) < 0.5:
            top = -v_max if backwards else v_max
            v = min(max(top, v - a_v * dt), v + a_v * dt)
        x += v * dt * math.cos(theta)
        y += v * dt * math.sin(theta)
        theta += w * dt
    c, s = math.cos(heading), math.sin(heading)
    along = x * c + y * s
    return along, abs(-x * s + y * c), speed * duration - along


def main() -> int:
    print("| dash | way | along [m] | off [m] | behind [m] | allowed off, behind [m] |")
    print("|---|---|---|---|---|---|")
    for name in DASHES:
        mission = yaml.safe_load((GENERATED / f"{name}.yaml").read_text())
        noise = mission.get("sensors", {}).get("noise_std", {})
        sigma = max(float(noise.get("x", 0.0)), float(noise.get("y", 0.0)))
        speed = float(mission["phases"][0]["track"]["path"]["speed"])
        allowed = (0.1 + sigma, 0.1 + sigma + 3 * 0.1 * speed)
        for backwards in (False, True):
            along, across, behind = reach(mission, backwards)
            way = "backwards" if backwards else "turned round"
            print(
                f"| {name} | {way} | {along:.3f} | {across:.3f} | {behind:.3f} "
                f"| {allowed[0]:.3f}, {allowed[1]:.3f} |"
            )
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
