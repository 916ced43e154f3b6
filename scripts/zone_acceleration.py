"""Lines through a keep-out circle under acceleration limits: how deep the
true robot goes into the zone, and where it ends (docs/paper-notes.md,
"Acceleration limits").

    python scripts/zone_acceleration.py
"""

from __future__ import annotations

import numpy as np

from wmr_mission import mission_from_dict, run_mission

CASES = [
    (speed, acceleration, centre_y)
    for speed, acceleration in (
        (1.0, {"v": 1.0, "omega": 3.0}),
        (2.0, {"v": 1.0, "omega": 3.0}),
        (3.0, {"v": 1.5, "omega": 4.0}),
        (2.0, {"v": 0.5, "omega": 2.0}),
    )
    for centre_y in (0.0, 0.3)
]


def line(speed: float, acceleration: dict[str, float], centre_y: float) -> dict:
    return {
        "version": 1,
        "name": "line",
        "robot": {
            "dt": 0.01,
            "initial_state": {"x": 0, "y": 0, "theta": 0},
            "limits": {"v": 4, "omega": 4, "acceleration": acceleration},
        },
        "regions": {"rock": {"type": "circle", "center": [5, centre_y], "radius": 1}},
        "phases": [
            {
                "name": "go",
                "track": {"path": {"type": "line", "start": [0, 0], "heading": 0, "speed": speed}},
                "constraints": [{"stay_outside": "rock"}],
                "until": {"elapsed": 14},
            }
        ],
    }


def main() -> None:
    print(
        "| speed [m/s] | acceleration [m/s^2, rad/s^2] | centre y [m] | into it [m] | x at 14 s |"
    )
    print("|---|---|---|---|---|")
    for speed, acceleration, centre_y in CASES:
        result = run_mission(mission_from_dict(line(speed, acceleration, centre_y)))
        depth = 1.0 - np.hypot(result.x - 5.0, result.y - centre_y).min()
        print(
            f"| {speed:g} | {acceleration['v']:g}, {acceleration['omega']:g} | {centre_y:g} | "
            f"{max(depth, 0.0):.3f} | {result.x[-1]:.2f} |"
        )


if __name__ == "__main__":
    main()
