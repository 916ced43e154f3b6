"""`wmr-mission falsify`: the search's box, its determinism, its outputs and
their replay, its exit codes, a stop, and `view` of its directory."""

from __future__ import annotations

import csv
import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from browser import Browser
from conftest import the_tests_package
from test_view import needs_chromium

from wmr_mission.campaign.falsify import DEFAULT_METHOD, METHODS
from wmr_mission.campaign.falsify.command import falsify_campaign, falsify_command
from wmr_mission.campaign.falsify.evaluate import Evaluation
from wmr_mission.campaign.falsify.search import (
    FACE_CANDIDATES,
    MODEL_RUNS,
    STALL,
    GpSearch,
    design,
    design_size,
    make_method,
)
from wmr_mission.campaign.falsify.space import Space
from wmr_mission.campaign.falsify.surrogate import Gp
from wmr_mission.campaign.load import load_campaign
from wmr_mission.campaign.models import Campaign
from wmr_mission.cli import app

DATA = Path(__file__).parent / "data" / "falsify"
PARK = DATA / "park-campaign.yaml"


def _command(campaign: Path, out: Path, *flags: str) -> int:
    from typer.testing import CliRunner

    result = CliRunner().invoke(app, ["falsify", str(campaign), "--out", str(out), *flags])
    return result.exit_code


def _lines(path: Path) -> list[str]:
    return path.read_text(encoding="utf-8").splitlines()


def _with_bound(tmp_path: Path, seconds: float) -> Path:
    """The test campaign with the parking time bounded by ``seconds``."""
    mission = (DATA / "park.yaml").read_text(encoding="utf-8")
    (tmp_path / "park.yaml").write_text(
        mission.replace("duration: {max: 11}", f"duration: {{max: {seconds}}}"), encoding="utf-8"
    )
    campaign = tmp_path / "campaign.yaml"
    campaign.write_text(PARK.read_text(encoding="utf-8"), encoding="utf-8")
    return campaign


# --- the box ------------------------------------------------------------------


def _campaign(vary: dict[str, object]) -> Campaign:
    return Campaign.model_validate(
        {"version": 1, "name": "box", "mission": "m.yaml", "runs": 1, "vary": vary}
    )


def test_a_point_of_the_box_is_a_draw_of_each_axis() -> None:
    space = Space(
        _campaign(
            {
                "a": {"uniform": [-2.0, 2.0]},
                "b": {"normal": [1.0, 0.5]},
                "c": {"choice": ["x", "y", "z"]},
                "d": {"grid": [0.1, 0.2]},
            }
        )
    )
    assert space.lower() == [0.0, 0.0, -0.5, -0.5]
    assert space.upper() == [1.0, 1.0, 2.5, 1.5]
    assert space.discrete() == [2, 3]
    middle = space.values([0.5, 0.5, 1.4, 0.6])
    assert middle == {"a": 0.0, "b": 1.0, "c": "y", "d": 0.2}
    low = space.values([0.0, 0.0, -0.5, -0.5])
    assert low["a"] == -2.0
    assert low["c"] == "x"
    assert low["d"] == 0.1
    assert low["b"] == pytest.approx(1.0 - 4 * 0.5)  # a normal axis is cut at 4 std
    high = space.values([1.0, 1.0, 2.5, 1.5])
    assert high["a"] < 2.0  # a uniform draw stays below hi
    assert high["b"] == pytest.approx(1.0 + 4 * 0.5)
    assert high["c"] == "z"
    assert high["d"] == 0.2


def test_random_points_are_the_campaigns_own_draws() -> None:
    """Uniform points of the box: a normal axis's values are normal, each choice
    equally likely, so a share of the box is a probability under the campaign."""
    space = Space(_campaign({"b": {"normal": [1.0, 0.5]}, "c": {"choice": [1, 2, 3, 4]}}))
    method = make_method("random", space, 7)
    values = [space.values(p) for _ in range(200) for p in method.ask()]
    normal = np.array([v["b"] for v in values])
    assert abs(normal.mean() - 1.0) < 0.03
    assert abs(normal.std() - 0.5) < 0.03
    counts = np.bincount([v["c"] for v in values], minlength=5)[1:]
    assert counts.min() > 0.9 * len(values) / 4


def test_cmaes_asks_the_same_points_whatever_else_draws_from_numpy() -> None:
    space = Space(_campaign({"a": {"uniform": [0.0, 1.0]}, "c": {"choice": [1, 2, 3]}}))

    def points(disturb: bool) -> list[list[float]]:
        method = make_method("cmaes", space, 3)
        asked = []
        for _ in range(4):
            batch = method.ask()
            if disturb:
                np.random.seed(99)
                np.random.rand(1000)  # a run in this process drawing from numpy's global generator
            method.tell(batch, [p[0] for p in batch])
            asked += batch
        return asked

    assert points(False) == points(True)
    assert all(p[1] == round(p[1]) for p in points(False))  # a choice's index is an integer


