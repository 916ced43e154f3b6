"""A campaign checks and plans its mission once, and writes each run's drawn
heading and initial estimate into the plan (wmr_mission.campaign.written):
each run's row must be the one the run gives checked and planned whole, and
a value the field's rule refuses must be refused with the same reason."""

from __future__ import annotations

import math
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path
from typing import Any, Literal

import pytest
from pydantic import Field

from wmr_mission.campaign import checked, rows, written
from wmr_mission.campaign.load import LoadedCampaign, load_campaign
from wmr_mission.campaign.plan import Draw, Plan
from wmr_mission.campaign.rows import INVALID, Row, mission_of, run_row
from wmr_mission.campaign.written import KEPT_SAMPLES, Written
from wmr_mission.geometry.paths import PATHS, line
from wmr_mission.geometry.paths.expression import ExpressionTrajectory
from wmr_mission.geometry.paths.registry import PathType
from wmr_mission.sim import runner
from wmr_mission.sim.plan import MissionPlan
from wmr_mission.sim.runner import run_mission

ROOT = Path(__file__).resolve().parents[1]
CAMPAIGNS = ROOT / "missions" / "campaigns"
SHORT = ROOT / "tests" / "data" / "campaigns" / "short.yaml"


def _campaign(
    tmp_path: Path, vary: str, *, mission: Path = SHORT, runs: int = 4, seed: int = 3
) -> LoadedCampaign:
    """A campaign of ``mission`` varying ``vary`` (its YAML lines), loaded."""
    path = tmp_path / "c.yaml"
    path.write_text(
        f"version: 1\nname: h\nmission: {mission}\nruns: {runs}\nseed: {seed}\nvary:\n{vary}",
        encoding="utf-8",
    )
    return load_campaign(path)


def _short_with(tmp_path: Path, phase: str, *, after: str = "phases:\n") -> Path:
    """short.yaml with ``phase`` (its YAML lines) written in after ``after``."""
    mission = tmp_path / "m.yaml"
    mission.write_text(
        SHORT.read_text(encoding="utf-8").replace(after, after + phase), encoding="utf-8"
    )
    return mission


def _written_plans(loaded: LoadedCampaign, runs: list[int], mine: Written) -> list[MissionPlan]:
    """Each run's plan as ``mine`` writes it, checked against the plan made whole."""
    whole, plan = _whole(loaded), Plan(loaded.campaign)
    plans = []
    for run in runs:
        a, b = mine.run(plan.draw(run))[0], whole.run(plan.draw(run))[0]
        assert a is not None
        assert b is not None
        _same_plan(a, b)
        plans.append(a)
    return plans


def _whole(loaded: LoadedCampaign) -> Written:
    """Every run checked and planned whole, as before the runs were written."""
    runs = Written(loaded)
    runs.writes = False
    return runs


def _same(a: Row, b: Row) -> None:
    assert a.cells() == b.cells()
    assert a.path_xy.tobytes() == b.path_xy.tobytes()
    assert (a.fired, a.missed, a.margin_metric) == (b.fired, b.missed, b.margin_metric)


def _same_plan(a: MissionPlan, b: MissionPlan) -> None:
    """What a written run changes in the plan, and what it must not."""
    assert a.initial_state.tobytes() == b.initial_state.tobytes()
    assert a.initial_estimate.tobytes() == b.initial_estimate.tobytes()
    assert (a.seed, a.max_samples, a.name, len(a.phases)) == (
        b.seed,
        b.max_samples,
        b.name,
        len(b.phases),
    )
    assert a.plant.runaway_position == b.plant.runaway_position
    assert a.plant.constraint_margin == b.plant.constraint_margin
    assert a.plant.limits.tobytes() == b.plant.limits.tobytes()
    assert a.noise_std.tobytes() == b.noise_std.tobytes()
    assert [p.target for p in a.phases] == [p.target for p in b.phases]


def _rows(
    loaded: LoadedCampaign, runs: list[int], how: Written, monkeypatch: pytest.MonkeyPatch
) -> list[Row]:
    monkeypatch.setattr(rows, "written_runs", lambda _: how)  # the name run_row calls
    plan = Plan(loaded.campaign)
    return [run_row(loaded, plan.draw(run)) for run in runs]


