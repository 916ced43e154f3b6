"""References that change on-line: a phase's `updates` (docs/mission-format.md,
"References that change on-line"; docs/paper-notes.md, section III.C)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from wmr_mission.api import load_mission, load_run, mission_from_text, run_mission
from wmr_mission.cli import app
from wmr_mission.output.result import RunResult

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
REPLANNED = MISSIONS / "replanned-patrol.yaml"


@pytest.fixture(scope="module")
def replanned(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("replanned") / "run"
    result = CliRunner().invoke(app, ["run", str(REPLANNED), "--out", str(out), "--no-plots"])
    assert result.exit_code == 0, result.stdout + result.stderr
    return out


def _updates(out: Path) -> list[dict[str, object]]:
    transitions = json.loads((out / "transitions.json").read_text())
    return [t for t in transitions if t["condition"] == "update"]


def test_the_replanned_patrol_succeeds_and_records_each_update(replanned: Path) -> None:
    summary = json.loads((replanned / "summary.json").read_text())
    assert summary["outcome"] == "success"
    updates = _updates(replanned)
    assert [(u["from"], u["to"], u["value"]) for u in updates] == [
        ("patrol", "patrol", 1.0),
        ("patrol", "patrol", 2.0),
    ]
    assert updates[0]["time"] == 25.0  # when: {elapsed: 25}
    assert 40.0 < float(updates[1]["time"]) < 60.0  # when: {travelled: 52.5}
    assert "travelled 52.5 m" in str(updates[1]["why"])
    run = load_run(replanned)
    assert run.reference is not None
    # the reference in force: 0 (the phase's own), 1, 2, then the dock's own
    changes = np.flatnonzero(np.diff(run.reference)) + 1
    assert run.reference[changes].tolist() == [1, 2, 0]
    assert run.t[changes[:2]].tolist() == [u["time"] for u in updates]


def test_inputs_stay_smooth_at_each_update(replanned: Path) -> None:
    """The acceptance's bound is turn_rate_jump_max (auto: limits.omega, 3 rad/s);
    the re-planned routes keep the leg the robot is on, and the jump at either
    change is below 0.1 rad/s and 0.25 m/s (0.025 and 0.062 rad/s, 0.015 and
    0.20 m/s measured: docs/mission-format.md)."""
    run = load_run(replanned)
    summary = json.loads((replanned / "summary.json").read_text())
    jumps = [e for e in summary["expectations"] if e["phase"] == "patrol" and "jump" in e["metric"]]
    assert {e["metric"] for e in jumps} == {"speed_jump_max", "turn_rate_jump_max"}
    assert all(e["met"] for e in jumps)
    for update in _updates(replanned):
        k = round(float(update["time"]) / run.dt)  # type: ignore[arg-type]
        around = slice(k - 1, k + 2)  # the steps into and out of the update's sample
        omega_jump = float(np.abs(np.diff(run.omega[around])).max())
        speed_jump = float(np.abs(np.diff(run.v[around])).max())
        assert omega_jump < 0.1, (update, omega_jump)
        assert speed_jump < 0.25, (update, speed_jump)


def test_a_mission_without_updates_has_no_reference_column(tmp_path: Path) -> None:
    mission = load_mission(MISSIONS / "park.yaml")
    result = run_mission(mission)
    assert result.reference is None
    result.write(tmp_path / "run", plots=False)
    header = (tmp_path / "run" / "trajectory.csv").read_text().split("\n", 1)[0]
    assert header.endswith(",phase2_iterations")


UPDATED = """
version: 1
name: updated
robot:
  dt: 0.01
  limits: {v: 2, omega: 3}
regions:
  gate: {type: circle, center: [2, 0], radius: 0.3}
phases:
  - name: east
    track:
      path: {type: line, heading: 0, speed: 1}
    updates:
      - when: {reaches: gate}
        path: {type: line, heading: 0.3, speed: 1}
    until: {elapsed: 4}
  - name: park
    regulate: {target: {x: 3, y: 1, theta: 0}}
    updates:
      - when: {elapsed: 2}
        target: {x: 3.5, y: 0.5, theta: 0}
    until: {settled: {position: 0.02, heading: 0.05}}
    timeout: 30
