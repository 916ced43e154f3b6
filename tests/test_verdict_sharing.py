"""What the judge computes once and shares gives the bits it gave computed apart:
a track phase's places on its path (its metrics and its formulas), a formula's
value at its first sample, the clearance measured at the points that can set
it; and the judge takes the checked mission as it takes its resolved form."""

from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_temporal import _traces

from wmr_mission.output.result import RunResult
from wmr_mission.sim.plan import plan_mission
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission
from wmr_mission.spec.models import Mission
from wmr_mission.verdicts import tracking, zones
from wmr_mission.verdicts.clearance import clearance_min
from wmr_mission.verdicts.metrics import judge, judge_mission, judge_run_metrics
from wmr_mission.verdicts.temporal import robustness, robustness_at_start
from wmr_mission.verdicts.tracking import Placement
from wmr_mission.verdicts.zones import Zone

MISSIONS = Path(__file__).resolve().parent.parent / "missions"


def _wavering_circle(samples: int, seed: int) -> tuple[np.ndarray, ...]:
    """Positions about a circle's reference points: mostly near their own, some
    far off (a place found along the path, or anywhere on it)."""
    rng = np.random.default_rng(seed)
    angle = np.linspace(0.0, 3.0 * math.pi, samples)  # more than a lap: the path meets itself
    rx, ry = np.cos(angle), np.sin(angle)
    off = rng.normal(scale=0.02, size=(2, samples))
    off[:, rng.random(samples) < 0.1] *= 40.0
    return rx + off[0], ry + off[1], rx, ry


@pytest.mark.parametrize("seed", range(4))
def test_places_found_once_are_those_found_for_each_reader(seed: int) -> None:
    """A placement asked for from a late sample, then from the first (a phase's
    metrics judge from its entry's end, its formulas from its start), gives
    what a placement of its own gives each: each sample is placed alone."""
    px, py, rx, ry = _wavering_circle(3000, seed)
    for first in (0, 7, 1500):
        shared = Placement(px, py, rx, ry)
        late = shared.on_path(0.1, first)
        early = shared.on_path(0.1, 0)
        for near in (0.1, 0.5):  # few positions far from their place, and many
            alone = Placement(px, py, rx, ry).on_path(near, first)
            again = shared.on_path(near, first)
            for ours, theirs in zip(again, alone, strict=True):
                np.testing.assert_array_equal(ours, theirs)
        for ours, theirs in zip(late, Placement(px, py, rx, ry).on_path(0.1, first), strict=True):
            np.testing.assert_array_equal(ours, theirs)
        for ours, theirs in zip(early, Placement(px, py, rx, ry).on_path(0.1, 0), strict=True):
            np.testing.assert_array_equal(ours, theirs)
        assert np.isnan(late[0][:first]).all()
        assert np.isfinite(early[0]).all()


def test_a_formulas_value_is_its_robustness_at_the_first_sample() -> None:
    """Picked over its outermost window alone, to the bit, on 300 generated
    formulas and traces (min and max round nothing)."""
    for node, signals in _traces(300, seed=35):
        at_start = robustness_at_start(node, signals, 1.0, {})
        assert at_start == float(robustness(node, signals, 1.0, {})[0]), node