# Runs of each shipped campaign: a few, and for the campaigns of many runs
# ones that meet every value of the discrete axes (a base each).
SAMPLED = {
    "case1-dt.yaml": [2, 7],
    "case2-headings.yaml": list(range(12)),
    "controllers.yaml": [0, 31, 62, 95, 140, 170],
    "estimators-disturbances.yaml": [0, 21, 45, 70],
    "estimators-noise.yaml": [0, 1, 25, 130, 190],
    "patrol-detour-ponds.yaml": [0, 1, 2],
}


@pytest.mark.parametrize("name", sorted(SAMPLED))
def test_a_written_run_gives_the_row_of_the_run_checked_and_planned_whole(
    name: str, monkeypatch: pytest.MonkeyPatch
) -> None:
    loaded = load_campaign(CAMPAIGNS / name)
    runs = SAMPLED[name]
    plan, mine, whole = Plan(loaded.campaign), Written(loaded), _whole(loaded)
    for run in runs:
        (a, record_a, _), (b, record_b, _) = mine.run(plan.draw(run)), whole.run(plan.draw(run))
        assert a is not None
        assert b is not None
        _same_plan(a, b)
        assert record_a == record_b
    before = _rows(loaded, runs, _whole(loaded), monkeypatch)
    after = _rows(loaded, runs, Written(loaded), monkeypatch)
    for old, new in zip(before, after, strict=True):
        _same(old, new)


def test_case2_checks_and_plans_once_per_noise_level(monkeypatch: pytest.MonkeyPatch) -> None:
    """Twelve runs of case2-headings meet its three noise levels: three
    missions checked and planned, the other runs written."""
    made = []
    real = checked.mission_of

    def counted(loaded: LoadedCampaign, draw: Draw) -> tuple[object, str]:
        made.append(draw.run)
        return real(loaded, draw)

    monkeypatch.setattr(checked, "mission_of", counted)
    loaded = load_campaign(CAMPAIGNS / "case2-headings.yaml")
    runs = Written(loaded)
    assert runs.writes
    plan = Plan(loaded.campaign)
    noise = {str(plan.draw(run).values["sensors.noise_std"]) for run in range(12)}
    for run in range(12):
        assert runs.run(plan.draw(run))[0] is not None
    assert len(runs.bases) == len(noise) == 3
    assert len(made) == 3


@pytest.mark.parametrize("value", [2e9, -2e9, math.inf, math.nan])
def test_a_value_the_field_refuses_is_refused_with_the_reason_of_the_whole_check(
    tmp_path: Path, value: float
) -> None:
    loaded = _campaign(
        tmp_path,
        "  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n"
        "  estimator.initial_estimate.x: {uniform: [-1.0, 1.0]}\n",
    )
    runs = Written(loaded)
    draw = Plan(loaded.campaign).draw(1)
    assert runs.run(draw)[0] is not None  # the base, made
    drawn = Draw(2, draw.seed, {**draw.values, "estimator.initial_estimate.x": value})
    plan, record, reason = runs.run(drawn)
    _, expected = mission_of(loaded, drawn)
    assert plan is None
    assert record == {}
    assert reason == expected != ""
    assert run_row(loaded, drawn).outcome == INVALID


