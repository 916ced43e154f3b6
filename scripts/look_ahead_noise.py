"""How far ahead the paper's tracking law looks against how much position noise
reaches its turn rate (docs/controllers.md, "The paper's tracking law under
position noise").

    python scripts/look_ahead_noise.py

Runs missions/patrol-detour.yaml (5 mm of position noise, 2 mrad of heading
noise, the default time constant 0.1 s) with each look-ahead, and prints per
look-ahead the worst turn-rate jitter of its track phases against the `auto`
bound, the worst cross-track error and the run's verdict.
"""

from __future__ import annotations

from wmr_mission import load_mission, run_mission
from wmr_mission.spec.numbers import mission_numbers
from wmr_mission.verdicts.metrics import auto_threshold

MISSION = "missions/patrol-detour.yaml"
LOOK_AHEADS = (None, 0.1, 0.2, 0.3, 0.5)  # None: the default, max(0.05, limits.v dt)


def main() -> None:
    print(
        "| look-ahead [m] | turn-rate jitter, worst track phase [rad/s] | auto bound [rad/s] "
        "| cross-track max [m] | outcome |"
    )
    print("|---|---|---|---|---|")
    for look_ahead in LOOK_AHEADS:
        mission = load_mission(MISSION, overrides={"controller.tracking.look_ahead": look_ahead})
        summary = run_mission(mission).summary()
        limits = (mission.robot.limits.v, mission.robot.limits.omega)
        numbers = mission_numbers(mission.model_dump(mode="json"), mission.robot.dt, limits)
        tracks = [p for p in summary["phases"] if p["kind"] == "track"]
        jitter = max(p["inputs"]["turn_rate_jitter"] for p in tracks)
        cross = max(p["tracking"]["cross_track_error_max"] for p in tracks)
        bound = auto_threshold("turn_rate_jitter", tracks[0], numbers)
        shown = "0.05 (default)" if look_ahead is None else f"{look_ahead:g}"
        print(f"| {shown} | {jitter:.3f} | {bound:.3f} | {cross:.4f} | {summary['outcome']} |")


if __name__ == "__main__":
    main()
