from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest
from test_output_synthetic import RADIUS, REF_OFFSET, circle_run

from wmr_mission.output.metrics import (
    check_expectations,
    convergence_index,
    overshoot,
    summarize,
    wrap_angle,
)
from wmr_mission.result import Outcome, PhaseInfo

NO_EXPECT = {
    "final_position_error": None,
    "final_heading_error": None,
    "max_constraint_violation": None,
    "estimation_convergence_time": None,
    "duration": None,
}


def test_summary_key_order_is_fixed() -> None:
    summary = summarize(circle_run())
    assert list(summary) == [
        "outcome",
        "message",
        "mission",
        "seed",
        "samples",
        "duration",
        "final",
        "estimation_convergence_time",
        "estimation_overshoot",
        "max_constraint_violation",
        "phases",
        "compute_us_per_sample",
        "loop_us_per_sample",
    ]
    assert list(summary["phases"][0]) == [
        "name",
        "kind",
        "start",
        "end",
        "duration",
        "tracking_error",
        "target_error",
        "constraint",
        "estimation",
        "max_abs_v",
        "max_abs_omega",
        "phase2_iterations",
    ]
    json.dumps(summary, allow_nan=False)  # plain, finite JSON data


def test_run_level_values() -> None:
    summary = summarize(circle_run())
    assert summary["outcome"] == "success"
    assert summary["samples"] == 2001
    assert summary["duration"] == pytest.approx(20.0)
    # 0.9**k < 0.05 first at k = 29 (log 0.05 / log 0.9 = 28.4)
    assert summary["estimation_convergence_time"] == pytest.approx(0.29)
    assert summary["max_constraint_violation"] == pytest.approx(0.02)
    # the position errors decay without crossing zero; the heading error is zero
    assert summary["estimation_overshoot"] == {"x": 0.0, "y": 0.0, "theta": 0.0}


def test_final_error_is_from_the_last_target() -> None:
    final = summarize(circle_run())["final"]
    assert final["position_error"] == pytest.approx(RADIUS)
    heading = 0.5 * 20.0 + math.pi / 2 - 4 * math.pi  # wrapped final heading vs 0
    assert final["heading_error"] == pytest.approx(abs(heading))
    assert final["target"] == {"phase": "park", "x": 0.0, "y": 0.0, "theta": 0.0}
    assert final["pose"]["x"] == pytest.approx(RADIUS * math.cos(10.0))


def test_final_error_of_a_track_phase_is_from_its_last_reference_point() -> None:
    run = circle_run(1200)  # ends in the orbit phase
    final = summarize(run)["final"]
    assert final["position_error"] == pytest.approx(REF_OFFSET)
    assert final["heading_error"] is None
    assert final["target"]["phase"] == "orbit"
    assert final["target"]["x"] == pytest.approx(run.x[-1] + REF_OFFSET)


def test_per_phase_values() -> None:
    approach, orbit, park = summarize(circle_run())["phases"]
    assert (approach["start"], approach["end"]) == pytest.approx((0.0, 5.0))
    assert orbit["duration"] == pytest.approx(10.0)
    assert park["end"] == pytest.approx(20.0)
    assert approach["tracking_error"] == pytest.approx(
        {"rms": REF_OFFSET, "max": REF_OFFSET, "rms_after_1s": REF_OFFSET}
    )
    assert park["tracking_error"] is None
    assert park["target_error"]["position"] == pytest.approx(RADIUS)
    assert approach["constraint"] == {
        "max_violation": None,
        "max_value": None,
        "time_in_violation": 0.0,
    }
    # 50 samples at 0.02 > 0
    assert park["constraint"] == pytest.approx(
        {"max_violation": 0.02, "max_value": 0.02, "time_in_violation": 0.5}
    )
    assert approach["estimation"]["max_abs_error"] == pytest.approx(
        {"x": 1.0, "y": 1.0, "theta": 0.0}
    )
    assert approach["estimation"]["convergence_time"] == pytest.approx(0.29)
    assert orbit["estimation"]["convergence_time"] == 0.0
    assert approach["max_abs_v"] == pytest.approx(1.0)
    assert approach["max_abs_omega"] == pytest.approx(0.5)
    assert approach["phase2_iterations"] == {"total": 15, "max": 3}
    assert orbit["phase2_iterations"] == {"total": 0, "max": 0}


def test_rms_after_one_second_leaves_out_the_entry_transient() -> None:
    run = circle_run()
    run.x_ref = run.x_ref.copy()
    run.x_ref[500:600] = run.x[500:600] + 0.5  # first second of the orbit: 0.5 m off
    orbit = summarize(run)["phases"][1]["tracking_error"]
    assert orbit["max"] == pytest.approx(0.5)
    assert orbit["rms"] == pytest.approx(math.sqrt((100 * 0.25 + 900 * 1e-4) / 1000))
    assert orbit["rms_after_1s"] == pytest.approx(REF_OFFSET)


def test_convergence_time_of_an_error_that_comes_back() -> None:
    run = circle_run()
    run.x_est = run.x_est.copy()
    run.x_est[1000] += 0.1  # one late excursion above 0.05
    assert summarize(run)["estimation_convergence_time"] == pytest.approx(10.01)


def test_convergence_never_is_null() -> None:
    errors = {"x": np.array([1.0, 0.5, 0.2, 0.06])}
    assert convergence_index(errors) is None
    assert convergence_index({"x": np.array([0.01, np.nan, 0.01])}) == 2