def test_an_estimate_left_to_the_start_pose_follows_the_written_heading(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A mission without an initial estimate starts its estimate at the start
    pose: a written heading is the estimate's too, as planning whole gives."""
    text = SHORT.read_text(encoding="utf-8")
    mission = tmp_path / "m.yaml"
    mission.write_text(text.replace("  initial_estimate: {x: -1, y: 0.5, theta: 0.5}\n", ""))
    theta = "  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n"
    loaded = _campaign(tmp_path, theta, mission=mission, runs=3, seed=5)
    runs = Written(loaded)
    plan = Plan(loaded.campaign)
    for run in range(3):
        draw = plan.draw(run)
        planned = runs.run(draw)[0]
        assert planned is not None
        theta = draw.values["robot.initial_state.theta"]
        assert planned.initial_state[2] == planned.initial_estimate[2] == theta
    assert len(runs.bases) == 1
    before = _rows(loaded, [0, 1, 2], _whole(loaded), monkeypatch)
    after = _rows(loaded, [0, 1, 2], Written(loaded), monkeypatch)
    for old, new in zip(before, after, strict=True):
        _same(old, new)


def test_the_runaway_bound_follows_the_written_estimate(tmp_path: Path) -> None:
    """Where the initial estimate is the farthest coordinate the mission names,
    the run's runaway bound is set by it (sim.plan's extent), run by run."""
    loaded = _campaign(tmp_path, "  estimator.initial_estimate.x: {uniform: [4.0, 9.0]}\n")
    plans = _written_plans(loaded, list(range(4)), Written(loaded))
    assert len({p.plant.runaway_position for p in plans}) == 4


def test_a_heading_that_a_return_home_reads_is_planned_whole(tmp_path: Path) -> None:
    """`return-home` regulates to the initial pose: a drawn heading is its
    target's, so the runs of such a mission are planned whole."""
    mission = tmp_path / "m.yaml"
    mission.write_text(SHORT.read_text(encoding="utf-8") + "on_failure: return-home\n")
    loaded = _campaign(
        tmp_path, "  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n", mission=mission, runs=3
    )
    mine, plan = Written(loaded), Plan(loaded.campaign)
    for run, written_plan in enumerate(_written_plans(loaded, [0, 1, 2], mine)):
        theta = plan.draw(run).values["robot.initial_state.theta"]
        assert written_plan.phases[-1].target == (-1.0, 0.5, theta)  # home
    assert list(mine.bases.values()) == [None]


def test_a_process_keeps_the_last_used_bases_only(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A grid of many cells: the bases kept are bounded (MAX_BASES), the last
    used; a cell that comes back is planned again, and its runs stay right."""
    monkeypatch.setattr(written, "MAX_BASES", 2)
    loaded = _campaign(
        tmp_path,
        "  robot.limits.v: {grid: [1.0, 1.5, 2.0]}\n"
        "  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n",
        runs=2,
    )
    mine = Written(loaded)
    for run in (0, 1, 2, 4, 5, 0, 3):  # cells 0, 0, 1, 2, 2, 0 (made again), 1
        (a,) = _written_plans(loaded, [run], mine)
        assert a.plant.limits[0] == [1.0, 1.5, 2.0][run // 2]
        assert len(mine.bases) <= 2
    assert list(mine.bases) == [("1.0",), ("1.5",)]


def test_each_thread_keeps_its_own_runs(tmp_path: Path) -> None:
    """A Dask worker runs tasks on several threads: each has its own bases,
    and a process keeps one campaign's runs at a time, per thread."""
    loaded = load_campaign(CAMPAIGNS / "case2-headings.yaml")
    mine = written.written_runs(loaded)
    assert written.written_runs(loaded) is mine
    with ThreadPoolExecutor(1) as thread:
        theirs = thread.submit(written.written_runs, loaded).result()
    assert theirs is not mine
    other = load_campaign(CAMPAIGNS / "case1-dt.yaml")
    assert written.written_runs(other) is not mine
    assert written.written_runs(loaded) is not mine  # one campaign kept at a time


def test_a_heading_that_a_sampling_check_reads_is_checked_whole(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A line path without a heading of its own, tracked first, starts along
    the robot's heading, and the sampling checks read it
    (wmr_mission.spec.checks.read_by_sampling_checks): such runs are checked
    and planned whole, and give the rows of runs checked whole."""
    mission = _short_with(
        tmp_path,
        "  - name: out\n    track: {path: {type: line, towards: [1, 0.5], speed: 0.2}}\n"
        "    until: {elapsed: 1}\n",
    )
    theta = "  robot.initial_state.theta: {uniform: [-0.5, 0.5]}\n"
    loaded = _campaign(tmp_path, theta, mission=mission, runs=3)
    mine = Written(loaded)
    assert mine.writes
    _written_plans(loaded, [0, 1, 2], mine)
    assert list(mine.bases.values()) == [None]
    before = _rows(loaded, [0, 1, 2], _whole(loaded), monkeypatch)
    after = _rows(loaded, [0, 1, 2], Written(loaded), monkeypatch)
    for old, new in zip(before, after, strict=True):
        _same(old, new)


def test_the_paths_start_is_found_once_per_base(monkeypatch: pytest.MonkeyPatch) -> None:
    """Twelve runs of case2-headings, three bases: the paths' first points
    (sim.plan.start_extent) found once per base, the runaway bound of each
    run still the one planned whole."""
    calls = []
    real = written.start_extent

    def counted(*args: Any) -> float:
        calls.append(args)
        return real(*args)

    monkeypatch.setattr(written, "start_extent", counted)
    loaded = load_campaign(CAMPAIGNS / "case2-headings.yaml")
    mine = Written(loaded)
    _written_plans(loaded, list(range(12)), mine)
    assert len(calls) == len(mine.bases) == 3


def _turned_start(path: Any, context: Any, pose: tuple[float, float, float]) -> Any:
    """A path whose first point is 20 m from the robot along its heading."""
    x, y, theta = pose
    return line.LineTrajectory(x + 20 * math.cos(theta), y + 20 * math.sin(theta), theta, 0.1)


def test_a_path_whose_start_turns_with_the_heading_is_placed_run_by_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A path type not built in may start where the start heading points: its
    first point, which sets the runaway bound, is found for each run."""

    class TurnedPath(line.LinePath):
        type: Literal["turned"] = Field(description="Path kind.")  # type: ignore[assignment]

    PATHS.register(PathType(TurnedPath, _turned_start))
    try:
        mission = _short_with(
            tmp_path,
            "  - name: out\n    track: {path: {type: turned, heading: 0, speed: 0.1}}\n"
            "    until: {elapsed: 0.1}\n",
        )
        theta = "  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n"
        loaded = _campaign(tmp_path, theta, mission=mission, runs=4)
        mine = Written(loaded)
        plans = _written_plans(loaded, list(range(4)), mine)
        assert [base is not None for base in mine.bases.values()] == [True]
        assert len({p.plant.runaway_position for p in plans}) == 4
    finally:
        PATHS.unregister("turned")


def test_an_expression_path_as_written_is_sampled_once_per_base(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """case2-headings' spiral is an expression path as written: the same curve
    for every run, sampled for the first run of each base and kept; its runs'
    rows are those of runs planned whole (the first test)."""
    sampled = []
    real = ExpressionTrajectory.sample

    def counted(self: ExpressionTrajectory, t: Any) -> Any:
        sampled.append(len(t))
        return real(self, t)

    monkeypatch.setattr(ExpressionTrajectory, "sample", counted)
    loaded = load_campaign(CAMPAIGNS / "case2-headings.yaml")
    mine, plan = Written(loaded), Plan(loaded.campaign)
    runs = [mine.run(plan.draw(run))[0] for run in range(12)]
    sampled.clear()  # the paths' first points, once per base (start_extent)
    for planned in runs:
        assert planned is not None
        run_mission(planned)
    per_run = len(sampled)
    assert 0 < per_run <= 3 * 3  # a base's chunks: once for its first run
    for planned in runs[:3]:
        assert planned is not None
        run_mission(planned)
    assert len(sampled) == per_run  # kept


def test_a_run_sampling_its_path_in_more_chunks_than_are_kept_finds_the_first_kept(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The spiral of case2-headings cut into chunks of 4 samples: more than
    KEPT_SAMPLES samplings a run, asked for in the same order by every run of
    the base. The first KEPT_SAMPLES are kept, so each run after the first
    samples that many fewer (kept last in, first out, it sampled them all
    again: each pushed out the one the run asked for next)."""
    sampled = []
    real = ExpressionTrajectory.sample

    def counted(self: ExpressionTrajectory, t: Any) -> Any:
        sampled.append(len(t))
        return real(self, t)

    monkeypatch.setattr(ExpressionTrajectory, "sample", counted)
    monkeypatch.setattr(runner, "FIRST_CHUNK", 4)
    monkeypatch.setattr(runner, "CHUNK", 4)
    loaded = load_campaign(CAMPAIGNS / "case2-headings.yaml")
    mine, plan = Written(loaded), Plan(loaded.campaign)
    planned = mine.run(plan.draw(0))[0]
    assert planned is not None
    counts = []
    for _ in range(3):
        sampled.clear()
        run_mission(planned)
        counts.append(len(sampled))
    assert counts[0] > 2 * KEPT_SAMPLES
    assert counts[1:] == [counts[0] - KEPT_SAMPLES] * 2


def test_an_expression_path_from_the_robot_is_sampled_by_each_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """An expression path with `start: current` moves with the pose its phase
    starts from (here where each run's park ended): not kept, each run's own."""
    mission = _short_with(
        tmp_path,
        "  - name: out\n    track: {path: {type: expression, x: 0.1*t, y: 0, start: current}}\n"
        "    until: {elapsed: 0.5}\n",
        after="    timeout: 20\n",
    )
    loaded = _campaign(
        tmp_path, "  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n", mission=mission
    )
    before = _rows(loaded, [0, 1, 2], _whole(loaded), monkeypatch)
    after = _rows(loaded, [0, 1, 2], Written(loaded), monkeypatch)
    for old, new in zip(before, after, strict=True):
        _same(old, new)
    assert len({row.metrics for row in after}) == 3