"""


def _updated() -> RunResult:
    return run_mission(mission_from_text(UPDATED))


def test_a_region_update_restarts_the_path_from_the_estimate() -> None:
    result = _updated()
    update = next(t for t in result.transitions if t.condition == "update")
    k = round(update.time / result.dt)
    # the first sample whose estimate is inside the gate, and not before
    inside = np.hypot(result.x_est - 2.0, result.y_est) <= 0.3
    assert k == int(np.argmax(inside))
    # the new line starts at the estimated pose there, and heads 0.3 rad
    assert result.x_ref[k] == pytest.approx(result.x_est[k], abs=1e-12)
    assert result.y_ref[k] == pytest.approx(result.y_est[k], abs=1e-12)
    assert result.reference is not None
    assert result.reference[k - 1] == 0
    assert result.reference[k] == 1
    heading = np.arctan2(
        result.y_ref[k + 10] - result.y_ref[k], result.x_ref[k + 10] - result.x_ref[k]
    )
    assert heading == pytest.approx(0.3, abs=1e-9)


def test_a_target_update_moves_the_regulated_target() -> None:
    result = _updated()
    assert result.transitions[-1].condition == "settled", result.message
    park = result.phase_names.index("park")
    end = np.flatnonzero(result.phase == park)[-1]
    # the robot parks at the updated target, not the phase's own
    assert np.hypot(result.x[end] - 3.5, result.y[end] - 0.5) < 0.03
    assert result.phases[park].target == (3.5, 0.5, 0.0)


SWITCH = """
version: 1
name: switch
robot:
  dt: 0.01
  limits: {{v: 2, omega: 3{acceleration}}}
phases:
  - name: go
    track:
      path: {{type: line, heading: 0, speed: 1}}
    updates:
      - when: {{elapsed: 3}}
        path: {{type: line, heading: {heading}, speed: {speed}}}
    until: {{elapsed: 6}}
