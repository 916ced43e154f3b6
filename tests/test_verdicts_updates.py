"""A regulate phase whose `updates` move its target is judged against the
target in force at each sample (docs/mission-format.md, "References that
change on-line"), not against its last target."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from wmr_mission.api import load_run, mission_from_text, run_mission
from wmr_mission.cli import app
from wmr_mission.verdicts.signals import run_signals

# A park to (A, 0) that an update moves to (B, 0); 1.2 m/s^2, so the robot
# cannot stop at once where the new target comes up ahead of it.
PARK = """
version: 1
name: park-update
robot:
  dt: 0.01
  initial_state: {{x: 0, y: 0, theta: 0}}
  limits: {{v: 6, omega: 7, acceleration: {{v: 1.2, omega: 10}}}}
phases:
  - name: park
    regulate: {{target: {{x: {a}, y: 0, theta: 0}}}}
    updates:
      - when: {{{when}}}
        target: {{x: {b}, y: 0, theta: 0}}
    until: {{settled: {{position: 0.02, heading: 0.02}}}}
    timeout: 60
"""


def _overshoot(summary: dict[str, object]) -> dict[str, object]:
    checks = summary["expectations"]
    assert isinstance(checks, list)
    return next(c for c in checks if c["metric"] == "overshoot_max")


def test_a_park_moved_back_overshooting_neither_target_passes(tmp_path: Path) -> None:
    """Parked near (4, 0), then sent back to (2, 0) at 3.4 s: against its last
    target from where it started, the way to (4, 0) read as 1.96 m past (2, 0)."""
    mission = mission_from_text(PARK.format(a=4, when="elapsed: 3.4", b=2))
    result = run_mission(mission)
    park = result.phases[0]
    update = int(np.flatnonzero(result.reference == 1)[0])
    assert park.targets == ((0, 4.0, 0.0, 0.0), (update, 2.0, 0.0, 0.0))
    assert result.x[:update].max() == pytest.approx(3.96, abs=0.01)  # short of 4
    # never behind 2 but by 14 um as it settles (the settled tolerance is 2 cm)
    assert result.x[update:].min() >= 2.0 - 2e-5
    summary = result.judged
    assert summary is not None
    assert summary["outcome"] == "success", summary["message"]
    check = _overshoot(summary)
    assert check["value"] == pytest.approx(1.4e-5, abs=1e-6)  # the 14 um above, not 1.96 m
    assert check["max"] == pytest.approx(0.02)
    # the figure's distance to the target is to the target in force
    goal = run_signals(result).lines["goal"]["distance to the target"]
    assert goal[update - 1] == pytest.approx(4.0 - result.x[update - 1], abs=1e-9)
    assert goal[update] == pytest.approx(result.x[update] - 2.0, abs=1e-9)
    # written to manifest.json and read back: the run directory judges the same
    written, out = tmp_path / "park.yaml", tmp_path / "run"
    written.write_text(PARK.format(a=4, when="elapsed: 3.4", b=2))
    ran = CliRunner().invoke(app, ["run", str(written), "--out", str(out), "--no-plots"])
    assert ran.exit_code == 0, ran.stdout + ran.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["run"]["phases"][0]["targets"] == [[0, 4, 0, 0], [update, 2, 0, 0]]
    assert load_run(out).phases[0].targets == park.targets


def test_a_park_that_passes_its_new_target_fails() -> None:
    """Sent to (5, 0) from (4.01, 0) at 3.08 m/s, with 3.95 m of braking at
    1.2 m/s^2: it turns round at speed (docs/controllers.md, "A park at speed
    turns round rather than reverse where that is sooner"), reaching x = 6.08,
    1.08 m past the target in force (braking straight, it stopped at 7.99)."""
    mission = mission_from_text(PARK.format(a=10, when="travelled: 4", b=5))
    result = run_mission(mission)
    update = int(np.flatnonzero(result.reference == 1)[0])
    assert result.x[update] == pytest.approx(4.01, abs=0.01)
    assert result.x.max() == pytest.approx(6.08, abs=0.01)
    summary = result.judged
    assert summary is not None
    assert summary["outcome"] == "expect-failed"
    check = _overshoot(summary)
    assert check["met"] is False
    assert check["value"] == pytest.approx(result.x.max() - 5.0, abs=1e-9)
    assert "park: overshoot_max = 1.07519 (max 0.02)" in summary["message"]


def test_a_formula_on_the_target_distance_reads_the_target_in_force() -> None:
    """From (0, 0) to (4, 0), sent back to (2, 0) at 6 s: the distance starts
    at 4 m from the target in force (2 m from the last), so always(distance
    <= 5) holds by (5 - 4) / 5, not (5 - 2) / 5."""
    text = PARK.format(a=4, when="elapsed: 6", b=2)
    text += '    expect: {temporal: ["always(target_distance <= 5)"]}\n'
    summary = run_mission(mission_from_text(text)).judged
    assert summary is not None
    rho = summary["phases"][0]["temporal"]["always(target_distance <= 5)"]
    assert rho == pytest.approx(0.2, abs=1e-9)


# A park to (3, 0) from facing north, sent to (-3, 0) at 4 s.
TURNED = """
version: 1
name: park-turned
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 1.5708}
  limits: {v: 1, omega: 1}
