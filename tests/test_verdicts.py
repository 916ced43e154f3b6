"""Runs that a control engineer would call failures end as failures, and runs
that do what they should are not failed for touching a limit.

Each mission in tests/data/verdicts/ is built to be bad: its turn rate really
bangs from one limit to the other, or the robot really is far behind its
reference. Every one of them used to end as a plain success. Each test checks
the premise from trajectory.csv on its own (not from our summary) before the
verdict. tests/data/soundness/ holds the cases of the generated set's judge
(docs/soundness.md): a stall at a zone, a drive at the speed limit, a detour.
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import soundness
import yaml
from geometry import distance_to_ellipse
from test_case_studies import read_trajectory, run

from wmr_mission.output.result import RunResult
from wmr_mission.record import Outcome
from wmr_mission.sim.plan import plan_mission
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.models import Mission
from wmr_mission.verdicts.metrics import judge

DATA = Path(__file__).resolve().parent / "data"
VERDICTS = DATA / "verdicts"
MISSIONS = Path(__file__).resolve().parent.parent / "missions"

SOUNDNESS = DATA / "soundness"

# mission file, phase, the input that bangs between its limits, that limit
BANG_BANG = [
    ("noisy_axle", "orbit", "omega", 20.0),  # the literal eq. (27) law under 1 cm noise
    ("noisy_ekf", "circle", "omega", 6.0),  # the shipped noisy-ekf mission, shortened
]


def _after_first_second(columns: dict[str, np.ndarray], phase: str) -> np.ndarray:
    on = columns["phase"] == phase
    return on & (columns["t"] >= columns["t"][on][0] + 1.0 - 1e-9)


def _failed(summary: dict[str, object]) -> set[tuple[str | None, str]]:
    checks = summary["expectations"]
    assert isinstance(checks, list)
    return {(c["phase"], c["metric"]) for c in checks if not c["met"]}


@pytest.mark.slow
@pytest.mark.parametrize(("name", "phase", "column", "limit"), BANG_BANG)
def test_inputs_that_bang_between_their_limits_are_not_a_success(
    name: str, phase: str, column: str, limit: float, tmp_path: Path
) -> None:
    out = tmp_path / "run"
    code, stdout, stderr = run(VERDICTS / f"{name}.yaml", out, "--no-plots")
    columns = read_trajectory(out)
    later = _after_first_second(columns, phase)
    values = columns[column][later]
    # the premise: by more than half the range in one sample, after the phase's first second
    assert np.abs(np.diff(values)).max() > limit
    summary = json.loads((out / "summary.json").read_text())
    assert code == 1, stdout + stderr
    assert summary["outcome"] == "expect-failed"
    assert (phase, "turn_rate_jump_max") in _failed(summary)
    assert f"{phase}: turn_rate_jump_max = " in summary["message"]
    assert next(line for line in stdout.splitlines() if line.startswith(phase)).endswith("NOT MET")


@pytest.mark.slow
def test_a_turn_rate_that_chatters_on_a_wall_is_not_a_success(tmp_path: Path) -> None:
    """The deviation regulator pinned on a box wall at v ~ 0, where the
    corrective action's lateral gradient is near-singular: its turn rate
    banged between its limits, +-3 rad/s, in one sample. The regulator's turn
    now moves by at most half its limit a sample (controllers/paper.py,
    TURN_SLEW), so no longer in one sample, but it still reverses dozens of
    times a second: still not a success, on its reversals."""
    out = tmp_path / "run"
    code, stdout, stderr = run(VERDICTS / "pinned_on_a_wall.yaml", out, "--no-plots")
    columns = read_trajectory(out)
    later = _after_first_second(columns, "go")
    assert np.abs(np.diff(columns["omega"][later])).max() <= 3.0
    summary = json.loads((out / "summary.json").read_text())
    assert code == 1, stdout + stderr
    assert summary["outcome"] == "expect-failed"
    assert ("go", "turn_rate_reversals") in _failed(summary)


@pytest.mark.slow
def test_a_slow_turn_at_a_tiny_turn_rate_limit_is_deliberate(tmp_path: Path) -> None:
    """Parking facing the wrong way with a 0.1 rad/s turn-rate limit: omega sits
    at its limit for most of the phase, one way, turning the robot towards its
    target: the best the limit allows, not a fight. It used to fail on
    turn_rate_at_limit (100 %); a mission that wants that bound sets it."""
    out = tmp_path / "run"
    code, stdout, stderr = run(VERDICTS / "tiny_turn_rate_limit.yaml", out, "--no-plots")
    columns = read_trajectory(out)
    omega = columns["omega"][_after_first_second(columns, "park")]
    assert np.mean(np.abs(omega) >= 0.1 * (1 - 1e-9)) > 0.9  # the premise: at the limit...
    assert len(set(np.sign(omega))) == 1  # ...one way...
    turned = abs(columns["theta"][-1] - columns["theta"][0])
    assert turned < math.pi  # ...and less than half a turn
    assert code == 0, stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    [park] = summary["phases"]
    assert park["inputs"]["turn_rate_fight_time"] == 0.0
    assert park["inputs"]["turn_rate_at_limit"] == pytest.approx(1.0)


@pytest.mark.slow
def test_a_robot_far_from_its_path_is_not_a_success(tmp_path: Path) -> None:
    """The line starts 5 m ahead and runs at 1.98 m/s against a 2 m/s limit."""
    out = tmp_path / "run"
    code, stdout, stderr = run(VERDICTS / "behind_a_fast_path.yaml", out, "--no-plots")
    columns = read_trajectory(out)
    later = _after_first_second(columns, "chase")
    # the path passed so far is the segment from (5, 0) to the reference point
    behind = np.clip(5.0 - columns["x"][later], 0.0, None)
    off = np.hypot(behind, columns["y"][later])
    assert off.max() > 2.9  # the premise
    summary = json.loads((out / "summary.json").read_text())
    assert code == 1, stdout + stderr
    assert summary["outcome"] == "expect-failed"
    # The limits cannot join the path within the 5 s phase (the robot gains
    # 0.02 m/s on it): the whole phase is its entry, so it is judged at its end.
    assert ("chase", "along_track_lag_max") in _failed(summary)
    [chase] = summary["phases"]
    assert chase["tracking"]["entry_time"] > 5.0
    assert chase["tracking"]["along_track_lag_max"] == pytest.approx(
        5.0 + 1.98 * 5.0 - columns["x"][-2],
        abs=0.03,  # the last sample's lag
    )
    assert chase["tracking_error"]["max"] == pytest.approx(off.max(), abs=1e-9)


def _run_past_validate(data: dict[str, Any]) -> tuple[dict[str, Any], RunResult]:
    """Run a mission that passed its schema, whatever `validate` says of it."""
    context = {"parameters": data.get("parameters", {}), "regions": list(data.get("regions", {}))}
    mission = Mission.model_validate(data, context=context)
    result = run_mission(plan_mission(mission, None))
    return judge(result, mission.model_dump(mode="json")), result


UNREACHABLE = DATA / "missions" / "invalid" / "path_faster_than_speed_limit.yaml"


def test_an_unreachable_path_is_refused_before_the_run(tmp_path: Path) -> None:
    """The ellipse at 0.8*pi needs 13.8 m/s against a 10 m/s limit."""
    code, _, stderr = run(UNREACHABLE, tmp_path / "run")
    assert code == 1
    assert f"{UNREACHABLE}:16:66: the path needs a speed of up to 13.8 m/s" in stderr
    assert not (tmp_path / "run").exists()


@pytest.mark.slow
@pytest.mark.parametrize("rate", ["0.8*pi", "1.2*pi"])
def test_an_unreachable_path_flown_anyway_is_not_a_success(rate: str) -> None:
    """Case 2 with the orbit too fast for the limits, run past `validate`: the
    robot falls off the ellipse, and the verdict says so."""
    data = yaml.safe_load((MISSIONS / "case2.yaml").read_text())
    data["phases"][1]["track"]["path"]["angular_rate"] = rate
    summary, result = _run_past_validate(data)
    orbit = summary["phases"][1]
    assert orbit["name"] == "orbit"
    assert orbit["tracking_error"]["rms"] > 0.2  # 0.29 m at 0.8*pi, 1.3 m at 1.2*pi
    assert result.outcome is Outcome.expect_failed
    assert ("orbit", "cross_track_error_max") in _failed(summary)


@pytest.mark.slow
def test_a_threshold_is_the_missions_own_call(tmp_path: Path) -> None:
    """The same tiny turn-rate limit: a mission that wants its turn rate off the
    limit says so (`turn_rate_at_limit`, a phase's own bound), and is held to it;
    one that relaxes a default (the turn-rate fight time) gets what it asked for."""
    data = yaml.safe_load((VERDICTS / "tiny_turn_rate_limit.yaml").read_text())
    data["phases"][0]["expect"] = {"turn_rate_at_limit": {"max": 0.5}}
    mission = tmp_path / "strict.yaml"
    mission.write_text(yaml.safe_dump(data))
    code, _, stderr = run(mission, tmp_path / "strict", "--no-plots")
    assert code == 1
    assert stderr.endswith("expectation not met: park: turn_rate_at_limit = 1 (max 0.5)\n")
    # 40 s at its 0.1 rad/s limit turn 4 rad, more than half a turn: a fight by its rule.
    data["phases"][0]["until"] = {"elapsed": 40}
    data["phases"][0]["expect"] = {}
    mission.write_text(yaml.safe_dump(data))
    code, _, stderr = run(mission, tmp_path / "longer", "--no-plots")
    assert code == 1
    assert "park: turn_rate_fight_time = " in stderr
    data["phases"][0]["expect"] = {"turn_rate_fight_time": {"max": 41.0}}
    mission.write_text(yaml.safe_dump(data))
    code, stdout, stderr = run(mission, tmp_path / "relaxed", "--no-plots")
    assert code == 0, stdout + stderr
    summary = json.loads((tmp_path / "relaxed" / "summary.json").read_text())
    [check] = [c for c in summary["expectations"] if c["metric"] == "turn_rate_fight_time"]
    assert check["phase"] == "park"
    assert check["max"] == 41.0
    assert check["met"] is True
    assert check["value"] > 31.4  # at the limit for more than half a turn


def _heading_run(case: str, heading: float) -> tuple[dict[str, Any], RunResult]:
    data = yaml.safe_load((MISSIONS / f"{case}.yaml").read_text())
    data["robot"]["initial_state"]["theta"] = heading
    return _run_past_validate(data)


def _off_the_ellipse(result: RunResult) -> bool:
    """Whether the orbit, after its first second, is ever more than 0.1 m off the
    ellipse: measured here from the arrays and the exact ellipse."""
    names = [info.name for info in result.phases]
    columns = {"t": result.t, "phase": np.array(names)[result.phase]}
    later = _after_first_second(columns, "orbit")
    return bool(later.any()) and distance_to_ellipse(result.x[later], result.y[later]).max() > 0.1


def _verdict_agrees(case: str, heading: float, tmp_path: Path) -> None:
    """The product's verdict is the independent judge's (scripts/soundness.py,
    docs/soundness.md): a success is sound, and a sound run is a success."""
    summary, result = _heading_run(case, heading)
    data = yaml.safe_load((MISSIONS / f"{case}.yaml").read_text())
    data["robot"]["initial_state"]["theta"] = heading
    result.write(tmp_path / "run", plots=False)
    problems = soundness.judge(data, tmp_path / "run").problems
    assert (summary["outcome"] == "success") == (not problems), (summary["message"], problems)
    if _off_the_ellipse(result):
        assert summary["outcome"] != "success"


# Headings every 15 degrees: from 11 of them in each case the one-step look-ahead
# law, the default before the tracking law with a time constant, flew the orbit
# partly in reverse at its turn-rate limit, and `run` said success. Whatever the
# law, the verdict must be the independent judge's, and a run off the ellipse
# must not be a success.
HEADINGS = [round(math.radians(d), 6) for d in range(-180, 180, 15)]


@pytest.mark.slow
@pytest.mark.parametrize("heading", [0.0, 2.094395, -1.308997])
def test_verdict_agrees_with_the_run_from_other_headings(heading: float, tmp_path: Path) -> None:
    _verdict_agrees("case2", heading, tmp_path)


@pytest.mark.sweep
@pytest.mark.parametrize("case", ["case1", "case2"])
@pytest.mark.parametrize("heading", HEADINGS)
def test_verdict_agrees_with_the_run_from_every_heading(
    case: str, heading: float, tmp_path: Path
) -> None:
    _verdict_agrees(case, heading, tmp_path)


# --- shipped missions whose inputs sit at a limit on purpose ---------------------


def _stretches(mask: np.ndarray) -> int:
    """Number of contiguous runs of True in ``mask``."""
    return int(np.count_nonzero(np.diff(mask.astype(np.int8)) == 1) + int(mask[0]))


@pytest.mark.slow
def test_fence_drives_to_the_fence_at_full_speed_and_succeeds(tmp_path: Path) -> None:
    """missions/fence.yaml drives to the fence at full speed on purpose: one
    forward run towards the fence, never a reversal at a limit. It used to relax
    `speed_at_limit`; a deliberate drive is no fight, and needs no relaxing."""
    out = tmp_path / "run"
    code, stdout, stderr = run(MISSIONS / "fence.yaml", out, "--no-plots")
    assert code == 0, stdout + stderr
    columns = read_trajectory(out)
    later = _after_first_second(columns, "approach")
    at_limit = np.abs(columns["v"][later]) >= 2.0 * (1 - 1e-9)
    assert at_limit.mean() > 0.01  # more than the 1 % that used to fail it
    assert np.all(columns["v"][later][at_limit] > 0.0)  # forward, towards the fence
    assert _stretches(at_limit) == 1  # one run, not chatter
    assert columns["x"].max() <= 3.0 + 1e-3  # and it stops at the fence
    [approach] = json.loads((out / "summary.json").read_text())["phases"]
    assert approach["inputs"]["speed_fight_time"] == 0.0


@pytest.mark.slow
def test_park_turns_in_place_at_full_rate_once_and_succeeds(tmp_path: Path) -> None:
    """missions/park.yaml turns in place at the bay at full rate once, never a
    bang-bang. It used to relax `turn_rate_at_limit`; a turn of less than half a
    turn at the limit is deliberate, and needs no relaxing."""
    out = tmp_path / "run"
    code, stdout, stderr = run(MISSIONS / "park.yaml", out, "--no-plots")
    assert code == 0, stdout + stderr
    columns = read_trajectory(out)
    later = _after_first_second(columns, "park")
    omega = columns["omega"][later]
    at_limit = np.abs(omega) >= 2.0 * (1 - 1e-9)
    assert at_limit.mean() > 0.01  # more than the 1 % that used to fail it
    assert _stretches(at_limit) == 1
    assert len(set(np.sign(omega[at_limit]))) == 1  # one direction
    at_the_bay = np.hypot(columns["x"][later], columns["y"][later]) < 0.02
    assert np.all(at_the_bay[at_limit])  # in place: at the bay while it turns
    park = json.loads((out / "summary.json").read_text())["phases"][0]
    assert park["inputs"]["turn_rate_fight_time"] == 0.0


# --- tracking against the timed reference, inputs by their quality ------------------


@pytest.mark.slow
def test_a_robot_stalled_at_a_zone_is_not_a_success(tmp_path: Path) -> None:
    """A 14 s line at 1 m/s into a wall across it (a keep-in half-plane): the
    robot stops at the wall, on the line, and ends about 10 m behind its
    reference. On the line it is never off its path (that alone used to make
    it a success); behind its reference it is."""
    out = tmp_path / "run"
    code, stdout, stderr = run(SOUNDNESS / "stalled.yaml", out, "--no-plots")
    columns = read_trajectory(out)
    # the premise: stopped at the wall (x = 4), on the line, ~10 m behind
    last = -2  # the last sample with a reference point
    assert columns["x"][last] == pytest.approx(3.85, abs=0.01)
    assert np.abs(columns["y"]).max() < 1e-3
    behind = columns["x_ref"][last] - columns["x"][last]
    assert behind > 9.5
    assert code == 1, stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "expect-failed"
    assert _failed(summary) == {("go", "along_track_lag_max")}
    [go] = summary["phases"]
    assert go["tracking"]["along_track_lag_max"] == pytest.approx(behind, abs=0.02)
    assert go["tracking"]["cross_track_error_max"] < 1e-3
    # a detour only while it drove on towards the zone in its way: stopped, it is not
    assert go["tracking"]["detour_time"] < 2.0


@pytest.mark.slow
def test_a_drive_at_the_speed_limit_to_its_target_is_a_success(tmp_path: Path) -> None:
    """Park 5 m away at limits 2 m/s and 3 rad/s: the regulator drives there at
    its speed limit on purpose, one way, and ends millimetres from the target.
    It used to fail on speed_at_limit (6.5 % of the phase)."""
    out = tmp_path / "run"
    code, stdout, stderr = run(SOUNDNESS / "drive-at-the-limit.yaml", out, "--no-plots")
    columns = read_trajectory(out)
    at_limit = np.abs(columns["v"]) >= 2.0 * (1 - 1e-9)
    assert at_limit.mean() > 0.05  # the premise: long at the limit...
    assert np.all(columns["v"][at_limit] > 0)  # ...one way...
    assert _stretches(at_limit) == 1  # ...in one drive...
    assert math.hypot(columns["x"][-1], columns["y"][-1] - 5) < 0.01  # ...to the target
    assert code == 0, stdout + stderr
    [park] = json.loads((out / "summary.json").read_text())["phases"]
    assert park["inputs"]["speed_fight_time"] == 0.0
    assert park["inputs"]["speed_at_limit"] > 0.05


@pytest.mark.slow
def test_a_detour_a_zone_forces_is_not_a_tracking_error(tmp_path: Path) -> None:
    """A line past a keep-out circle 0.7 m off it: the robot goes round, 0.44 m
    off the line, and is back on it. That is a detour, measured as one, and the
    run a success (the former zone filter failed it on its kick of the turn rate
    at the zone's edge, 4.5 rad/s in one sample)."""
    out = tmp_path / "run"
    code, stdout, stderr = run(SOUNDNESS / "detour.yaml", out, "--no-plots")
    columns = read_trajectory(out)
    off = np.abs(columns["y"])
    assert off.max() == pytest.approx(0.44, abs=0.01)  # the premise: round the zone...
    assert off[columns["t"] > 12].max() < 1e-3  # ...and back on the line
    jumps = np.abs(np.diff(columns["omega"]))
    assert jumps.max() < 3.0  # no kick of the 3 rad/s limit in one sample
    assert code == 0, stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    assert _failed(summary) == set()
    [go] = summary["phases"]
    assert go["tracking"]["detour_offset_max"] == pytest.approx(off.max(), abs=0.01)
    assert 2.0 < go["tracking"]["detour_time"] < 6.0
    assert go["tracking"]["cross_track_error_max"] < 1e-3
    assert go["tracking"]["along_track_lag_max"] < 1e-3
    assert go["inputs"]["turn_rate_jump_max"] == pytest.approx(jumps.max())
    # the zones reach 0.3 m into the path; the default allows the margin the
    # controller keeps round them (the estimate's, 0.05 m), the look-ahead and
    # the tracking tolerance on top: 0.5 m
    assert summary["constraint_margin"] == pytest.approx(0.05)
    [check] = [c for c in summary["expectations"] if c["metric"] == "detour_offset_max"]
    assert check["max"] == pytest.approx(0.3 + 0.05 + 0.05 + 0.1)


@pytest.mark.slow
def test_noise_driven_turn_rate_jitter_is_not_a_success(tmp_path: Path) -> None:
    """Case 2 sampled at 5 ms with 3 cm / 0.03 rad of noise tracks its orbit well
    but turns by noise: 0.7 rad/s of jitter where the heading noise explains
    0.3 (0.03 rad corrected within the 0.1 s time constant) and 1 % of the
    20 rad/s limit adds 0.2. It used to be a success."""
    data = yaml.safe_load((MISSIONS / "case2.yaml").read_text())
    data["robot"]["dt"] = 0.005
    data["sensors"]["noise_std"] = {"x": 0.03, "y": 0.03, "theta": 0.03}
    # the observer's poles as they were by default: the poles that follow the
    # noise filter it (docs/paper-notes.md, "Eqs. (6)-(7) under position noise")
    data["estimator"]["poles"] = {"x": 0.9, "y": 0.9, "theta": 0.9}
    mission = tmp_path / "case2-jitter.yaml"
    mission.write_text(yaml.safe_dump(data, sort_keys=False))
    out = tmp_path / "run"
    code, stdout, stderr = run(mission, out, "--no-plots")
    columns = read_trajectory(out)
    orbit = columns["phase"] == "orbit"
    omega = columns["omega"][orbit][400:]  # after the first 2 s
    mean = np.convolve(omega, np.ones(41) / 41, mode="valid")
    spread = 1.4826 * np.median(np.abs(omega[20:-20] - mean))
    assert spread > 0.6  # the premise, measured here: well above 0.5
    assert code == 1, stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    assert ("orbit", "turn_rate_jitter") in _failed(summary)
    [check] = [
        c
        for c in summary["expectations"]
        if (c["phase"], c["metric"]) == ("orbit", "turn_rate_jitter")
    ]
    assert check["max"] == pytest.approx(0.01 * 20 + 0.03 / 0.1)
    assert check["value"] == pytest.approx(spread, rel=0.05)
    orbit_summary = next(p for p in summary["phases"] if p["name"] == "orbit")
    assert orbit_summary["tracking"]["cross_track_error_max"] < 0.03  # it tracks well


@pytest.mark.slow
def test_a_regulator_that_stalls_short_of_its_target_is_not_a_success(tmp_path: Path) -> None:
    """The deviation LQR parks for 20 s and stalls 2.1 m short: a phase that runs
    for a set time has no goal to time out on, and its progress is what is judged."""
    out = tmp_path / "run"
    code, stdout, stderr = run(VERDICTS / "deviation_stalls.yaml", out, "--no-plots")
    columns = read_trajectory(out)
    # the premise: far from the target at the end, and hardly moving for the last 5 s
    assert math.hypot(columns["x"][-1], columns["y"][-1]) > 2.0
    moved = math.hypot(columns["x"][-1] - columns["x"][-500], columns["y"][-1] - columns["y"][-500])
    assert moved < 0.1
    assert code == 1, stdout + stderr
    summary = json.loads((out / "summary.json").read_text())
    assert _failed(summary) == {("park", "stall_time")}
    [park] = summary["phases"]
    assert park["regulation"]["stall_time"] > 10.0
    # a regulator that gets there makes progress all the way
    code, stdout, stderr = run(MISSIONS / "park.yaml", tmp_path / "park", "--no-plots")
    assert code == 0, stdout + stderr
    park = json.loads((tmp_path / "park" / "summary.json").read_text())["phases"][0]
    assert park["regulation"]["stall_time"] == 0.0
