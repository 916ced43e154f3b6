"""A planner over ROS 2 (docs/backends.md, "A planner over ROS 2"): each
nav_msgs/Path on the mission's plan topic replaces the track phase's path."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from test_backends import WMR, background, needs_ros2, ros_env  # noqa: F401

from wmr_mission.api import load_run

DATA = Path(__file__).parent / "data"
PLANNED = DATA / "planned-ros2.yaml"
# Three plans, a second apart, each from where the robot will roughly be (it
# holds at the origin until the first), in frame odom.
PLANS = ("0.5,0.1;1.0,0.3", "0.8,0.2;1.2,0.0", "1.2,-0.1;1.5,-0.4")


@needs_ros2
def test_the_run_follows_each_plan_in_turn_and_keeps_the_last(
    tmp_path: Path,
    ros_env: dict[str, str],  # noqa: F811
) -> None:
    out = tmp_path / "run"
    planner = [sys.executable, str(Path(__file__).parent / "ros2_planner.py"), *PLANS]
    robot = [*WMR, "serve-robot", str(PLANNED)]
    with (
        background(robot, ros_env, "serve-robot:"),
        background(planner, ros_env, "ready") as published,
    ):
        done = subprocess.run(
            [*WMR, "run", str(PLANNED), "--backend", "ros2", "--out", str(out), "--no-plots"],
            env=ros_env, capture_output=True, text=True, timeout=90, check=False,
        )  # fmt: skip
        assert published.stdout is not None
        planner_said = published.stdout.read()
    assert done.returncode == 0, done.stderr
    assert planner_said.count("published") == 3  # and then it stopped
    summary = json.loads((out / "summary.json").read_text())
    assert summary["realtime"]["plans_taken"] == 3
    assert summary["realtime"]["plans_refused"] == 0
    run = load_run(out)
    assert run.reference is not None
    # no plan yet: from the first sample the robot holds where it is (reference 1)
    assert run.reference[0] == 1
    changes = np.flatnonzero(np.diff(run.reference)) + 1
    assert run.reference[changes].tolist() == [2, 3, 4]
    held = slice(0, changes[0])
    assert np.ptp(run.x_ref[held]) == 0
    assert np.ptp(run.y_ref[held]) == 0
    assert np.abs(run.v[held]).max() < 1e-9
    assert np.abs(run.omega[held]).max() < 1e-9
    assert run.reference[-1] == 4  # the planner stopped: its last plan stays in force
    ends = [*changes[1:], run.samples]
    for number, (start, end) in enumerate(zip(changes, ends, strict=True), 1):
        goal = np.array([float(v) for v in PLANS[number - 1].split(";")[-1].split(",")])
        # the new reference starts at the estimate and runs towards the plan's last point
        assert (
            np.hypot(run.x_ref[start] - run.x_est[start], run.y_ref[start] - run.y_est[start])
            < 1e-9
        )
        before = np.hypot(*(np.array([run.x_ref[start], run.y_ref[start]]) - goal))
        after = np.hypot(*(np.array([run.x_ref[end - 2], run.y_ref[end - 2]]) - goal))
        assert after < before, (number, before, after)
    transitions = json.loads((out / "transitions.json").read_text())
    whys = [t["why"] for t in transitions if t["condition"] == "update"]
    assert len(whys) == 4
    assert "no plan yet" in whys[0]
    assert all("plan on 'plan'" in why for why in whys[1:])
    assert "ros2: plans from 'plan'" in done.stderr
    assert "ros2: no plan yet on 'plan': holding the estimated pose" in done.stderr


@needs_ros2
def test_serve_robot_plan_from_publishes_a_mission_s_updates_as_plans(
    tmp_path: Path,
    ros_env: dict[str, str],  # noqa: F811
) -> None:
    out = tmp_path / "run"
    robot = [*WMR, "serve-robot", str(PLANNED), "--plan-from", str(DATA / "plans-ros2.yaml")]
    with background(robot, ros_env, "serve-robot: 3 plans scripted on 'plan', at 1, 2.5, 4 s"):
        done = subprocess.run(
            [*WMR, "run", str(PLANNED), "--backend", "ros2", "--out", str(out), "--no-plots"],
            env=ros_env, capture_output=True, text=True, timeout=90, check=False,
        )  # fmt: skip
    assert done.returncode == 0, done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["realtime"]["plans_taken"] == 3
    run = load_run(out)
    assert run.reference is not None
    changes = np.flatnonzero(np.diff(run.reference)) + 1
    assert run.reference[changes].tolist() == [2, 3, 4]  # 1: no plan yet, holding
    ends = [*changes[1:], run.samples]
    for heading, start, end in zip((0.4, -0.3, 0.0), changes, ends, strict=True):
        # each plan is a line from the robot's pose when it was sent: the new
        # reference runs along it
        late = start + (end - start) // 2
        direction = np.arctan2(
            run.y_ref[late] - run.y_ref[start], run.x_ref[late] - run.x_ref[start]
        )
        assert abs(direction - heading) < 0.2, (heading, direction)


@needs_ros2
def test_a_goal_pose_becomes_a_track_phase_s_route_and_a_regulate_phase_s_target(
    tmp_path: Path,
    ros_env: dict[str, str],  # noqa: F811
) -> None:
    out = tmp_path / "run"
    mission = DATA / "goals-ros2.yaml"
    # one goal while 'go' tracks (its 100th command heard, t ~ 1 s), one while
    # 'park' regulates (its 400th, t ~ 4 s): counted in the run's commands, so
    # that a run late on the wall clock is in 'park' by the second
    planner = [
        sys.executable, str(Path(__file__).parent / "ros2_goals.py"),
        "0.8,0.6,0.5@100", "0.6,-0.4,-1.0@400",
    ]  # fmt: skip
    robot = [*WMR, "serve-robot", str(mission)]
    with background(robot, ros_env, "serve-robot:"), background(planner, ros_env, "ready"):
        done = subprocess.run(
            [*WMR, "run", str(mission), "--backend", "ros2", "--out", str(out), "--no-plots"],
            env=ros_env, capture_output=True, text=True, timeout=90, check=False,
        )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "ros2: goals from 'goal'" in done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["realtime"]["plans_taken"] == 2
    transitions = json.loads((out / "transitions.json").read_text())
    updates = [t for t in transitions if t["condition"] == "update"]
    assert [u["from"] for u in updates] == ["go", "go", "park"]
    assert "no plan yet" in updates[0]["why"]  # 'go' holds until the first goal
    assert "a new path" in updates[1]["why"]
    assert "a new target" in updates[2]["why"]
    run = load_run(out)
    go = run.phase == run.phase_names.index("go")
    start = int(np.flatnonzero(np.diff(run.reference) != 0)[0]) + 1
    assert go[start]
    # the track phase's route starts at the estimate and runs towards the goal
    assert abs(run.x_ref[start] - run.x_est[start]) < 1e-9
    end = int(np.flatnonzero(go)[-1])
    assert np.hypot(run.x_ref[end] - 0.8, run.y_ref[end] - 0.6) < np.hypot(
        run.x_ref[start] - 0.8, run.y_ref[start] - 0.6
    )
    # the regulate phase drives to the second goal, not its own target
    park = run.phases[run.phase_names.index("park")]
    assert park.target == (0.6, -0.4, -1.0)
    assert np.hypot(run.x[-1] - 0.6, run.y[-1] + 0.4) < 0.15


def _quiet_mission(tmp_path: Path, on_plan_stale: str) -> Path:
    """The planner test's mission, its planner counted quiet after 1.5 s, and
    8 s long: a plan late by the planner's discovery of the run (up to 3 s,
    docs/backends.md) still leaves a second and a half of holding."""
    text = (
        PLANNED.read_text()
        .replace(
            "plan_speed: 0.4}",
            f"plan_speed: 0.4, plan_stale_after: 1.5, on_plan_stale: {on_plan_stale}}}",
        )
        .replace("until: {elapsed: 6}", "until: {elapsed: 8}")
    )
    assert "on_plan_stale" in text
    assert "elapsed: 8" in text
    mission = tmp_path / f"quiet-{on_plan_stale}.yaml"
    mission.write_text(text)
    return mission


@needs_ros2
def test_a_quiet_planner_with_on_plan_stale_hold_leaves_the_robot_holding(
    tmp_path: Path,
    ros_env: dict[str, str],  # noqa: F811
) -> None:
    out = tmp_path / "run"
    mission = _quiet_mission(tmp_path, "hold")
    planner = [sys.executable, str(Path(__file__).parent / "ros2_planner.py"), PLANS[0]]
    robot = [*WMR, "serve-robot", str(mission)]
    with background(robot, ros_env, "serve-robot:"), background(planner, ros_env, "ready"):
        done = subprocess.run(
            [*WMR, "run", str(mission), "--backend", "ros2", "--out", str(out), "--no-plots"],
            env=ros_env, capture_output=True, text=True, timeout=90, check=False,
        )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert "for 1.5 s: holding the estimated pose" in done.stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["realtime"]["plans_taken"] == 1
    transitions = json.loads((out / "transitions.json").read_text())
    updates = [t for t in transitions if t["condition"] == "update"]
    assert "no plan yet" in updates[0]["why"]
    # The planner sends its plan a second after it hears the first command;
    # on a loaded machine it may hear it late, and be quiet once before it
    # (1.5 s of the run's time from its start): then it is counted twice.
    quiet = [u for u in updates if "planner quiet for 1.5 s" in u["why"]]
    assert summary["realtime"]["plans_stale"] == len(quiet) in (1, 2)
    plan = next(u for u in updates if "plan on 'plan'" in u["why"])
    assert updates[-1] is quiet[-1]  # after the plan, quiet: held
    assert updates.index(quiet[-1]) == updates.index(plan) + 1
    assert "hold the estimated pose" in quiet[-1]["why"]
    run = load_run(out)
    assert run.reference is not None
    held = int(np.flatnonzero(run.reference == quiet[-1]["value"])[0])
    # 1.5 s after the plan (taken ~1 s in) the reference rests at the estimate
    # there: 1.5 s of the run's time, whatever the machine's load
    plan_taken = int(np.flatnonzero(run.reference == plan["value"])[0])
    assert (held - plan_taken) * run.dt == pytest.approx(1.5, abs=1e-9)
    assert run.x_ref[held:-1] == pytest.approx(run.x_est[held], abs=1e-12)
    assert run.y_ref[held:-1] == pytest.approx(run.y_est[held], abs=1e-12)
    # and the robot stopped within a second of the hold, and stays stopped
    # (1e-5 m/s and less with both cores loaded five times over), timed from
    # the hold: the last samples alone were the hold's first where the plan
    # came late
    second = round(1.0 / run.dt)
    assert run.samples - held > second + 50
    assert np.abs(run.v[held + second :]).max() < 0.05


@needs_ros2
def test_a_quiet_planner_with_on_plan_stale_fail_fails_the_run(
    tmp_path: Path,
    ros_env: dict[str, str],  # noqa: F811
) -> None:
    out = tmp_path / "run"
    mission = _quiet_mission(tmp_path, "fail")
    robot = [*WMR, "serve-robot", str(mission)]
    with background(robot, ros_env, "serve-robot:"):  # and no planner at all
        done = subprocess.run(
            [*WMR, "run", str(mission), "--backend", "ros2", "--out", str(out), "--no-plots"],
            env=ros_env, capture_output=True, text=True, timeout=90, check=False,
        )  # fmt: skip
    assert done.returncode != 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "failed"
    assert "the planner went quiet: no plan or goal on 'plan' for 1.5 s" in summary["message"]
    run = load_run(out)
    assert run.t[-1] == pytest.approx(1.5, abs=0.011)  # not the phase's 8 s
