"""The paper's estimator against the EKF under sensor noise, on case study 2.

For each noise level (the same std on x [m], y [m] and theta [rad]) and
estimator, case 2 (missions/case2.yaml, estimate starting at [1, 1, 0]) runs
over a few seeds; the estimation error is true - estimate. Columns:

* transient [s]: from the start until every state's error stays within
  max(0.05, 3 sigma) (in its unit);
* peak after [m]: the largest x or y error after it first got there;
* RMS x-y [m], RMS theta [rad]: from t = 5 s to the end.

Values are the worst (transient, peak) or the mean (RMS) over the seeds.

    python scripts/estimator_table.py            # the table in docs/paper-notes.md
"""

from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission_text

ROOT = Path(__file__).resolve().parents[1]
NOISE = (0.0, 0.005, 0.02, 0.05)
STEADY_FROM = 5.0  # [s]
ESTIMATORS: dict[str, dict[str, Any]] = {
    "observer, default bounds": {"type": "constrained-observer"},
    "observer, paper's +-0.05": {
        "type": "constrained-observer",
        "output_error_bounds": {state: [-0.05, 0.05] for state in ("x", "y", "theta")},
    },
    "observer, phase I only": {"type": "constrained-observer", "output_error_bounds": None},
    "EKF (defaults)": {"type": "ekf"},
}


def run(estimator: dict[str, Any], noise: float, seed: int) -> tuple[float, float, float, float]:
    data = yaml.safe_load((ROOT / "missions" / "case2.yaml").read_text())
    data["sensors"]["noise_std"] = dict.fromkeys(("x", "y", "theta"), noise)
    data["sensors"]["seed"] = seed
    data["estimator"] = {**estimator, "initial_estimate": {"x": 1, "y": 1, "theta": 0}}
    r = run_mission(load_mission_text(yaml.safe_dump(data), "case2-noise.yaml"))
    error = np.column_stack(
        [r.x - r.x_est, r.y - r.y_est, (r.theta - r.theta_est + math.pi) % (2 * math.pi) - math.pi]
    )
    band = max(0.05, 3 * noise)
    outside = np.flatnonzero(np.any(np.abs(error) > band, axis=1))
    transient = r.t[min(outside[-1] + 1, r.t.size - 1)] if outside.size else 0.0
    position = np.hypot(error[:, 0], error[:, 1])
    inside = np.flatnonzero(np.all(np.abs(error) <= band, axis=1))
    peak = float(np.abs(error[inside[0] :, :2]).max()) if inside.size else math.inf
    steady = r.t >= STEADY_FROM
    rms_xy = float(np.sqrt(np.mean(position[steady] ** 2)))
    rms_theta = float(np.sqrt(np.mean(error[steady, 2] ** 2)))
    return float(transient), peak, rms_xy, rms_theta


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--seeds", type=int, default=4)
    args = parser.parse_args(argv)
    print("| sigma | estimator | transient [s] | peak after [m] | RMS x-y [m] | RMS theta [rad] |")
    print("|---|---|---|---|---|---|")
    for noise in NOISE:
        for name, estimator in ESTIMATORS.items():
            rows = np.array(
                [run(estimator, noise, seed) for seed in range(args.seeds if noise else 1)]
            )
            print(
                f"| {noise:g} | {name} | {rows[:, 0].max():.2f} | {rows[:, 1].max():.3g} | "
                f"{rows[:, 2].mean():.2g} | {rows[:, 3].mean():.2g} |"
            )
    return 0


if __name__ == "__main__":
    sys.exit(main())