def test_the_design_is_seeded_and_fills_the_box() -> None:
    """A scrambled Sobol batch: each continuous axis's cells of 1/n hold one
    point each, a choice takes each of its values, and the seed fixes the points."""
    space = Space(_campaign({"a": {"uniform": [0.0, 1.0]}, "b": {"normal": [0.0, 1.0]},
                             "c": {"choice": [1, 2, 3, 4]}}))  # fmt: skip
    size = design_size(space.dimension)
    assert size == 16  # 4 a coordinate, a power of 2

    def points(seed: int) -> list[list[float]]:
        return design(space, size, np.random.default_rng(seed))

    first = points(1)
    assert first == points(1)
    assert first != points(2)
    for axis in (0, 1):
        assert sorted(math.floor(p[axis] * size) for p in first) == list(range(size))
    assert sorted({p[2] for p in first}) == [0.0, 1.0, 2.0, 3.0]
    assert [p[2] for p in first].count(0.0) == size // 4


def test_cmaes_first_asks_the_corners_of_the_box_then_the_design() -> None:
    """Each axis at its ends (a choice at its first and last value), the first
    axis slowest, before the Sobol design; none beyond 5 axes (64 corners)."""
    space = Space(_campaign({"a": {"uniform": [2.0, 3.0]}, "c": {"choice": [1, 2, 3]}}))
    method = make_method("cmaes", space, 0)
    first = method.ask()
    assert len(first) == 4 + design_size(2)
    ends = [(v["a"], v["c"]) for v in map(space.values, first[:4])]
    top = math.nextafter(3.0, 2.0)  # a uniform axis stays below its hi, as a draw does
    assert ends == [(2.0, 1), (2.0, 3), (top, 1), (top, 3)]
    assert sorted(math.floor(p[0] * 8) for p in first[4:]) == list(range(8))  # the design
    assert method.settings()["corners"] == 4
    six = Space(_campaign({k: {"uniform": [0.0, 1.0]} for k in "abcdef"}))
    assert len(make_method("cmaes", six, 0).ask()) == design_size(6) == 32


def test_cmaes_starts_with_the_design_and_then_searches_about_its_best_point() -> None:
    """About the design's best point, never a corner, even one that margins lower:
    from a corner most of a generation would lie beyond the box."""
    space = Space(_campaign({"a": {"uniform": [0.0, 1.0]}, "b": {"uniform": [0.0, 1.0]}}))
    method = make_method("cmaes", space, 0)
    first = method.ask()
    assert len(first) == 4 + design_size(2) == 12
    target = [0.5, 0.5]
    method.tell(first, [-1.0] * 4 + [math.dist(p, target) for p in first[4:]])
    best = min(first[4:], key=lambda p: math.dist(p, target))
    second = method.ask()
    assert len(second) == method.settings()["popsize"] == 6
    mean = np.mean(second, axis=0).tolist()
    assert math.dist(mean, best) < 0.3
    assert min(math.dist(mean, corner) for corner in first[:4]) > 0.4


def test_cmaes_reaches_a_corner_of_the_box_exactly() -> None:
    """Points beyond the box run at its nearest point: a margin lowest at a
    corner is run at the corner itself, not only near it."""
    space = Space(_campaign({"a": {"uniform": [2.0, 3.0]}, "b": {"uniform": [-1.0, 1.0]}}))
    method = make_method("cmaes", space, 4)
    reached = False
    for _ in range(12):
        batch = method.ask()
        values = [space.values(p) for p in batch]
        reached = reached or any(v["a"] == 2.0 and v["b"] == -1.0 for v in values)
        method.tell(batch, [v["a"] + v["b"] for v in values])
    assert reached


def test_cmaes_starts_again_when_its_best_margin_stops_falling() -> None:
    """Margins that never fall below the first generation's (a basin that does
    not fail, its runs' noise keeping them apart) restart the search after STALL
    generations: from a new design (no corners again), with twice the population."""
    space = Space(_campaign({"a": {"uniform": [0.0, 1.0]}, "b": {"uniform": [0.0, 1.0]}}))
    method = make_method("cmaes", space, 2)
    design_points = method.ask()
    method.tell(design_points, [1.0] * len(design_points))
    first_popsize = method.settings()["popsize"]
    generations = 0
    while True:
        batch = method.ask()
        if method.settings()["restarts"]:
            break
        generations += 1
        method.tell(batch, [1.0 + generations + 0.01 * i for i in range(len(batch))])
    assert generations == STALL + 1
    assert len(batch) == design_size(2)
    assert all(0 < x < 1 for p in batch for x in p)  # Sobol points, not the corners
    method.tell(batch, [math.dist(p, [0.3, 0.6]) for p in batch])
    assert len(method.ask()) == method.settings()["popsize"] == 2 * first_popsize


def _disc(point: list[float]) -> float:
    """A margin falling towards (0.3, 0.7), below 0 only within 0.04 of it:
    0.5 % of the unit box."""
    return (math.dist(point, [0.3, 0.7]) - 0.04) / 0.5


def test_gp_finds_a_small_failing_disc_soon_and_the_same_way_for_a_seed() -> None:
    """The corners, then the model's most likely failures, two a batch: the disc
    is found within 30 runs on every seed of 5 (uniform draws would need about
    140 for a chance of a half), the same points for a seed whatever else draws
    from numpy's global generator."""
    space = Space(_campaign({"a": {"uniform": [0.0, 1.0]}, "b": {"uniform": [0.0, 1.0]}}))

    def search(seed: int, disturb: bool = False) -> list[list[float]]:
        method = make_method("gp", space, seed)
        asked: list[list[float]] = []
        while len(asked) < 30 and not any(_disc(p) < 0 for p in asked):
            batch = method.ask()
            if disturb:
                np.random.seed(99)
                np.random.rand(1000)
            method.tell(batch, [_disc(p) for p in batch])
            asked += batch
        return asked

    opening = make_method("gp", space, 0).ask()
    assert opening == [[0.0, 0.0], [0.0, 1.0], [1.0, 0.0], [1.0, 1.0]]  # no design besides
    first = search(0)
    assert first == search(0, disturb=True)
    assert first != search(1)
    for seed in range(5):
        assert any(_disc(p) < 0 for p in search(seed)), seed