def test_overshoot_of_a_known_signal() -> None:
    assert overshoot(np.array([-1.0, -0.5, 0.2, 0.1, 0.0])) == pytest.approx(0.2)
    assert overshoot(np.array([2.0, 0.5, -0.5, 0.0])) == pytest.approx(0.25)
    assert overshoot(np.array([0.0, 0.3])) == 0.0
    assert overshoot(np.array([1.0, 0.5, 0.1])) == 0.0


def test_heading_overshoot_is_wrapped() -> None:
    error = np.zeros(2001)
    error[:4] = [0.5, -0.1, 0.05, 0.0]
    error[10] = 2 * math.pi - 0.2  # the same as -0.2 once wrapped
    summary = summarize(circle_run(theta_error=error))
    assert summary["estimation_overshoot"]["theta"] == pytest.approx(0.4)
    assert wrap_angle(np.array([math.pi]))[0] == pytest.approx(-math.pi)


def test_compute_time_in_microseconds() -> None:
    compute = summarize(circle_run())["compute_us_per_sample"]
    ns = 1000 + 10 * (np.arange(2001) % 100)
    assert compute == pytest.approx(
        {
            "mean": ns.mean() / 1000,
            "median": np.median(ns) / 1000,
            "p99": np.percentile(ns, 99) / 1000,
        }
    )


def test_loop_time_per_sample_in_microseconds() -> None:
    run = circle_run()
    assert summarize(run)["loop_us_per_sample"] is None  # not timed: a run read back
    run.loop_ns = 3_000_000
    assert summarize(run)["loop_us_per_sample"] == pytest.approx(3_000.0 / 2001)


def test_diverged_run_gives_nulls_not_warnings() -> None:
    run = circle_run(800)
    run = dataclasses.replace(
        run,
        x=run.x.copy(),
        x_est=run.x_est.copy(),
        outcome=Outcome.diverged,
        message="state not finite",
    )
    run.x[700:] = np.nan
    run.x_est[700:] = np.inf
    summary = summarize(run)
    assert summary["final"]["position_error"] is None
    assert summary["estimation_convergence_time"] is None
    orbit = summary["phases"][1]
    assert orbit["tracking_error"]["rms"] == pytest.approx(REF_OFFSET)  # finite part only
    json.dumps(summary, allow_nan=False)


def test_hold_without_target_falls_back_to_an_earlier_phase() -> None:
    run = circle_run()
    run.phases = [*run.phases[:2], PhaseInfo("wait", "hold")]
    final = summarize(run)["final"]
    assert final["target"]["phase"] == "orbit"


def test_expectations_met_unmet_and_null() -> None:
    summary = summarize(circle_run(1200))  # ends in a track phase: no heading error
    expect = dict(NO_EXPECT) | {
        "final_position_error": {"max": 0.05},
        "final_heading_error": {"max": 0.01},
        "estimation_convergence_time": {"max": 0.2},
        "duration": {"max": 12.0},
    }
    checks = check_expectations(summary, expect)
    assert [(c["metric"], c["met"]) for c in checks] == [
        ("final_position_error", True),
        ("final_heading_error", False),  # null never meets a threshold
        ("estimation_convergence_time", False),
        ("duration", True),
    ]
    assert checks[1]["value"] is None
    assert checks[2] == {
        "metric": "estimation_convergence_time",
        "max": 0.2,
        "value": pytest.approx(0.29),
        "met": False,
    }
    assert check_expectations(summary, NO_EXPECT) == []


def test_expectation_on_the_constraint() -> None:
    summary = summarize(circle_run())
    [check] = check_expectations(summary, {"max_constraint_violation": {"max": 0.001}})
    assert check["value"] == pytest.approx(0.02)
    assert check["met"] is False


def test_unknown_expectation_is_an_error() -> None:
    with pytest.raises(ValueError, match="unknown expectation 'speed'"):
        check_expectations(summarize(circle_run(100)), {"speed": {"max": 1.0}})


def test_a_held_constraint_is_no_violation() -> None:
    """Rows at -0.5 and at rounding level above 0: nothing violated, the margin kept."""
    run = circle_run()
    run.constraint[1600:1650] = 5e-8  # on the boundary, held by the corrective action
    park = summarize(run)["phases"][2]
    assert park["constraint"] == pytest.approx(
        {"max_violation": 5e-8, "max_value": 5e-8, "time_in_violation": 0.0}
    )
    run.constraint[1600:1650] = -0.5
    summary = summarize(run)
    assert summary["max_constraint_violation"] == 0.0
    assert summary["phases"][2]["constraint"]["max_value"] == pytest.approx(-0.5)


def test_per_phase_estimation_overshoot() -> None:
    """The x/y errors decay from 1 without crossing zero; a heading error that
    starts at 0.2 in the orbit and swings to -0.05 overshoots by a quarter."""
    samples = 2001
    heading = np.zeros(samples)
    heading[500:1500] = np.linspace(0.2, -0.05, 1000)
    phases = summarize(circle_run(samples, theta_error=heading))["phases"]
    assert phases[0]["estimation"]["overshoot"] == pytest.approx({"x": 0.0, "y": 0.0, "theta": 0.0})
    assert phases[1]["estimation"]["overshoot"]["theta"] == pytest.approx(0.25)
