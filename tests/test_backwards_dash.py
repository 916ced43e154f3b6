"""A track phase whose path starts behind the robot, too short for it to turn
round and join driving forwards, driven backwards (controllers/paper.py,
``drives_backwards`` and ``mirrored``; docs/paper-notes.md,
"Eq. (27) driving backwards")."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from wmr_mission.controllers.paper import drives_backwards

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from judge_generated import GENERATED, judge_all  # noqa: E402
from soundness import read_trajectory  # noqa: E402

# The three generated dashes a robot turned round ends behind their reference
# (python scripts/dash_reach.py).
DASHES = ("gen-098-dash", "gen-120-dash", "gen-129-dash")


@pytest.mark.slow
def test_a_dash_that_starts_behind_the_robot_is_driven_backwards(tmp_path: Path) -> None:
    """Each failed its dash driving forwards (gen-098: along_track_lag_max,
    turned round and 0.77 m behind at the end); backwards each succeeds, and
    the independent judge finds it sound."""
    judged = judge_all([GENERATED / f"{name}.yaml" for name in DASHES], tmp_path, workers=1)
    assert [(j.mission, j.outcome, j.sound) for j in judged] == [
        (name, "success", True) for name in DASHES
    ]
    for name in DASHES:
        trajectory = read_trajectory(tmp_path / name / "trajectory.csv")
        dash = np.asarray(trajectory.phase) == "dash"
        assert np.all(np.asarray(trajectory["v"])[dash] <= 0.0), name


# gen-098-dash's numbers: heading -0.086, line 3.095 at 0.776 m/s for 1 s,
# limits 1.177 m/s, 3.339 rad/s, 1.095 m/s^2, 10.597 rad/s^2.
LIMITS = np.array([1.177, 3.339, 1.095, 10.597])
AHEAD = (math.cos(3.095), math.sin(3.095))


def test_only_a_path_behind_too_short_to_turn_round_for_is_driven_backwards() -> None:
    # time constant 0.22 s: the law's under these limits (a fifth of 1.177 / 1.095 s)
    assert drives_backwards(-0.086, *AHEAD, 0.776, 1.0, 0.215, LIMITS)
    # long enough to turn round and catch up: forwards
    assert not drives_backwards(-0.086, *AHEAD, 0.776, 4.0, 0.215, LIMITS)
    # no known end (only elapsed gives one): forwards
    assert not drives_backwards(-0.086, *AHEAD, 0.776, math.inf, 0.215, LIMITS)
    # the path less than pi/2 off the heading: forwards
    assert not drives_backwards(3.095 - 1.5, *AHEAD, 0.776, 1.0, 0.215, LIMITS)
    # a resting path (no tangent): forwards
    assert not drives_backwards(-0.086, math.nan, math.nan, 0.0, 1.0, 0.215, LIMITS)


DASH = """
version: 1
name: backing-dash
robot:
  dt: 0.01
  initial_state: {{x: 0, y: 0, theta: {theta}}}
  limits: {{v: 2, omega: 4, acceleration: {{v: 2, omega: 8}}}}
sensors: {{measure: [x, y, theta], noise_std: {{x: 0.01, y: 0.01, theta: 0.005}}, seed: 3}}
phases:
  - name: dash
    track:
      path: {{type: line, heading: 0, speed: 1.0}}
    until: {{elapsed: 1.5}}
  - name: park
    regulate: {{target: {{x: 2, y: 0.5, theta: 0}}}}
    until: {{settled: {{position: 0.02, heading: 0.05}}}}
    timeout: 20
"""


@pytest.mark.parametrize(("theta", "backwards"), [(3.0, True), (0.0, False)])
def test_the_run_s_table_says_a_phase_was_driven_backwards(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, theta: float, backwards: bool
) -> None:
    """A user's dash facing away from its line (heading 3.0, the line at 0, 1.5 s)
    is driven backwards, and the table says so in the phase's row; facing
    along it, the same dash drives forwards and the row says nothing."""
    from typer.testing import CliRunner

    from wmr_mission.cli import app

    monkeypatch.setenv("COLUMNS", "100")
    mission = tmp_path / "dash.yaml"
    mission.write_text(DASH.format(theta=theta))
    ran = CliRunner().invoke(
        app, ["run", str(mission), "--out", str(tmp_path / "run"), "--no-plots"]
    )
    assert ran.exit_code == 0, ran.output
    rows = ran.output.splitlines()
    dash = next(i for i, line in enumerate(rows) if line.startswith("dash "))
    assert ("backwards" in rows[dash + 1].split()[:1]) is backwards, ran.output
    assert "backwards" not in "".join(rows[dash + 2 :]), ran.output


def test_a_robot_that_stood_still_after_driving_forwards_was_not_driven_backwards() -> None:
    """Its speed after it stopped is -1e-10 (rounding) for most of the phase's
    samples: the table said `backwards`; its travel is forwards."""
    from types import SimpleNamespace

    import numpy as np

    from wmr_mission.output.report import _backwards

    dt = 0.01
    v = np.concatenate((np.full(300, 0.5), np.full(700, -1e-10)))  # 1.5 m, then a stand
    result = SimpleNamespace(t=np.arange(v.size) * dt, v=v, dt=dt)
    phase = {"kind": "track", "start": 0.0, "duration": v.size * dt}
    assert not _backwards(phase, result)  # type: ignore[arg-type]
    assert _backwards(phase, SimpleNamespace(t=result.t, v=-v, dt=dt))  # type: ignore[arg-type]