def test_gp_hands_over_to_cmaes_about_its_lowest_run() -> None:
    """After MODEL_RUNS of the model's runs, CMA-ES searches about the lowest run
    so far, with cma's population, and no corners again."""
    space = Space(_campaign({"a": {"uniform": [0.0, 1.0]}, "b": {"uniform": [0.0, 1.0]}}))
    method = make_method("gp", space, 3)
    told: list[tuple[list[float], float]] = []
    while len(told) < 4 + MODEL_RUNS:
        batch = method.ask()
        assert len(batch) == (4 if not told else 2)
        margins = [1.0 + math.dist(p, [0.9, 0.1]) for p in batch]  # never fails
        method.tell(batch, margins)
        told += zip(batch, margins, strict=True)
    lowest = min(told, key=lambda pair: pair[1])[0]
    generation = method.ask()
    assert len(generation) == 6 == method.settings()["cmaes"]["popsize"]
    assert math.dist(np.mean(generation, axis=0).tolist(), lowest) < 0.3


def _corner(point: list[float]) -> float:
    """A margin below 0 within 0.1 of the box's first corner only."""
    return math.dist(point, [0.0] * len(point)) - 0.1


def test_gp_hands_over_to_cmaes_at_its_first_failure_and_never_runs_a_point_twice() -> None:
    """The first corner fails (as park-corner's does): the model's job is done,
    CMA-ES searches on, and no point runs twice, neither a copy of the failing
    corner (a step clipped to its faces) nor one of CMA-ES's clamped to it."""
    space = Space(_campaign({k: {"uniform": [0.0, 1.0]} for k in "abc"}))
    method = make_method("gp", space, 0)
    asked: list[list[float]] = []
    while len(asked) < 60:
        batch = method.ask()
        if asked:
            assert "cmaes" in method.settings()  # a run failed in the first batch
        method.tell(batch, [_corner(p) for p in batch])
        asked += batch
    ran = [tuple(np.clip(p, 0.0, 1.0)) for p in asked]
    assert ran[0] == (0.0, 0.0, 0.0)
    assert _corner(asked[0]) < 0
    assert len(set(ran)) == len(ran)


def test_the_model_proposes_no_point_of_choices_that_has_run() -> None:
    """Two choices of 3 values, nothing fails: the model proposes each of the 9
    points not yet run (rounded to the values, many candidates are one point),
    then hands over to CMA-ES."""
    space = Space(_campaign({"a": {"choice": [1, 2, 3]}, "b": {"choice": [4, 5, 6]}}))
    method = make_method("gp", space, 0)
    ran = method.ask()
    method.tell(ran, [1.0 + p[0] + p[1] for p in ran])
    proposed: list[tuple[float, ...]] = []
    while "cmaes" not in method.settings():
        batch = method.ask()
        if "cmaes" in method.settings():
            break
        proposed += [tuple(p) for p in batch]
        method.tell(batch, [1.0 + p[0] + p[1] for p in batch])
    assert len(set(proposed)) == len(proposed)
    assert not set(proposed) & {tuple(p) for p in ran}
    assert {tuple(p) for p in ran} | set(proposed) == {
        (float(a), float(b)) for a in range(3) for b in range(3)
    }


def test_the_model_starts_on_the_corners_or_on_a_design_where_there_are_none() -> None:
    """Up to 5 axes the corners are the design; beyond, 64 corners and more would
    outnumber a design of 4 a coordinate, and a Sobol design takes their place."""
    for dimension, opening in ((1, 2), (3, 8), (5, 32), (6, 16)):
        space = Space(_campaign({f"a{i}": {"uniform": [0.0, 1.0]} for i in range(dimension)}))
        assert len(make_method("gp", space, 0).ask()) == opening


def test_the_model_scores_points_on_each_face_of_the_box() -> None:
    """FACE_CANDIDATES points on each face of a continuous axis (at 0 and at 1),
    none for a choice, whose ends are its values."""
    space = Space(_campaign({"a": {"uniform": [0.0, 1.0]}, "b": {"choice": [1, 2, 3]}}))
    method = make_method("gp", space, 0)
    assert isinstance(method, GpSearch)
    faces = method._on_faces()
    assert [face.shape for face in faces] == [(FACE_CANDIDATES, 2)] * 2
    assert np.all(faces[0][:, 0] == 0.0)
    assert np.all(faces[1][:, 0] == 1.0)
    assert np.ptp(faces[0][:, 1]) > 0.9  # spread over the rest of the face


def test_gp_falsifies_estimate_band_within_its_first_runs() -> None:
    """benchmarks/falsification/estimate-band's failing bands reach the faces of
    the largest lateral estimate error: the model, started on the corners and
    scoring points of the faces, runs into them within 10 runs on seeds 0 to 2
    (25, 29 and 27 runs with a design of 4 Sobol points and no faces; uniform
    draws need 43 for a chance of a half)."""
    campaign = BENCHMARKS / "estimate-band-campaign.yaml"
    for seed in range(3):
        found = falsify_campaign(campaign, budget=40, seed=seed, first=True, workers=1)
        assert found.record["runs_to_first_failure"] <= 10, seed


