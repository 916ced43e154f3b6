from __future__ import annotations

import dataclasses
import json
import math
from typing import Any

import numpy as np
import pytest
from test_output_synthetic import PHASE_STARTS, RADIUS, REF_OFFSET, REGIONS, TURN_RATE, circle_run

from wmr_mission.output.result import RunResult
from wmr_mission.record import Outcome, PhaseRecord, Transition
from wmr_mission.verdicts.metrics import (
    AT_LIMIT_TOLERANCE,
    LOCAL_WINDOW,
    at_limit_fraction,
    check_expectations,
    convergence_index,
    distance_to_path,
    judge,
    overshoot,
    summarize,
    wrap_angle,
)

NO_EXPECT = {
    "final_position_error": None,
    "final_heading_error": None,
    "max_constraint_violation": None,
    "estimation_convergence_time": None,
    "duration": None,
}


def off_arc(run: RunResult, start: int, end: int) -> np.ndarray:
    """Distance of the robot from the arc its reference covered in samples
    start..end-1. The reference runs 0.01 m east of the robot: at sample k it is
    at angle 0.5 t_k on the circle of radius 2 about (0.01, 0); the nearest point
    of that arc lies along the ray from the centre, clamped to the arc's ends."""
    x, y = run.x[start:end] - REF_OFFSET, run.y[start:end]
    along = TURN_RATE * run.t[start:end]
    angle = along + wrap_angle(np.arctan2(y, x) - along)
    angle = np.clip(angle, along[0], along[-1])
    return np.hypot(x - RADIUS * np.cos(angle), y - RADIUS * np.sin(angle))


def _park_clearance() -> Any:
    """The park phase's least distance from its keep-in ellipse's edge [m], by
    shapely on the ellipse drawn with 20,000 corners (to 1e-6 m)."""
    import shapely

    run = circle_run()
    region = REGIONS["ellipse"]
    (a, b), rotation = region["semi_axes"], region["rotation"]
    angle = np.linspace(0.0, 2.0 * np.pi, 20_000, endpoint=False)
    u, w = a * np.cos(angle), b * np.sin(angle)
    edge = shapely.LinearRing(
        np.column_stack(
            [
                np.cos(rotation) * u - np.sin(rotation) * w,
                np.sin(rotation) * u + np.cos(rotation) * w,
            ]
        )
    )
    park = slice(PHASE_STARTS[2], None)
    least = shapely.distance(shapely.points(run.x[park], run.y[park]), edge).min()
    return pytest.approx(float(least), abs=2e-6)


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
        "convergence_tolerance",
        "estimation_overshoot",
        "estimation_rms",
        "constraint_margin",  # a run with constraints
        "max_constraint_violation",
        "clearance_min",  # [m] the body's, in a run with zones
        "clearance_phases",  # the phases it is the least over: those with zones
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
        "settle_time",
        "settled_samples",
        "tracking_error",
        "tracking",
        "target_error",
        "regulation",
        "constraint",
        "estimation",
        "inputs",
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


def test_final_error_of_a_run_ending_on_a_track_phase_is_at_its_last_reference_point() -> None:
    """A run's last sample follows its last command and has no reference point: the
    robot is measured at the last reference point's own sample, not 0.02 m (the
    arc of one sample) past it."""
    run = circle_run(1200)
    x_ref, y_ref = run.x_ref.copy(), run.y_ref.copy()
    x_ref[-1] = y_ref[-1] = np.nan  # as a run records it
    final = summarize(dataclasses.replace(run, x_ref=x_ref, y_ref=y_ref))["final"]
    assert final["position_error"] == pytest.approx(REF_OFFSET, abs=1e-12)
    assert final["target"]["x"] == pytest.approx(run.x[-2] + REF_OFFSET)
    assert final["time"] == pytest.approx(run.t[-2])
    assert final["pose"]["x"] == pytest.approx(run.x[-1])  # the pose is the last sample's