@pytest.mark.parametrize("keep_inside", [True, False])
def test_the_clearance_to_an_ellipse_is_its_least_over_every_point(
    keep_inside: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Measured only where the distance bounds leave a point in the running (an
    ellipse's exact distance is an iteration), the clearance is the least over
    all of them, exactly."""
    region = {"type": "ellipse", "center": [0.5, -0.2], "semi_axes": [5.5, 3.0], "rotation": 0.3}
    zone = Zone("ellipse", region, keep_inside)
    rng = np.random.default_rng(3)
    measured = []
    to_ellipse = zones._to_ellipse

    def counted(u: np.ndarray, *rest: float) -> np.ndarray:
        measured.append(u.size)
        return to_ellipse(u, *rest)

    for scale in (0.3, 1.0, 3.0):
        x, y = rng.normal(scale=scale * 4.0, size=(2, 2000))
        theta = np.zeros(x.size)
        every = float(np.min(-zone.depth(x, y)))
        monkeypatch.setattr(zones, "_to_ellipse", counted)
        measured.clear()
        assert clearance_min(x, y, theta, [zone], None) == round(every, 6) + 0.0
        monkeypatch.setattr(zones, "_to_ellipse", to_ellipse)
        assert sum(measured) < x.size * 0.7  # not every point


@pytest.fixture(scope="module")
def case2() -> tuple[Mission, RunResult]:
    mission = load_mission(MISSIONS / "case2.yaml")
    return mission, run_mission(plan_mission(mission))


def test_the_judge_takes_the_checked_mission_as_its_resolved_form(
    case2: tuple[Mission, RunResult],
) -> None:
    """A campaign hands the judge the checked mission; a run directory's
    mission is its resolved form: the same verdict, to the bit."""
    mission, result = case2
    dumped = mission.model_dump(mode="json")
    for judged in (judge, judge_run_metrics):
        typed, plain = copy.deepcopy(result), copy.deepcopy(result)
        assert judged(typed, mission) == judged(plain, dumped)
        assert (typed.outcome, typed.message) == (plain.outcome, plain.message)
    assert judge(copy.deepcopy(result), mission)["phases"][1]["temporal"]


def test_a_track_phase_is_placed_on_its_path_once(
    case2: tuple[Mission, RunResult], monkeypatch: pytest.MonkeyPatch
) -> None:
    """case2's orbit has a formula on its cross-track error: its metrics and its
    formula share the places of its samples, each sample placed once."""
    mission, result = case2
    placed: list[int] = []
    place_samples = tracking.Placement._place_samples

    def counted(self: Placement, begin: int, end: int, *columns: Any) -> tuple[int, float, float]:
        placed.append(end - begin)
        return place_samples(self, begin, end, *columns)

    monkeypatch.setattr(tracking.Placement, "_place_samples", counted)
    summary = judge(copy.deepcopy(result), mission)
    orbit = summary["phases"][1]
    assert orbit["name"] == "orbit"
    assert orbit["temporal"]
    samples = round(orbit["duration"] / result.dt)
    assert samples <= sum(placed) <= samples + 2  # not twice over


def test_a_few_points_distances_to_an_ellipse_are_the_arrays(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Up to 8 points are iterated as Python numbers, in step as the arrays
    are: the same roots, to the bit, on 2 000 generated batches (inside, on,
    near and far outside the ellipse)."""
    rng = np.random.default_rng(34)
    for _ in range(2000):
        a, b = sorted(rng.uniform(0.1, 10.0, 2), reverse=True)
        n = int(rng.integers(1, 9))
        angle = rng.uniform(0.0, math.pi / 2, n)
        scale = rng.choice([0.01, 0.5, 1.5, 10.0, 1.0])
        radius = 1.0 + rng.normal(scale=1e-9, size=n) if scale == 1.0 else scale * rng.random(n)
        u = a * radius * np.cos(angle) + 1e-300  # off the axes
        w = b * radius * np.sin(angle) + 1e-300
        few = zones._roots(u, w, a, b)
        with monkeypatch.context() as patched:
            patched.setattr(zones, "_FEW", 0)
            np.testing.assert_array_equal(few, zones._roots(u, w, a, b))


def test_a_campaigns_run_is_judged_with_its_robots_body() -> None:
    """A campaign's run carries no mission of its own (it runs a plan): its
    judge reads the body from the mission it is handed, and gives the
    clearance and the verdict `run` gives (the axle's was 0.53 m where the
    body came within 0.17 m of a pallet, and a failed run counted as a success)."""
    mission = load_mission(MISSIONS / "shelf.yaml")
    assert mission.robot.footprint is not None
    dumped = mission.model_dump(mode="json")
    as_run = judge(copy.deepcopy(run_mission(plan_mission(mission))), dumped)  # a plan's run
    assert as_run["clearance_min"] is not None
    by_run = judge_mission(run_mission(plan_mission(mission)), mission)  # as `run` judges
    row = judge_run_metrics(run_mission(plan_mission(mission)), dumped)  # as a row judges
    assert as_run["clearance_min"] == by_run["clearance_min"] == row["clearance_min"]
    # the body's clearance, not the axle's: smaller by at least the body's half-width
    point = {**dumped, "robot": {**dumped["robot"], "footprint": None}}
    axle = judge(copy.deepcopy(run_mission(plan_mission(mission))), point)
    assert row["clearance_min"] < axle["clearance_min"] - 0.1


def test_a_contingencys_phase_is_judged_by_its_own_expect() -> None:
    """patrol-detour's round-the-pond writes settle_time: 2.0 in its `expect`;
    its judge took the mission's (1 s) and any bound of its own was not
    checked: a contingency's phases were missing from the phases as written."""
    mission = load_mission(MISSIONS / "patrol-detour.yaml")
    dumped = mission.model_dump(mode="json")
    result = run_mission(plan_mission(mission))
    pond = next(p for p in judge(copy.deepcopy(result), dumped)["phases"] if "pond" in p["name"])
    assert pond["settle_time"] == 2.0
    dumped["contingencies"]["detour"]["phases"][0]["expect"]["cross_track_error_max"] = {
        "max": 0.0001
    }
    dumped["contingencies"]["detour"]["phases"][0]["expect"]["temporal"] = ["always(speed <= 0.1)"]
    for judged in (judge, judge_run_metrics):
        summary = judged(copy.deepcopy(result), dumped)
        assert summary["outcome"] == "expect-failed"
        checks = summary.get("expectations") or summary["missed"]
        missed = {(c["phase"], c["metric"]) for c in checks if not c["met"]}
        assert missed == {
            ("round-the-pond", "cross_track_error_max"),
            ("round-the-pond", "always(speed <= 0.1)"),
        }