"""


def _jumps(heading: float, speed: float = 1.0, acceleration: str = "") -> tuple[float, float]:
    """The largest one-sample change of omega and v from the update (t = 3 s) on."""
    text = SWITCH.format(heading=heading, speed=speed, acceleration=acceleration)
    result = run_mission(mission_from_text(text))
    after = slice(299, None)
    return float(np.abs(np.diff(result.omega[after])).max()), float(
        np.abs(np.diff(result.v[after])).max()
    )


@pytest.mark.parametrize("mismatch", [0.02, 0.05, 0.1])
def test_the_turn_rate_step_at_a_switch_is_the_laws_transient(mismatch: float) -> None:
    """A new line from the estimated pose, turned by ``mismatch`` from the robot's
    heading: the default law (look-ahead l = 0.05 m, time constant 0.1 s) steps
    the turn rate by mismatch (v dt + (1 - exp(-dt / tau)) l) / ((l + v dt / 2) dt),
    26.8 rad/s per radian at 1 m/s (docs/paper-notes.md, "References that change
    on-line")."""
    dt, look_ahead, tau, v = 0.01, 0.05, 0.1, 1.0
    gain = (v * dt + (1.0 - np.exp(-dt / tau)) * look_ahead) / ((look_ahead + v * dt / 2) * dt)
    omega_jump, speed_jump = _jumps(mismatch)
    assert omega_jump == pytest.approx(gain * mismatch, rel=0.02)
    assert speed_jump < 0.01


def test_acceleration_limits_bound_the_step_at_any_switch() -> None:
    limits = ", acceleration: {v: 2, omega: 6}"
    for heading, speed in ((0.5, 1.0), (1.0, 1.0), (0.0, 1.5)):
        omega_jump, speed_jump = _jumps(heading, speed, limits)
        assert omega_jump <= 6 * 0.01 + 1e-9
        assert speed_jump <= 2 * 0.01 + 1e-9
    # without them a new speed is taken at once, and a turn of 0.5 rad kicks
    # the turn rate to its limit
    assert _jumps(0.0, 1.5)[1] == pytest.approx(0.5)
    assert _jumps(0.5)[0] == pytest.approx(3.0)


# rclpy's type support imports lark, which imports the deprecated sre_parse and sre_constants.
@pytest.mark.filterwarnings(
    "ignore:module 'sre_(parse|constants)' is deprecated:DeprecationWarning"
)
def test_the_mcap_export_sends_a_path_for_each_reference(replanned: Path, tmp_path: Path) -> None:
    """ROS 2 tools see the reference in force: a nav_msgs/Path at each update,
    holding the new reference's points from then on."""
    pytest.importorskip("rclpy.serialization", reason="the ros2 extra")
    from test_export_ros2 import _read

    from wmr_mission.review.export import export_command

    out = tmp_path / "run.mcap"
    assert export_command(replanned, "mcap", out) == 0
    topics, _ = _read(out)
    run = load_run(replanned)
    assert run.reference is not None
    patrol = run.phase == run.phase_names.index("patrol")
    starts = [0, *(np.flatnonzero(np.diff(run.reference) != 0) + 1)]
    starts = [k for k in starts if patrol[k]]  # the dock has no path
    paths = topics["/reference"]
    assert [t for t, _ in paths] == [round(run.t[k] * 1e9) for k in starts]
    assert len(starts) == 3
    for (_, path), start in zip(paths, starts, strict=True):
        first = path.poses[0].pose.position
        assert (first.x, first.y) == (run.x_ref[start], run.y_ref[start])


@pytest.mark.parametrize("offset", [0.002, 0.01])
def test_the_turn_rate_step_for_a_path_beside_the_robot(offset: float) -> None:
    """A new line parallel to the robot's, ``offset`` to its side: the step is
    offset (1 - exp(-dt / tau)) / ((l + v dt / 2) dt), 173 rad/s per metre
    (docs/paper-notes.md, "References that change on-line")."""
    dt, look_ahead, tau, v = 0.01, 0.05, 0.1, 1.0
    text = SWITCH.replace("heading: {heading}", "start: [3.0, {heading}], heading: 0")
    # the robot is at (3, 0) at t = 3 s, on its first line (noise-free)
    result = run_mission(mission_from_text(text.format(heading=offset, speed=1, acceleration="")))
    assert (result.x_est[300], result.y_est[300]) == (3.0, 0.0)
    jump = float(np.abs(np.diff(result.omega[299:])).max())
    gain = (1.0 - np.exp(-dt / tau)) / ((look_ahead + v * dt / 2) * dt)
    assert jump == pytest.approx(gain * offset, rel=1e-6)


LAPS = """
version: 1
name: laps
robot:
  dt: 0.01
  limits: {v: 2, omega: 3}
phases:
  - name: rounds
    repeat:
      times: 3
      phases:
        - name: out
          track:
            path: {type: line, heading: 0, speed: 1}
          updates:
            - when: {lap: 2}
              path: {type: line, heading: 0.5, speed: 1}
          until: {elapsed: 1}
        - name: back
          regulate: {target: {x: 0, y: 0, theta: 0}}
          until: {elapsed: 3}
"""


def test_a_lap_update_takes_over_at_the_entry_of_that_lap_and_each_later_one() -> None:
    result = run_mission(mission_from_text(LAPS))
    updates = [t for t in result.transitions if t.condition == "update"]
    entries = {t.to_phase: t.time for t in result.transitions if t.condition != "update"}
    # lap 1 keeps the phase's own line; laps 2 and 3 take the update at their first sample
    assert [(u.from_phase, u.time) for u in updates] == [
        ("out#2", entries["out#2"]),
        ("out#3", entries["out#3"]),
    ]
    assert [u.lap for u in updates] == [2, 3]  # into a phase of a repeat: its lap
    assert "lap 2" in str(updates[0].why)
    assert result.reference is not None
    for lap in (1, 2, 3):
        rows = result.phase == result.phase_names.index(f"out#{lap}")
        assert set(result.reference[rows].tolist()) == ({0} if lap == 1 else {1})
        k = int(np.flatnonzero(rows)[0])
        heading = np.arctan2(
            result.y_ref[k + 50] - result.y_ref[k], result.x_ref[k + 50] - result.x_ref[k]
        )
        assert heading == pytest.approx(0.0 if lap == 1 else 0.5, abs=1e-9)


PACED = """
version: 1
name: paced
robot:
  dt: 0.01
  limits: {{v: 2, omega: 3}}
{controller}
phases:
  - name: go
    track:
      path: {path}
    updates:
      - when: {{elapsed: {at}}}
        {change}
    until: {{elapsed: 4}}
"""


def _paced(path: str, change: str, controller: str = "", at: float = 2.0) -> tuple[RunResult, int]:
    text = PACED.format(path=path, change=change, controller=controller, at=at)
    result = run_mission(mission_from_text(text))
    update = next(t for t in result.transitions if t.condition == "update")
    return result, round(update.time / result.dt)


def test_a_speed_update_runs_the_same_line_on_at_the_new_speed() -> None:
    result, k = _paced("{type: line, heading: 0.4, speed: 1}", "speed: 0.5")
    assert k == 200
    assert result.reference is not None
    assert result.reference[k - 1] == 0
    assert result.reference[k] == 1
    step = np.hypot(np.diff(result.x_ref), np.diff(result.y_ref)) / result.dt
    # 1 m/s up to the update, 0.5 m/s after it, from the reference point in force
    assert step[: k - 1] == pytest.approx(1.0, abs=1e-9)
    assert step[k:-1] == pytest.approx(0.5, abs=1e-9)  # the last sample has no reference
    assert (
        np.hypot(result.x_ref[k] - result.x_ref[k - 1], result.y_ref[k] - result.y_ref[k - 1])
        < 0.011
    )
    # on the same line: every reference point at heading 0.4 from the first
    heading = np.arctan2(result.y_ref[1:-1] - result.y_ref[0], result.x_ref[1:-1] - result.x_ref[0])
    assert heading == pytest.approx(0.4, abs=1e-9)
    assert "speed 0.5" in str(next(t.why for t in result.transitions if t.condition == "update"))


def test_a_speed_update_of_a_circle_sets_its_angular_rate_on_the_same_circle() -> None:
    path = "{type: circle, center: [0, 1], radius: 1, angular_rate: 0.5}"
    result, k = _paced(path, "speed: 1.0")
    radius = np.hypot(result.x_ref[:-1], result.y_ref[:-1] - 1.0)
    assert radius == pytest.approx(1.0, abs=1e-9)
    angle = np.unwrap(np.arctan2(result.y_ref - 1.0, result.x_ref))
    rate = np.diff(angle) / result.dt
    assert rate[: k - 1] == pytest.approx(0.5, abs=1e-6)
    assert rate[k:-1] == pytest.approx(1.0, abs=1e-6)


def test_a_look_ahead_update_changes_the_law_from_the_update_on() -> None:
    line = "{type: line, heading: 0, speed: 1, start: [0, 1]}"
    controller = "controller: {tracking: {look_ahead: 0.1, time_constant: 0.5}}"
    before, k = _paced(line, "look_ahead: 0.1", controller, at=0.1)  # the same look-ahead
    after, _ = _paced(line, "look_ahead: 0.6", controller, at=0.1)
    # the same run up to the update, then the longer look-ahead turns towards
    # the line 1 m to the left more gently
    assert k == 10
    assert np.array_equal(before.omega[:k], after.omega[:k])
    assert before.omega[k] > 0.0
    assert 0.0 < after.omega[k] < 0.8 * before.omega[k]
    assert "a new look-ahead" in str(
        next(t.why for t in after.transitions if t.condition == "update")
    )


@pytest.mark.parametrize(
    ("change", "speed_step"),
    [("speed: 0.5", 0.5), ("speed: 1.5", 0.5), ("look_ahead: 0.3", 0.0), ("look_ahead: 0.02", 0.0)],
)
def test_a_speed_or_look_ahead_update_on_the_path_steps_only_the_speed(
    change: str, speed_step: float
) -> None:
    """The reference point does not move at the switch: on the path, the turn
    rate does not step, and the speed steps by the change of the path's speed."""
    result, k = _paced("{type: line, heading: 0, speed: 1}", change, at=3.0)
    assert k == 300
    window = slice(k - 1, k + 50)
    assert np.abs(np.diff(result.omega[window])).max() < 1e-9
    assert np.abs(np.diff(result.v[window])).max() == pytest.approx(speed_step, abs=1e-9)