def test_per_phase_values() -> None:
    run = circle_run()
    approach, orbit, park = summarize(run)["phases"]
    assert (approach["start"], approach["end"]) == pytest.approx((0.0, 5.0))
    assert orbit["duration"] == pytest.approx(10.0)
    assert park["end"] == pytest.approx(20.0)
    off_path = off_arc(run, 0, 500)
    settled = slice(100, 500)  # the approach after its first second
    assert approach["tracking_error"] == pytest.approx(
        {
            "rms": np.sqrt(np.mean(off_path[settled] ** 2)),
            "max": off_path[settled].max(),
            "rms_from_start": np.sqrt(np.mean(off_path[:500] ** 2)),
            "max_from_start": off_path[:500].max(),
            "reference_error_rms": REF_OFFSET,
        },
        abs=1e-5,  # the reference polyline cuts the circle's chords by 6e-6 m at most
    )
    assert approach["settle_time"] == 1.0
    assert approach["settled_samples"] == 400
    assert park["tracking_error"] is None
    assert park["target_error"]["position"] == pytest.approx(RADIUS)
    assert approach["constraint"] == {
        "max_violation": None,
        "max_value": None,
        "time_in_violation": 0.0,
        "intrusion_max": None,
        "clearance_min": None,
    }
    # 50 samples at 0.02 > 0; the true position itself stays inside the ellipse
    assert park["constraint"] == pytest.approx(
        {
            "max_violation": 0.02,
            "max_value": 0.02,
            "time_in_violation": 0.5,
            "intrusion_max": 0.0,
            "clearance_min": _park_clearance(),
        }
    )
    assert approach["estimation"]["max_abs_error"] == pytest.approx(
        {"x": 1.0, "y": 1.0, "theta": 0.0}
    )
    assert approach["estimation"]["convergence_time"] == pytest.approx(0.29)
    # after the first second the position errors are 0.9**100 and below
    assert approach["estimation"]["rms"] == pytest.approx(
        {s: np.sqrt(np.mean(0.9 ** (2 * np.arange(100, 500)))) for s in ("x", "y")} | {"theta": 0}
    )
    # judged from the first sample with the position estimate within 0.05 m:
    # 2**0.5 * 0.9**k <= 0.05 first at k = 32
    assert approach["inputs"] == pytest.approx(
        {
            "judged_from": 0.32,
            "speed_jump_max": 0.0,
            "turn_rate_jump_max": 0.0,
            "speed_reversals": 0,
            "turn_rate_reversals": 0,
            "speed_fight_time": 0.0,
            "turn_rate_fight_time": 0.0,
            "turn_rate_jitter": 0.0,
            "speed_at_limit": 0.0,
            "turn_rate_at_limit": 0.0,
        },
        abs=1e-12,
    )
    assert orbit["inputs"]["judged_from"] == 0.0
    assert orbit["estimation"]["convergence_time"] == 0.0
    assert approach["max_abs_v"] == pytest.approx(1.0)
    assert approach["max_abs_omega"] == pytest.approx(0.5)
    assert approach["phase2_iterations"] == {"total": 15, "max": 3}
    assert orbit["phase2_iterations"] == {"total": 0, "max": 0}


def test_settle_time_leaves_out_the_entry_transient() -> None:
    run = circle_run()
    run.x = run.x.copy()
    run.x[500:600] += 0.5  # first second of the orbit: pushed 0.5 m east, off the path
    off_path = off_arc(run, 500, 1500)
    orbit = summarize(run)["phases"][1]["tracking_error"]
    assert orbit["max_from_start"] == pytest.approx(off_path.max(), abs=1e-5)
    assert orbit["max_from_start"] > 0.3
    assert orbit["rms_from_start"] == pytest.approx(np.sqrt(np.mean(off_path**2)), abs=1e-5)
    assert orbit["max"] == pytest.approx(off_path[100:].max(), abs=1e-5)
    assert orbit["max"] < 0.011
    longer = summarize(run, {"expect": {"settle_time": 2.0}})["phases"][1]
    assert longer["settle_time"] == 2.0
    assert longer["settled_samples"] == 800


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
    # finite part only
    assert orbit["tracking_error"]["reference_error_rms"] == pytest.approx(REF_OFFSET)
    assert 0.0 < orbit["tracking_error"]["max"] <= REF_OFFSET + 1e-5
    json.dumps(summary, allow_nan=False)


def _renamed(change: Transition, old: str, new: str) -> Transition:
    """``change`` with phase ``old`` called ``new``."""
    return dataclasses.replace(
        change,
        from_phase=new if change.from_phase == old else change.from_phase,
        to_phase=new if change.to_phase == old else change.to_phase,
    )