@pytest.mark.parametrize("name", ["gp", "cmaes"])
def test_a_lone_choice_is_searched_past_its_values(name: str) -> None:
    """A campaign of one choice axis of 3 values: all 3 run in the first batches,
    and CMA-ES goes on searching (its integer handling, in one axis, raised an
    IndexError at its first generation)."""
    space = Space(_campaign({"a": {"choice": [1, 2, 3]}}))
    method = make_method(name, space, 0)
    asked: list[list[float]] = []
    while len(asked) < 40:
        batch = method.ask()
        method.tell(batch, [1.0 + abs(p[0] - 0.4) for p in batch])
        asked += batch
    assert {space.values(p)["a"] for p in asked} == {1, 2, 3}
    settings = method.settings()
    assert settings.get("cmaes", settings)["integer_variables"] == []  # CMA-ES ran


def test_the_models_batch_is_as_if_its_first_point_had_run() -> None:
    """The second point of a batch is chosen on the variance of the model refitted
    with the first point at its own mean (the kriging believer), computed without
    refitting: the same variances as the model with that point added."""
    rng = np.random.default_rng(0)
    x = rng.uniform(size=(12, 2))
    y = np.sin(4 * x[:, 0]) + x[:, 1]
    gp = Gp(x, y)
    candidates = rng.uniform(size=(200, 2))
    first, second = gp.most_likely_failures(candidates, 2)
    mean, std = gp.predict(candidates)
    assert first == int(np.argmax(-mean / std))  # the greatest chance of a margin below 0
    believed = Gp(x, y)
    believed.x = np.vstack([x, candidates[first]])
    believed.y = np.append(believed.y, (mean[first] - gp.offset) / gp.spread)
    believed._factor()
    after, after_std = believed.predict(candidates)
    assert np.allclose(after, mean)
    chance = -after / after_std
    chance[first] = -np.inf  # never the same point twice
    assert second == int(np.argmax(chance))


def test_the_model_fits_a_smooth_margin() -> None:
    rng = np.random.default_rng(1)
    x = rng.uniform(size=(30, 2))
    y = np.sin(4 * x[:, 0]) + x[:, 1]
    probe = rng.uniform(0.1, 0.9, size=(50, 2))
    mean, std = Gp(x, y).predict(probe)
    truth = np.sin(4 * probe[:, 0]) + probe[:, 1]
    assert np.max(np.abs(mean - truth)) < 0.1
    assert np.all(std < 0.2)


def test_a_run_the_mission_refuses_or_that_broke_is_never_a_failure() -> None:
    def run(outcome: str, margin: float) -> Evaluation:
        return Evaluation(0, 1, {}, outcome, margin, outcome, margin, "")

    assert not run("invalid", math.inf).falsified
    assert not run("error", math.inf).falsified
    assert run("invalid", math.inf).told() == 1e3  # told as far from failing
    assert run("timeout", -math.inf).falsified
    assert run("timeout", -math.inf).told() == -1e3
    assert run("expect-failed", -0.25).falsified
    assert run("expect-failed", -0.25).told() == -0.25
    assert not run("success", 0.0).falsified  # a value at its bound meets it


# --- determinism ----------------------------------------------------------------


def test_park_corner_runs_44_distinct_points(tmp_path: Path) -> None:
    """benchmarks/falsification/park-corner fails at its first corner, run 0: the
    model ran that point 28 times more, and failing/ held 30 copies of it."""
    campaign = BENCHMARKS / "park-corner-campaign.yaml"
    found = falsify_campaign(campaign, budget=44, workers=1, out=tmp_path, plots=False)
    with (tmp_path / "evaluations.csv").open(encoding="utf-8") as rows:
        axes = [f"robot.initial_state.{k}" for k in ("x", "y", "theta")]
        points = [tuple(row[k] for k in axes) for row in csv.DictReader(rows)]
    assert len(points) == 44 == len(set(points))
    assert found.record["runs_to_first_failure"] == 1
    best = [tuple(b["values"].values()) for b in found.record["best"]]
    assert len(set(best)) == len(best)


def test_the_same_search_gives_the_same_evaluations_on_one_or_two_workers(tmp_path: Path) -> None:
    for workers in (1, 2):
        falsify_campaign(PARK, budget=20, seed=5, workers=workers, out=tmp_path / str(workers))
    one = (tmp_path / "1" / "evaluations.csv").read_bytes()
    assert one == (tmp_path / "2" / "evaluations.csv").read_bytes()
    assert one.count(b"\n") == 21


def test_gp_gives_the_same_evaluations_on_one_or_two_workers_past_its_hand_over(
    tmp_path: Path,
) -> None:
    """The default's three parts (corners and design, the model, CMA-ES) on a
    campaign of two axes whose parking time nothing passes (a failure would
    end the model's part): the same evaluations.csv on 1 and 2 workers."""
    campaign = _with_bound(tmp_path, 60)
    campaign.write_text(
        campaign.read_text(encoding="utf-8").replace(
            "  robot.initial_state.theta: {uniform: [-1.5707963267948966, 1.5707963267948966]}\n",
            "",
        ),
        encoding="utf-8",
    )
    budget = 4 + MODEL_RUNS + 6  # the corners, the model's runs, one CMA-ES generation
    for workers in (1, 2):
        found = falsify_campaign(
            campaign, budget=budget, seed=2, workers=workers, out=tmp_path / str(workers)
        )
        assert found.record["method"] == "gp"
        assert not found.record["falsified"]
        assert found.record["settings"]["cmaes"]["popsize"] == 6
    one = (tmp_path / "1" / "evaluations.csv").read_bytes()
    assert one == (tmp_path / "2" / "evaluations.csv").read_bytes()
    assert one.count(b"\n") == budget + 1


