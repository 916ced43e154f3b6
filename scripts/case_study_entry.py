"""Case study 1's first phase measured: how far the robot is from the spiral
of eq. (30) while it joins it, and the speed it uses against its limit.

    python scripts/case_study_entry.py            # the table of docs/case-studies.md

Runs missions/case1.yaml through the API and prints, every 0.1 s of the
`spiral-out` phase, the true robot's distance from the spiral (the polyline of
the phase's reference points), its distance from the sample's reference point,
its speed and turn rate; then the largest speed and turn rate against the
limits, and the most the law closes of a large error per sample across the
robot's heading (eq. (27)'s error closed at most HEADING_STEP look-aheads a
sample across it, along it up to what the speed limit leaves:
docs/paper-notes.md).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from wmr_mission import load_mission, run_mission
from wmr_mission.controllers.paper import HEADING_STEP
from wmr_mission.verdicts.metrics import distance_to_path

ROOT = Path(__file__).resolve().parent.parent


def main() -> None:
    mission = load_mission(ROOT / "missions" / "case1.yaml")
    result = run_mission(mission)
    phase = np.asarray(result.phase)
    spiral = np.flatnonzero(phase == 0)
    end = int(spiral[-1]) + 1
    x, y = result.x[:end], result.y[:end]
    x_ref, y_ref = result.x_ref[:end], result.y_ref[:end]
    off = distance_to_path(x, y, x_ref, y_ref)
    behind = np.hypot(x - x_ref, y - y_ref)
    t = result.t[:end]
    limits = mission.robot.limits
    dt = mission.robot.dt
    look_ahead = max(0.05, limits.v * dt)
    reference_speed = np.hypot(np.diff(x_ref), np.diff(y_ref)) / dt
    print(f"spiral-out: t = 0 to {result.t[end]:.2f} s (the ellipse reached)")
    print("| t [s] | off the spiral [m] | from the reference point [m] | v [m/s] | omega [rad/s] |")
    print("|---|---|---|---|---|")
    for k in [*range(0, end, round(0.1 / dt)), end - 1]:
        print(
            f"| {t[k]:.2f} | {off[k]:.3f} | {behind[k]:.3f} | {result.v[k]:.2f} | "
            f"{result.omega[k]:.2f} |"
        )
    joined = np.flatnonzero(off > 0.1)
    print(f"within 0.1 m of the spiral from t = {t[int(joined[-1]) + 1]:.2f} s")
    print(f"largest |v| {np.abs(result.v[:end]).max():.2f} m/s (limit {limits.v:g})")
    print(f"largest |omega| {np.abs(result.omega[:end]).max():.2f} rad/s (limit {limits.omega:g})")
    print(
        f"reference speed {reference_speed.min():.2f} to {reference_speed.max():.2f} m/s; "
        f"a large error closed at most {HEADING_STEP * look_ahead / dt:.2f} m/s faster "
        "across the heading, along it up to the speed limit"
    )


if __name__ == "__main__":
    main()