def test_hold_without_target_falls_back_to_an_earlier_phase() -> None:
    run = circle_run()
    run.phases = [*run.phases[:2], PhaseRecord("wait", "hold")]
    run.transitions = [_renamed(tr, "park", "wait") for tr in run.transitions]
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
    checks = check_expectations(summary, {"expect": expect})
    assert [(c.metric, c.met) for c in checks] == [
        ("final_position_error", True),
        ("final_heading_error", False),  # null never meets a threshold
        ("estimation_convergence_time", False),
        ("duration", True),
    ]
    assert checks[1].value is None
    assert checks[2].record() == {
        "metric": "estimation_convergence_time",
        "phase": None,
        "max": 0.2,
        "value": pytest.approx(0.29),
        "met": False,
        "rho": pytest.approx(-0.09),  # 0.09 s late
        "margin": pytest.approx(-0.45),  # by 45 % of its bound
    }
    assert checks[1].record()["margin"] is None  # a null value: missed by -inf
    assert check_expectations(summary, {"expect": NO_EXPECT}) == []


def test_expectation_on_the_constraint() -> None:
    summary = summarize(circle_run())
    [check] = check_expectations(summary, {"expect": {"max_constraint_violation": {"max": 0.001}}})
    assert check.value == pytest.approx(0.02)
    assert check.met is False


def test_unknown_expectation_is_an_error() -> None:
    with pytest.raises(ValueError, match="unknown expectation 'speed'"):
        check_expectations(summarize(circle_run(100)), {"expect": {"speed": {"max": 1.0}}})