# --- outputs and their replay --------------------------------------------------------


def test_a_failing_mission_replays_byte_for_byte_and_validates_strictly(tmp_path: Path) -> None:
    out = tmp_path / "out"
    assert _command(PARK, out, "--budget", "12", "--seed", "0", "--no-plots") == 1
    record = json.loads((out / "falsify.json").read_text(encoding="utf-8"))
    assert record["falsified"]
    assert record["runs_to_first_failure"] >= 1
    failing = [b for b in record["best"] if "mission" in b]
    assert failing, record["best"]
    best = failing[0]
    mission = out / best["mission"]
    assert mission.is_file()
    assert (
        subprocess.run(
            [sys.executable, "-m", "wmr_mission", "validate", "--strict", str(mission)],
            capture_output=True,
        ).returncode
        == 0
    )
    mine = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "run", str(mission), "--out", str(tmp_path / "a"),
         "--no-plots"], capture_output=True,
    )  # fmt: skip
    assert mine.returncode == 1  # it fails, as the evaluation did
    replay = [*best["replay"].split(), "--out", str(tmp_path / "b"), "--no-plots"]
    assert subprocess.run([sys.executable, "-m", "wmr_mission", *replay[1:]]).returncode == 1
    trajectory = (tmp_path / "a" / "trajectory.csv").read_bytes()
    assert trajectory == (tmp_path / "b" / "trajectory.csv").read_bytes()
    summary = json.loads((tmp_path / "a" / "summary.json").read_text(encoding="utf-8"))
    assert summary["margin"] == best["margin"] < 0  # the run the evaluation was
    rows = list(csv.DictReader(_lines(out / "evaluations.csv")))
    row = rows[best["evaluation"]]
    assert float(row["margin"]) == best["margin"]
    assert row["seed"] == str(best["seed"])


def test_evaluations_csv_has_every_run_its_values_seed_and_margin(tmp_path: Path) -> None:
    result = falsify_campaign(PARK, budget=9, method="random", seed=2, out=tmp_path / "o")
    rows = list(csv.DictReader(_lines(tmp_path / "o" / "evaluations.csv")))
    assert [int(r["evaluation"]) for r in rows] == list(range(9))
    assert list(rows[0])[:6] == [
        "evaluation", "seed", "outcome",
        "robot.initial_state.x", "robot.initial_state.y", "robot.initial_state.theta",
    ]  # fmt: skip
    for row, evaluation in zip(rows, result.evaluations, strict=True):
        assert float(row["robot.initial_state.x"]) == evaluation.values["robot.initial_state.x"]
        assert float(row["margin"]) == evaluation.margin
        assert (float(row["margin"]) < 0) == (row["outcome"] != "success")
    assert result.record["method"] == "random"
    assert result.record["settings"]["budget"] == 9


# --- exit codes and messages ------------------------------------------------------