phases:
  - name: park
    regulate: {target: {x: 3, y: 0, theta: 0}}
    updates:
      - when: {elapsed: 4}
        target: {x: -3, y: 0, theta: 3.14159}
    until: {settled: {position: 0.02, heading: 0.02}}
    timeout: 60
"""


def test_a_fight_is_progress_towards_the_target_in_force() -> None:
    """At its speed limit towards (3, 0), the robot went away from (-3, 0):
    judged by its last target, 2.34 s of that read as a fight with the limit."""
    result = run_mission(mission_from_text(TURNED))
    update = int(np.flatnonzero(result.reference == 1)[0])
    assert result.x[update] > 1.0  # well on its way to the first target
    summary = result.judged
    assert summary is not None
    inputs = summary["phases"][0]["inputs"]
    assert inputs["speed_at_limit"] > 0.2  # it drove at its limit, ...
    assert inputs["speed_fight_time"] == pytest.approx(0.0, abs=1e-12)  # ... never in vain
    assert inputs["turn_rate_fight_time"] == pytest.approx(0.0, abs=1e-12)


FIGHT = """
version: 1
name: fight
robot: {dt: 0.01, limits: {v: 1.0, omega: 2}}
phases:
  - name: park
    regulate: {target: {x: 2.3, y: 2, theta: 0}}
    until: {settled: {position: 0.05, heading: 0.05}}
    timeout: 30
    updates:
      - when: {elapsed: 2}
        target: {x: 2.3, y: 0, theta: 0}
"""


def test_a_stretch_at_the_limit_that_ends_at_an_update_is_judged_by_its_own_target() -> None:
    """At its speed limit for the 2 s before the update, the robot drove most
    of the way to (2.3, 2): no fight, as without the update (the stretch ends
    where the new target takes over, which judged it before)."""
    from wmr_mission.verdicts.inputs import progress_to

    result = run_mission(mission_from_text(FIGHT))
    without = run_mission(mission_from_text(FIGHT.split("    updates:")[0]))
    update = int(np.flatnonzero(result.reference == 1)[0])
    assert update == 200
    assert np.array_equal(result.x[: update + 1], without.x[: update + 1])  # the same drive
    for run in (result, without):
        inputs = run.summary()["phases"][0]["inputs"]
        assert inputs["speed_fight_time"] == 0.0
    # progress over samples 0 .. 200 towards the aim in force over them,
    # sample by sample, as a robot sent at each to its target is judged
    x, y = result.x[: update + 10], result.y[: update + 10]
    aim_x = np.full(x.size, 2.3)
    aim_y = np.where(np.arange(x.size) < update, 2.0, 0.0)
    progress = progress_to(x, y, (aim_x, aim_y))
    assert progress(0, update) == pytest.approx(
        np.hypot(x[0] - 2.3, y[0] - 2.0) - np.hypot(x[update] - 2.3, y[update] - 2.0), abs=1e-12
    )
    across = progress(100, update + 5)  # the aim moved at sample 200
    assert across == pytest.approx(
        np.hypot(x[100] - 2.3, y[100] - 2.0)
        - np.hypot(x[update] - 2.3, y[update] - 2.0)
        + np.hypot(x[update] - 2.3, y[update])
        - np.hypot(x[update + 5] - 2.3, y[update + 5]),
        abs=1e-12,
    )


REVERSED = """
version: 1
name: reversed
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 3.14159}
  limits: {v: 1.5, omega: 2}
phases:
  - name: park
    regulate: {target: {x: 6, y: 0, theta: 3.14159}}
    updates:
      - when: {elapsed: 2}
        target: {x: -2, y: 0, theta: 3.14159}
    until: {settled: {position: 0.03, heading: 0.05}}
    timeout: 30
"""


def test_a_target_sent_back_the_way_it_came_reverses_at_the_limit_without_a_fight() -> None:
    """Backing to (6, 0) at the limit, then sent to (-2, 0): the robot drives
    forward at the limit from the next sample, its distance to the target in
    force shrinking all the while. One stretch at the limit changing sign
    read 4.33 s of fight; judged apart on each side of the update, none."""
    result = run_mission(mission_from_text(REVERSED))
    update = int(np.flatnonzero(result.reference == 1)[0])
    limit = 1.5 * (1.0 - 1e-3)
    assert (result.v[update - 50 : update] <= -limit).all()  # backing at the limit
    assert (result.v[update : update + 50] >= limit).all()  # then forward at it
    summary = result.judged
    assert summary is not None
    assert summary["phases"][0]["inputs"]["speed_fight_time"] == 0.0
