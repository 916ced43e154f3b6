"""The independent judge (scripts/soundness.py) on acceleration limits and
overshoot: a run of the product's, then the same run with its record made
to break each promise, judged from trajectory.csv alone."""

from __future__ import annotations

import csv
from pathlib import Path

import numpy as np
from soundness import judge

from wmr_mission import mission_from_dict, run_mission

PARK = {
    "version": 1,
    "name": "park",
    "robot": {
        "dt": 0.01,
        "initial_state": {"x": 0, "y": 0, "theta": 0},
        "limits": {"v": 6, "omega": 7, "acceleration": {"v": 1.2, "omega": 10}},
    },
    "phases": [
        {
            "name": "park",
            "regulate": {"target": {"x": 10, "y": 0, "theta": 0}},
            "until": {"settled": {"position": 0.02, "heading": 0.02}},
            "timeout": 60,
        }
    ],
}


def _rewrite(run_dir: Path, change: dict[str, np.ndarray]) -> None:
    path = run_dir / "trajectory.csv"
    with path.open(newline="") as stream:
        rows = list(csv.DictReader(stream))
    for key, values in change.items():
        for row, value in zip(rows, values, strict=True):
            row[key] = repr(float(value))
    with path.open("w", newline="") as stream:
        writer = csv.DictWriter(stream, fieldnames=list(rows[0]))
        writer.writeheader()
        writer.writerows(rows)


def test_the_judge_holds_a_park_to_its_target_and_its_accelerations(tmp_path: Path) -> None:
    result = run_mission(mission_from_dict(PARK))
    result.write(tmp_path / "run", plots=False)
    verdict = judge(PARK, tmp_path / "run")
    assert verdict.sound, verdict.problems
    [park] = verdict.phases
    assert park.metrics["overshoot"] < 0.02
    assert park.metrics["v_acceleration_max"] <= 1.2 * (1 + 1e-6)

    # the same run, 2.29 m past the target before it came back (as eq. (19) drove it)
    x = np.array(result.x)
    k = int(np.argmax(x > 5.0))
    x[k:] += 2.29 * np.sin(np.linspace(0.0, np.pi, x.size - k))
    _rewrite(tmp_path / "run", {"x": x})
    [park] = judge(PARK, tmp_path / "run").phases
    assert any(p.startswith("overshot: ") for p in park.problems), park.problems

    # the same run with a speed command that jumps faster than 1.2 m/s^2 allows
    result.write(tmp_path / "jump", plots=False)
    v = np.array(result.v)
    v[100:] += 0.05
    _rewrite(tmp_path / "jump", {"v": v})
    [park] = judge(PARK, tmp_path / "jump").phases
    assert any(p.startswith("v changes at 6.2") for p in park.problems), park.problems