def test_exit_0_and_the_lowest_margin_when_nothing_fails(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    campaign = _with_bound(tmp_path, 60)
    code = falsify_command(
        campaign, budget=6, method="cmaes", seed=0, objective=None, first=False, workers=1,
        scheduler=None, out=tmp_path / "out", plots=False,
    )  # fmt: skip
    assert code == 0
    printed = capsys.readouterr().out
    assert "no failing run found within the budget of 6 runs" in printed
    record = json.loads((tmp_path / "out" / "falsify.json").read_text(encoding="utf-8"))
    lowest = min(e["objective"] for e in record["best"])
    assert f"lowest margin {lowest:.4g}" in printed
    assert not record["falsified"]
    assert record["runs_to_first_failure"] is None
    assert not (tmp_path / "out" / "failing").exists()


def test_first_stops_after_the_batch_holding_the_first_failure(tmp_path: Path) -> None:
    result = falsify_campaign(PARK, budget=300, method="random", seed=0, first=True)
    first = result.record["runs_to_first_failure"]
    assert first is not None
    assert len(result.evaluations) < 300
    assert first <= len(result.evaluations)
    assert not any(e.falsified for e in result.evaluations[: first - 1])
    assert result.evaluations[first - 1].falsified


def test_objective_names_a_check_and_an_unknown_one_is_a_usage_error(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    result = falsify_campaign(PARK, budget=4, seed=0, objective="duration")
    for evaluation in result.evaluations:  # duration is the only check that can bind here
        assert evaluation.objective == pytest.approx(1 - _duration(evaluation) / 11)
    code = falsify_command(
        PARK, budget=4, method="cmaes", seed=0, objective="park: no_such_metric", first=False,
        workers=1, scheduler=None, out=tmp_path / "out", plots=False,
    )  # fmt: skip
    assert code == 2
    err = capsys.readouterr().err
    assert "--objective park: no_such_metric: the mission has no such check; its checks: " in err
    assert "duration" in err
    assert not (tmp_path / "out").exists()


def test_a_run_that_misses_a_check_besides_the_objective_is_a_failing_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """--objective changes what is minimised, not what fails: the corners park
    in more than 11 s (duration missed) while the objective, the stall time, is
    met everywhere. Those runs are failing runs for the exit code, the report,
    falsify.json, failing/ and view, and each fails when run."""
    from typer.testing import CliRunner

    out = tmp_path / "out"
    code = falsify_command(
        PARK, budget=8, method="gp", seed=0, objective="park: stall_time", first=False,
        workers=1, scheduler=None, out=out, plots=False,
    )  # fmt: skip
    rows = list(csv.DictReader(_lines(out / "evaluations.csv")))
    failed = [int(r["evaluation"]) for r in rows if r["outcome"] != "success"]
    assert failed, rows  # some corner misses its parking time
    assert {r["outcome"] for r in rows if int(r["evaluation"]) in failed} == {"expect-failed"}
    assert all(float(r["objective"]) >= 0 for r in rows)  # the objective is never missed
    assert code == 1
    record = json.loads((out / "falsify.json").read_text(encoding="utf-8"))
    assert record["falsified"]
    assert record["failing_runs"] == len(failed)
    assert record["runs_to_first_failure"] == failed[0] + 1
    assert [f["evaluation"] for f in record["failing"]] == failed
    written = sorted(int(p.stem) for p in (out / "failing").glob("*.yaml"))
    assert written == failed
    printed = capsys.readouterr().out
    assert "no failing run" not in printed
    first = (out / "failing" / f"{failed[0]}.yaml").resolve()
    assert f"falsified: {len(failed)} failing runs, the first run {failed[0]} " in printed
    assert any(
        line.startswith(f"  {failed[0]}: ") and line.endswith(f"wmr-mission run {first}")
        for line in printed.splitlines()
    ), printed
    ran = CliRunner().invoke(app, ["run", str(first), "--out", str(tmp_path / "r"), "--no-plots"])
    assert ran.exit_code == 1, ran.output
    viewed = CliRunner().invoke(app, ["view", str(out)])
    assert viewed.exit_code == 0, viewed.output
    page = (out / "report.html").read_text(encoding="utf-8")
    meta = json.loads(
        page.split('<script type="application/json" id="meta">')[1].split("</script>")[0]
    )
    assert meta["record"]["falsified"]
    assert meta["replays"][failed[0]] == f"wmr-mission run {first}"


def test_the_methods_and_the_default_are_named_once() -> None:
    """The command line, the Python API and falsify_campaign read the names of
    wmr_mission.campaign.falsify: the help lists them, each default is its."""
    import inspect

    from typer.testing import CliRunner

    from wmr_mission import api

    for function in (api.falsify_campaign, falsify_campaign):
        assert inspect.signature(function).parameters["method"].default == DEFAULT_METHOD
    shown = " ".join(CliRunner().invoke(app, ["falsify", "--help"]).output.split())
    assert f"One of {', '.join(METHODS)}. [default: {DEFAULT_METHOD}]" in shown


def _duration(evaluation: Evaluation) -> float:
    return 11 * (1 - evaluation.margin) if evaluation.margin_check == "duration" else math.nan


def test_a_bad_campaign_file_is_told_at_its_line_and_column(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.yaml"
    bad.write_text(
        PARK.read_text(encoding="utf-8").replace("mission: park.yaml", f"mission: {DATA}/park.yaml")
        .replace("{uniform: [-4.0, -1.0]}", "{uniform: [-1.0, -4.0]}"),
        encoding="utf-8",
    )  # fmt: skip
    code = falsify_command(
        bad, budget=4, method="cmaes", seed=0, objective=None, first=False, workers=1,
        scheduler=None, out=tmp_path / "out", plots=False,
    )  # fmt: skip
    assert code == 1
    err = capsys.readouterr().err
    assert err.startswith(f"{bad}:8:")
    assert "lo < hi" in err
    assert not (tmp_path / "out").exists()


def test_usage_errors_exit_2(tmp_path: Path) -> None:
    assert _command(PARK, tmp_path / "a", "--method", "annealing") == 2
    assert _command(PARK, tmp_path / "b", "--budget", "0") == 2
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("taken", encoding="utf-8")
    assert _command(PARK, tmp_path / "full", "--budget", "2") == 2


# --- a stop -------------------------------------------------------------------------


@pytest.mark.parametrize(
    ("number", "code", "name"), [(signal.SIGINT, 130, "Ctrl-C"), (signal.SIGTERM, 143, "SIGTERM")]
)
def test_ctrl_c_keeps_what_was_evaluated(
    tmp_path: Path, number: signal.Signals, code: int, name: str
) -> None:
    out = tmp_path / "out"
    process = subprocess.Popen(
        [sys.executable, "-m", "wmr_mission", "falsify", str(PARK), "--budget", "5000",
         "--method", "random", "--out", str(out), "--workers", "2", "--no-plots"],
        cwd=tmp_path,
        env=the_tests_package(dict(os.environ)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        start_new_session=True,
    )  # fmt: skip
    rows = out / "evaluations.csv"
    deadline = time.monotonic() + 120
    while time.monotonic() < deadline:
        if rows.is_file() and rows.read_bytes().count(b"\n") > 20:
            break
        time.sleep(0.1)
    os.killpg(process.pid, number)  # the whole group, as a shell's Ctrl-C or a kill of the job
    _, stderr = process.communicate(timeout=120)
    assert process.returncode == code, stderr
    assert b"Traceback" not in stderr
    record = json.loads((out / "falsify.json").read_text(encoding="utf-8"))
    written = list(csv.DictReader(_lines(rows)))
    assert record["interrupted"] is True
    assert record["stopped_by"] == name
    assert 20 <= record["evaluations"] == len(written) < 5000
    assert [int(r["evaluation"]) for r in written] == sorted(int(r["evaluation"]) for r in written)
    for failing in record["failing"]:  # each failing run kept is written as a mission
        assert (out / failing["mission"]).is_file()


# --- view ---------------------------------------------------------------------------


def test_a_search_stopped_before_its_first_run_leaves_no_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """As the command does: a retry may use the same ``out``."""
    from wmr_mission.campaign.falsify import command

    def stopped(*_: object) -> None:
        raise KeyboardInterrupt

    monkeypatch.setattr(command, "_warm_up", stopped)
    with pytest.raises(KeyboardInterrupt):
        falsify_campaign(PARK, budget=4, seed=1, out=tmp_path / "out", plots=False)
    assert not (tmp_path / "out").exists()


def test_view_shows_a_falsification_directory(tmp_path: Path) -> None:
    out = tmp_path / "out"
    falsify_campaign(PARK, budget=12, seed=1, out=out, plots=True)
    assert (out / "margins.png").is_file()
    assert (out / "region.png").is_file()
    from typer.testing import CliRunner

    result = CliRunner().invoke(app, ["view", str(out)])
    assert result.exit_code == 0, result.output
    page = (out / "report.html").read_text(encoding="utf-8")
    meta = json.loads(
        page.split('<script type="application/json" id="meta">')[1].split("</script>")[0]
    )
    assert meta["kind"] == "falsification"
    assert meta["record"]["evaluations"] == 12 == meta["total_rows"] == len(meta["rows"])
    assert [f["name"] for f in meta["figures"]] == ["margins.png", "region.png"]
    failing = list(meta["record"]["failing"])
    for entry in failing:  # a failing run's command runs its own mission file
        replay = meta["replays"][entry["evaluation"]]
        assert replay == f"wmr-mission run {(out / entry['mission']).resolve()}"


def test_view_of_a_damaged_falsification_says_which_file_and_line(tmp_path: Path) -> None:
    """FILE:LINE: what is wrong, as for a damaged run or campaign; never an
    internal error."""
    import shutil

    from typer.testing import CliRunner

    out = tmp_path / "out"
    falsify_campaign(PARK, budget=4, seed=1, out=out, plots=False)
    damages = {
        "falsify.json": (lambda text: "{\n,\n}", "falsify.json:2:1: not valid JSON"),
        "manifest.json": (lambda text: "[]", "manifest.json:1:1: not a JSON object"),
        "evaluations.csv": (
            lambda text: text + "7,8\n",
            "evaluations.csv:6: expected ",
        ),
    }
    headers = {  # a header that is not falsify's, and a file of blank lines
        "run,seed\n0,1\n": "evaluations.csv:1: not the header of falsify's evaluations",
        "\n\n": "evaluations.csv:1: not the header of falsify's evaluations",
    }
    for number, (text, said) in enumerate(headers.items()):
        damaged = tmp_path / f"header-{number}"
        shutil.copytree(out, damaged)
        (damaged / "evaluations.csv").write_text(text, encoding="utf-8")
        result = CliRunner().invoke(app, ["view", str(damaged)])
        assert result.exit_code == 1, result.output
        assert result.stderr.startswith(f"{damaged}: {said}"), result.stderr
    for name, (damage, said) in damages.items():
        damaged = tmp_path / f"damaged-{name}"
        shutil.copytree(out, damaged)
        path = damaged / name
        path.write_text(damage(path.read_text(encoding="utf-8")), encoding="utf-8")
        result = CliRunner().invoke(app, ["view", str(damaged)])
        assert result.exit_code == 1, result.output
        assert result.stderr.startswith(f"{damaged}: {said}"), result.stderr
        assert "please report it" not in result.stderr


@needs_chromium
def test_view_of_a_falsification_renders_without_a_console_error(tmp_path: Path) -> None:
    out = tmp_path / "out"
    falsify_campaign(PARK, budget=8, seed=1, out=out, plots=False)
    from wmr_mission.review.view import view_command

    assert view_command(out) == 0
    with Browser() as browser, browser.open(out / "report.html") as page:
        assert page.problems() == []
        assert page.evaluate("document.body.dataset.rendered") == "1"
        assert "falsification (gp)" in page.evaluate("document.querySelector('h1').textContent")
        said = page.evaluate("document.querySelector('p.sub').textContent")
    # the first failing run by its evaluation number, as the command and the table name it
    record = json.loads((out / "falsify.json").read_text(encoding="utf-8"))
    first = min(entry["evaluation"] for entry in record["failing"])
    assert record["runs_to_first_failure"] == first + 1
    runs_in = f"{first + 1} run{'s' if first else ''} in"
    assert f"{record['failing_runs']} failing runs of 8; the first run {first} ({runs_in})" in said


@pytest.mark.sweep
def test_the_same_search_on_dask_as_on_local_workers(tmp_path: Path) -> None:
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True) as cluster:
        falsify_campaign(PARK, budget=40, seed=4, scheduler=cluster.scheduler_address,
                         out=tmp_path / "dask")  # fmt: skip
    falsify_campaign(PARK, budget=40, seed=4, workers=2, out=tmp_path / "local")
    local = (tmp_path / "local" / "evaluations.csv").read_bytes()
    assert local == (tmp_path / "dask" / "evaluations.csv").read_bytes()


def test_loaded_campaign_axes_are_searched_in_campaign_order() -> None:
    space = Space(load_campaign(PARK).campaign)
    assert space.paths == [
        "robot.initial_state.x", "robot.initial_state.y", "robot.initial_state.theta"
    ]  # fmt: skip


@pytest.mark.sweep
def test_cmaes_falsifies_park_corner_on_every_seed_and_sooner_than_random() -> None:
    """benchmarks/falsification/park-corner (0.15 % of its box fails): docs/falsification.md's
    table, on 5 of its 20 seeds."""
    campaign = Path(__file__).parent.parent / "benchmarks" / "falsification"
    campaign = campaign / "park-corner-campaign.yaml"

    def runs(method: str, seed: int) -> int:
        found = falsify_campaign(campaign, budget=300, method=method, seed=seed, first=True)
        first = found.record["runs_to_first_failure"]
        return 301 if first is None else int(first)

    cmaes = [runs("cmaes", seed) for seed in range(5)]
    random = [runs("random", seed) for seed in range(5)]
    assert max(cmaes) <= 300
    assert np.median(cmaes) * 5 <= np.median(random)


@pytest.mark.sweep
@pytest.mark.parametrize(("name", "share"), [("heading-band", 0.0070), ("estimate-band", 0.0164)])
def test_gp_falsifies_a_band_in_a_fifth_of_randoms_runs(name: str, share: float) -> None:
    """The acceptance on the two benchmarks CMA-ES alone missed it on
    (docs/falsification.md's table): every seed of 20 falsified within 300
    runs, the median runs to the first failure at most a fifth of the median
    uniform draws need to reach a region of the stated ``share``,
    ln 2 / -ln(1 - share) (random search's own median over 20 seeds is itself
    noisy: estimate-band's 96.5 is near twice the 42 its share predicts), and
    of random search's median on the same seeds: 11 of 99 and 77, 7 of 42 and
    96.5. estimate-band's was 16, 0.37 of 43, before the model started on the
    corners alone and scored the faces of the box."""
    campaign = BENCHMARKS / f"{name}-campaign.yaml"

    def runs(method: str, seed: int) -> int:
        found = falsify_campaign(
            campaign, budget=300, method=method, seed=seed, first=True, workers=1
        )
        first = found.record["runs_to_first_failure"]
        return 301 if first is None else int(first)

    gp = [runs("gp", seed) for seed in range(20)]
    assert max(gp) <= 300
    assert np.median(gp) * 5 <= math.log(2) / -math.log(1 - share)
    random = [runs("random", seed) for seed in range(20)]
    assert np.median(gp) * 5 <= np.median(random)


BENCHMARKS = Path(__file__).parent.parent / "benchmarks" / "falsification"


@pytest.mark.parametrize(
    ("name", "inside", "outside"),
    [
        # the longest lag with the most negative bias; a short lag, no bias
        ("lag-bias", [1.0, 0.0], [0.0, 0.5]),
        # heading estimate -0.58 rad and lateral +0.44 m, and its mirror; -0.3 rad, +0.44 m
        ("estimate-band", [0.21, 0.94], [0.35, 0.94]),
        ("estimate-band", [0.79, 0.06], [0.5, 0.5]),
        # facing 3.8 rad (south-west) at the fastest path speed; 3.45 rad, the same speed
        ("heading-band", [0.71, 1.0], [0.6, 1.0]),
    ],
)
def test_a_benchmark_fails_inside_its_stated_region_and_holds_beside_it(
    name: str, inside: list[float], outside: list[float]
) -> None:
    """docs/falsification.md's benchmark table: each region is where its bound is
    passed, on every sensor seed (the bounds follow the control: lag-bias's 0.4 m
    failed nowhere once the turn-limit speed and the ramped aim were merged)."""
    from wmr_mission.campaign.falsify.evaluate import evaluate_draws
    from wmr_mission.campaign.falsify.loop import draws_of

    loaded = load_campaign(BENCHMARKS / f"{name}-campaign.yaml")
    space = Space(loaded.campaign)
    for seed in range(3):
        failing, holding = evaluate_draws(loaded, draws_of(space, seed, 0, [inside, outside]), None)
        assert failing.falsified, (seed, failing.objective)
        assert holding.ran
        assert holding.objective > 0.5, (seed, holding.objective)


@pytest.mark.sweep
@pytest.mark.parametrize("name", ["estimate-band", "heading-band", "lag-bias"])
def test_a_benchmark_region_is_at_most_2_percent_of_its_box(name: str) -> None:
    """The share docs/falsification.md states, on its 60 x 60 grid (region.py): at most
    the 2 % the acceptance speaks of (estimate-band's 1.2 m failed 2.39 %)."""
    sys.path.insert(0, str(BENCHMARKS))
    from region import failing_share

    failing, total = failing_share(str(BENCHMARKS / f"{name}-campaign.yaml"), [60], 2)
    assert 0 < failing <= 0.02 * total