def test_a_held_constraint_is_no_violation() -> None:
    """Rows at -0.5 and at rounding level above 0: nothing violated, the margin kept."""
    run = circle_run()
    run.constraint[1600:1650] = 5e-8  # on the boundary, held by the corrective action
    park = summarize(run)["phases"][2]
    assert park["constraint"] == pytest.approx(
        {
            "max_violation": 5e-8,
            "max_value": 5e-8,
            "time_in_violation": 0.0,
            "intrusion_max": 0.0,
            "clearance_min": _park_clearance(),
        }
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


# --- the quality metrics of a phase ---------------------------------------------


def _brute_force_distance(
    qx: np.ndarray, qy: np.ndarray, px: np.ndarray, py: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Distance to every segment of the polyline: the smallest, and its segment."""
    ax, ay = px[:-1], py[:-1]
    sx, sy = px[1:] - ax, py[1:] - ay
    along = np.clip(((qx[:, None] - ax) * sx + (qy[:, None] - ay) * sy) / (sx**2 + sy**2), 0, 1)
    distance = np.hypot(qx[:, None] - ax - along * sx, qy[:, None] - ay - along * sy)
    return distance.min(axis=1), distance.argmin(axis=1)


def test_distance_to_path_against_brute_force_on_a_figure_eight() -> None:
    """A robot up to 0.3 m off a figure-eight flown twice (it crosses itself,
    and its second lap falls between the first one's points), the last samples
    far behind their reference point: exact where the nearest segment is near
    the sample's own reference point, never below the true distance, and at
    most one sampling step above it elsewhere."""
    t = np.arange(0.0, 4 * math.pi, 0.02)
    px, py = 3 * np.sin(t), 2 * np.sin(2 * t)
    rng = np.random.default_rng(0)
    x = px + rng.uniform(-0.3, 0.3, t.size)
    y = py + rng.uniform(-0.3, 0.3, t.size)
    behind = np.arange(t.size - 80, t.size) - 40
    x[-80:], y[-80:] = px[behind] + 0.05, py[behind]
    distance = distance_to_path(x, y, px, py)
    expected, segment = _brute_force_distance(x, y, px, py)
    step = np.hypot(np.diff(px), np.diff(py)).max()
    assert np.all(distance >= expected - 1e-12)
    assert np.all(distance <= expected + step)
    near_own = np.abs(segment - np.arange(t.size)) < LOCAL_WINDOW
    np.testing.assert_allclose(distance[near_own], expected[near_own], rtol=0, atol=1e-12)
    assert np.all(distance[-80:] <= 0.05 + 1e-12)  # behind, but on the path
    # once round: the nearest segment is the sample's own but near the crossing
    once = slice(0, t.size // 2)
    first_lap = distance_to_path(x[once], y[once], px[once], py[once])
    expected, segment = _brute_force_distance(x[once], y[once], px[once], py[once])
    near_own = np.abs(segment - np.arange(first_lap.size)) < LOCAL_WINDOW
    assert near_own.mean() > 0.9
    np.testing.assert_allclose(first_lap[near_own], expected[near_own], rtol=0, atol=1e-12)


def test_the_tracking_bound_of_a_row_is_never_below_the_distance_to_the_path() -> None:
    """A row's verdict tries a tracking threshold against each sample's distance
    to its own reference point (from the squares, not np.hypot) before the
    distance to the path: that bound must never be below it, at any scale.
    The tight case: a robot off a straight path square to it at its reference
    point, where the two distances are the same number but for rounding."""
    from wmr_mission.verdicts.metrics import _off_path_bound

    rng = np.random.default_rng(3)
    s = np.arange(0.0, 40.0, 0.02)
    across = np.array([-0.7, 1.0]) / math.hypot(-0.7, 1.0)  # square to the path
    for scale in (1e-6, 1e-3, 1.0, 1e3, 1e6):
        px, py = scale * s, scale * (0.7 * s + 2.0)
        off = scale * rng.uniform(-0.3, 0.3, s.size)
        for x, y in (
            (px + off * across[0], py + off * across[1]),
            (px + off, py + scale * rng.uniform(-0.3, 0.3, s.size)),
        ):
            bound = _off_path_bound(x, y, px, py)
            assert np.all(bound >= distance_to_path(x, y, px, py))
            assert np.all(bound <= np.hypot(x - px, y - py) * (1 + 1e-8) + 1e-11)
    # a reference point missing: the distance to the path itself
    px[5] = np.nan
    np.testing.assert_array_equal(_off_path_bound(x, y, px, py), distance_to_path(x, y, px, py))


def test_phase_segments_are_the_entries_into_phases() -> None:
    """(phase, first sample, one past the last, what ended it) of each entry in
    run order, as the transitions made them, on random runs: a phase entered
    again at once (a retry) starts a stretch of its own, ended by its own
    transition, a phase left at the sample it was entered has one without
    samples, an update starts none; the stretches with samples are the phase
    column's."""
    from wmr_mission.verdicts.metrics import phase_segments

    def column_runs(phase: np.ndarray) -> list[tuple[int, int, int]]:
        stretches: list[tuple[int, int, int]] = []
        for k, value in enumerate(phase.tolist()):
            if stretches and stretches[-1][0] == value:
                stretches[-1] = (value, stretches[-1][1], k + 1)
            else:
                stretches.append((value, k, k + 1))
        return stretches

    rng = np.random.default_rng(5)
    base = circle_run(200)
    phases = [PhaseRecord(name, "hold") for name in ("a", "b", "c", "d")]
    for _ in range(30):
        count = int(rng.integers(1, 12))
        indices = [0, *rng.integers(0, 4, count - 1).tolist()]
        lengths = rng.integers(0, 4, count)
        lengths[-1] += 1  # the run's last row is its last phase's
        ends = np.cumsum(lengths)
        starts = ends - lengths
        # what ended each entry: a change's condition, the last the run's end
        ended = [*rng.choice(["elapsed", "timeout", "reaches"], count - 1).tolist(), "settled"]
        expected = list(zip(indices, starts.tolist(), ends.tolist(), ended, strict=True))
        samples = int(ends[-1])
        t = base.t[:samples]
        changes = [
            Transition(float(t[k]), phases[i].name, phases[j].name, why, 1.0)
            for i, j, k, why in zip(indices, indices[1:], starts[1:].tolist(), ended, strict=False)
        ]
        update = Transition(float(t[-1]), phases[indices[-1]].name, phases[indices[-1]].name,
                            "update", 1.0)  # fmt: skip
        end = Transition(float(t[-1]), phases[indices[-1]].name, None, "settled", 1.0)
        run = dataclasses.replace(
            base,
            phases=phases,
            **{name: getattr(base, name)[:samples] for name in ("t", "x", "y", "theta")},
            phase=np.repeat(np.array(indices, dtype=np.int64), lengths),
            transitions=[*changes, update, end],
        )
        segments = phase_segments(run)
        assert segments == expected
        assert all(type(n) is int for segment in segments for n in segment[:3])
        with_samples: list[tuple[int, int, int]] = []
        for i, start, stop, _ in (s for s in segments if s[1] < s[2]):
            if with_samples and with_samples[-1][0] == i:  # a retry's, run on
                with_samples[-1] = (i, with_samples[-1][1], stop)
            else:
                with_samples.append((i, start, stop))
        assert with_samples == column_runs(run.phase)
    assert phase_segments(dataclasses.replace(base, t=base.t[:0], phase=base.phase[:0])) == []


def test_distance_to_path_of_a_track_phase_ignores_the_lag() -> None:
    """On an ellipse flown 2 s behind the reference, the robot is on the path."""
    t = np.arange(0.0, 20.0, 0.01)
    px, py = 5.5 * np.cos(0.4 * np.pi * t), 3 * np.sin(0.4 * np.pi * t)
    x, y = np.roll(px, 200), np.roll(py, 200)
    x[:200], y[:200] = px[0], py[0]
    distance = distance_to_path(x, y, px, py)
    assert distance.max() < 1e-12


def test_distance_to_path_is_lateral_and_counts_only_the_path_passed() -> None:
    px, py = np.linspace(5.0, 10.0, 4), np.zeros(4)  # a line from (5, 0) to (10, 0)
    x, y = np.array([7.0, 7.0, 0.0, np.nan]), np.array([0.3, -2.0, 0.0, 1.0])
    distance = distance_to_path(x, y, px, py)
    np.testing.assert_allclose(distance[:3], [0.3, 2.0, 5.0], atol=1e-12)
    assert math.isnan(distance[3])
    assert np.all(np.isnan(distance_to_path(x, y, np.full(4, np.nan), np.full(4, np.nan))))
    # reference points missing at the start: the path is the rest, from (25/3, 0)
    px[:2] = np.nan
    np.testing.assert_allclose(
        distance_to_path(x, y, px, py)[:3],
        [math.hypot(25 / 3 - 7, 0.3), math.hypot(25 / 3 - 7, 2), 25 / 3],
        atol=1e-12,
    )


def test_at_limit_fraction_counts_both_signs_at_the_limit_only() -> None:
    values = np.array([3.0, -3.0, 3.0 * (1 - 1e-12), 2.99, 0.0])
    assert at_limit_fraction(values, 3.0) == pytest.approx(3 / 5)
    assert at_limit_fraction(values, math.inf) == 0.0
    assert at_limit_fraction(np.array([]), 3.0) is None


def test_at_limit_fraction_counts_each_value_once_as_its_magnitude_does() -> None:
    """Counted on either side without a column of magnitudes: the same count
    as ``|value| >= bound``, NaN never, a zero once where the limit is 0."""
    rng = np.random.default_rng(7)
    values = np.concatenate((rng.uniform(-4, 4, 500), [3.0, -3.0, 0.0, -0.0, math.nan]))
    for limit in (3.0, 0.5, 0.0):
        bound = limit * (1.0 - AT_LIMIT_TOLERANCE)
        expected = np.count_nonzero(np.abs(values) >= bound) / values.size
        assert at_limit_fraction(values, limit) == expected


def test_convergence_tolerance_per_state_in_its_unit() -> None:
    """3 cm of position error and 0.08 rad of heading error never converge
    under one 0.05 threshold; they do under 0.05 m and 0.1 rad."""
    errors = {
        "x": np.full(10, 0.03),
        "y": np.full(10, -0.03),
        "theta": np.array([0.3, 0.2, *[0.08] * 8]),
    }
    assert convergence_index(errors) is None
    assert convergence_index(errors, {"x": 0.05, "y": 0.05, "theta": 0.1}) == 2


def test_overshoot_is_relative_to_a_floor_not_to_a_vanishing_start() -> None:
    """From 1 mm to -45.5 mm: 45.5 times the start, 0.91 of a 0.05 floor."""
    error = np.array([0.001, -0.0455, 0.0])
    assert overshoot(error) == pytest.approx(45.5)
    assert overshoot(error, floor=0.05) == pytest.approx(0.91)
    # a start above the floor is its own scale
    assert overshoot(np.array([-1.0, 0.2]), floor=0.05) == pytest.approx(0.2)
    summary = summarize(circle_run(theta_error=np.r_[0.001, -0.0455, np.zeros(1999)]))
    assert summary["estimation_overshoot"]["theta"] == pytest.approx(0.91)


def _mission(expect: dict[str, Any], **phases: dict[str, Any]) -> dict[str, Any]:
    return {
        "expect": expect,
        "phases": [
            {"name": name, "expect": phases.get(name, {})} for name in ("approach", "orbit", "park")
        ],
    }


def _chattering_orbit() -> RunResult:
    """circle_run with omega at +-20 rad/s (its limit) on 100 samples of the
    orbit after its first second: 10 % of them."""
    run = circle_run()
    run.omega = run.omega.copy()
    run.omega[700:800] = 20.0 * (-1.0) ** np.arange(100)
    return run


def test_input_at_a_limit_is_measured_after_the_settle_time() -> None:
    orbit = summarize(_chattering_orbit())["phases"][1]["inputs"]
    assert orbit["turn_rate_at_limit"] == pytest.approx(100 / 900)
    assert orbit["speed_at_limit"] == 0.0
    # the input quality is judged over the whole phase: 99 reversals within one
    # second (the 100th, back to +0.5, comes a second after the first), jumps of
    # twice the limit, and a second at the limit both ways: a fight. A second of
    # chatter is too short to move the robust jitter.
    assert orbit["turn_rate_reversals"] == 99
    assert orbit["turn_rate_jump_max"] == pytest.approx(40.0)
    assert orbit["turn_rate_fight_time"] == pytest.approx(1.0)
    assert orbit["turn_rate_jitter"] == pytest.approx(0.0, abs=1e-12)
    # the same chatter inside the first second is the entry transient
    run = circle_run()
    run.omega = run.omega.copy()
    run.omega[510:590] = 20.0
    assert summarize(run)["phases"][1]["inputs"]["turn_rate_at_limit"] == 0.0


def test_a_phase_threshold_overrides_the_missions() -> None:
    run = _chattering_orbit()
    mission = _mission({"settle_time": 1.0, "turn_rate_at_limit": {"max": 0.01}})
    checks = check_expectations(summarize(run, mission), mission)
    assert [(c.phase, c.metric, c.met) for c in checks] == [
        ("approach", "turn_rate_at_limit", True),
        ("orbit", "turn_rate_at_limit", False),
        ("park", "turn_rate_at_limit", True),
    ]
    relaxed = _mission(
        {"settle_time": 1.0, "turn_rate_at_limit": {"max": 0.01}},
        orbit={"turn_rate_at_limit": {"max": 0.2}, "settle_time": None},
    )
    checks = check_expectations(summarize(run, relaxed), relaxed)
    assert [c.met for c in checks] == [True, True, True]
    assert checks[1].bound == 0.2


def test_phase_checks_apply_where_they_mean_something() -> None:
    """Tracking thresholds only on track phases; none on a phase no longer than
    its settle time; estimation RMS per state."""
    mission = _mission(
        {
            "settle_time": 1.0,
            "tracking_error_max": {"max": 0.1},
            "estimation_rms": {"x": 1e-3, "y": None, "theta": 0.01},
        },
        approach={"settle_time": 6.0},  # longer than the 5 s phase
    )
    checks = check_expectations(summarize(circle_run(), mission), mission)
    assert [(c.phase, c.metric, c.met) for c in checks] == [
        ("orbit", "tracking_error_max", True),
        ("orbit", "estimation_rms.x", True),
        ("orbit", "estimation_rms.theta", True),
        ("park", "estimation_rms.x", True),
        ("park", "estimation_rms.theta", True),
    ]


def test_judge_turns_a_success_that_misses_a_threshold_into_expect_failed() -> None:
    mission = _mission({"settle_time": 1.0, "turn_rate_at_limit": {"max": 0.01}})
    run = _chattering_orbit()
    summary = judge(run, mission)
    assert run.outcome is Outcome.expect_failed
    assert summary["outcome"] == "expect-failed"
    assert run.message == ("expectation not met: orbit: turn_rate_at_limit = 0.111111 (max 0.01)")
    assert summary["expectations"][1]["met"] is False
    # a clean run stays a success; a divergence keeps its own outcome
    clean = circle_run()
    assert judge(clean, mission)["outcome"] == "success"
    diverged = dataclasses.replace(_chattering_orbit(), outcome=Outcome.diverged, message="x")
    assert judge(diverged, mission)["outcome"] == "diverged"


def test_a_phase_in_a_repeat_keeps_its_thresholds_on_every_lap() -> None:
    """A repeated phase runs as name#lap; its own expect applies to each lap."""
    run = _chattering_orbit()
    run.phases = [run.phases[0], dataclasses.replace(run.phases[1], name="orbit#1"), run.phases[2]]
    run.transitions = [_renamed(tr, "orbit", "orbit#1") for tr in run.transitions]
    mission = {
        "expect": {"settle_time": 1.0, "turn_rate_at_limit": {"max": 0.01}},
        "phases": [
            {"name": "approach", "expect": {}},
            {
                "name": "patrol",
                "repeat": {
                    "times": 1,
                    "phases": [{"name": "orbit", "expect": {"turn_rate_at_limit": {"max": 0.2}}}],
                },
            },
            {"name": "park", "expect": {}},
        ],
    }
    checks = check_expectations(summarize(run, mission), mission)
    assert [(c.phase, c.bound, c.met) for c in checks] == [
        ("approach", 0.01, True),
        ("orbit#1", 0.2, True),
        ("park", 0.01, True),
    ]
