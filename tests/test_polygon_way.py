"""A keep-out box or polygon is gone round by one side for the whole pass,
decided once where the path passes nearest it, as an ellipse is
(controllers/constrained_tracking.ways_round, docs/paper-notes.md, eq. (28),
"The way round a box or polygon, decided once")."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from aims import moved_across, spiral_past
from judge_generated import judge_all
from keep_out_shapes import main as write_shapes

from wmr_mission import mission_from_text, run_mission
from wmr_mission.controllers.constrained_tracking import (
    _way_round_eased,
    _way_round_polygon,
    _way_round_polygon_eased,
    aim_round_zones,
    way_at,
    ways_round,
)
from wmr_mission.geometry.regions import (
    BoxRegion,
    CircleRegion,
    PolygonRegion,
    constraint_rows,
)
from wmr_mission.kernels.convex import polygon_distance
from wmr_mission.kernels.corrective import POLYGON_ROW

ROCK = [[-1.6, 0.9], [-1.0, 0.6], [-0.8, 1.3], [-1.3, 1.6]]
ZONES = Path(__file__).resolve().parent / "data" / "zones"


def _spiral(t: np.ndarray) -> np.ndarray:
    """Rows x, y, tx, ty of the spiral r = 0.5 + 0.06 t, at 0.5 rad/s."""
    r = 0.5 + 0.06 * t
    phi = 0.5 * t
    dx = 0.06 * np.cos(phi) - 0.5 * r * np.sin(phi)
    dy = 0.06 * np.sin(phi) + 0.5 * r * np.cos(phi)
    norm = np.hypot(dx, dy)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), dx / norm, dy / norm])


def test_a_spiral_through_a_rock_keeps_one_side_of_it() -> None:
    """The spiral's loop at radius 1.3-1.5 m runs into the rock's corner.
    The shorter way across at each aim swung with the curve's tangent: the
    aim went round the outside, then the inside, then the outside again,
    0.7 m to either side, so it jumped 1.5 m across in one step."""
    path = _spiral(np.linspace(0.0, 30.0, 3001))
    rock = PolygonRegion(type="polygon", vertices=ROCK)
    across = moved_across(path, *constraint_rows(rock, "outside"))
    assert across.max() > 0.5  # round by the inside of the loop, the left
    assert across.min() >= 0.0  # and never the outside
    assert np.abs(np.diff(across)).max() < 0.1  # 0.01 s of path a step: no jump


def test_a_circle_through_a_box_keeps_its_aim_out_of_the_box() -> None:
    """A circle of radius 2.5 m through a box, gone round by the outside: the
    path curves away from the side it goes round by, and the ramp measured on
    the line of the pass left the aim, 0.06 m along its tangent, 0.10 m
    inside the box grown by its margins, from 1 m before the box's middle to
    1 m past it (the robot stood at its corner, 0.81 m off its path,
    gen-025-circle-box of scripts/keep_out_shapes.py)."""
    box = BoxRegion(type="box", center=[-4.186, -3.974], size=[1.544, 0.926], heading=1.766)
    kinds, params = constraint_rows(box, "outside")
    phi = np.linspace(2.097, 4.447, 1001)
    x = -1.721 + 2.486 * np.cos(phi)
    y = -4.255 + 2.486 * np.sin(phi)
    path = np.column_stack([x, y, -np.sin(phi), np.cos(phi)])
    ways = ways_round(x, y, kinds, params)
    look_ahead, margin, gap, lead = 0.05, 0.06, 0.025, 0.06
    clearance = []
    for row in path:
        aim = row.copy()
        aim_round_zones(aim, kinds, params, ways, look_ahead, margin, gap, lead)
        ahead = aim[:2] + (look_ahead + lead) * row[2:]
        clearance.append(polygon_distance(params[0], ahead[0], ahead[1])[0])
    assert ways[0, 4] == -1.0  # by the outside, the right
    assert min(clearance) > look_ahead + margin + gap - 1e-6


SPIRAL = spiral_past(f"{{type: polygon, vertices: {ROCK}}}")


def test_a_spiral_past_a_polygon_rock_succeeds() -> None:
    """End to end: the robot goes round the rock by one side and back onto
    its spiral, without a turn-rate kick. It stood at the rock's corner,
    turned on the spot, and failed on its cross-track error and lag."""
    run = run_mission(mission_from_text(SPIRAL))
    assert run.outcome.value == "success"
    assert np.abs(np.diff(run.omega)).max() < 1.0  # rad/s in one sample
    params = constraint_rows(PolygonRegion(type="polygon", vertices=ROCK), "outside")[1]
    clearance = [polygon_distance(params[0], x, y)[0] for x, y in zip(run.x, run.y, strict=True)]
    assert min(clearance) > 0.05
    off = np.hypot(run.x - run.x_ref, run.y - run.y_ref)[:-1]  # the last sample has no reference
    assert off.max() > 0.3  # the detour
    assert off[run.t[:-1] > 22.0].max() < 0.01  # back on its spiral


def test_a_polygons_climb_is_an_ellipses_and_above_its_ramp() -> None:
    """Under a turn-rate acceleration limit a polygon's aim climbs as an
    ellipse's does: round a 256-gon on a circle its climb is the circle's
    within the gap between the two, and round a box along the path, whose
    face is a plateau, it never falls below the box's ramp, which the robot
    swung past (docs/paper-notes.md, eq. (28), "The way round a box or
    polygon, decided once", The climb under a turn-rate acceleration
    limit)."""
    angles = np.linspace(0.0, 2.0 * np.pi, 256, endpoint=False)
    corners = [[2.0 * np.cos(a), 0.5 + 2.0 * np.sin(a)] for a in angles]
    polygon = constraint_rows(PolygonRegion(type="polygon", vertices=corners), "outside")[1][0]
    circle = constraint_rows(CircleRegion(type="circle", center=[0, 0.5], radius=2.0), "outside")
    x = np.linspace(-12.0, 12.0, 2)
    way = way_at(x, np.zeros(2), 0, 0.5, int(circle[0][0]), circle[1][0], 3.0)
    xs = np.linspace(-12.0, 12.0, 481)
    eased = [_way_round_polygon_eased(polygon, 0.1, u, 0.0, way, 6.0, u + 30.0) for u in xs]
    disc = circle[1][0]
    round_circle = [_way_round_eased(disc, 0.1, u, 0.0, way, -1.0, 6.0, u + 30.0) for u in xs]
    assert max(eased) == pytest.approx(2.0 - 0.5 + 0.1, abs=1e-3)
    assert np.abs(np.subtract(eased, round_circle)).max() < 1e-3
    box = constraint_rows(BoxRegion(type="box", center=[0, 0.6], size=[3.0, 1.6]), "outside")[1][0]
    box_way = way_at(x, np.zeros(2), 0, 0.5, POLYGON_ROW, box, 3.0)
    eased = [_way_round_polygon_eased(box, 0.1, u, 0.0, box_way, 6.0, u + 30.0) for u in xs]
    ramp = [_way_round_polygon(box, 0.1, u, 0.0, 1.0, 0.0, box_way[4])[0] for u in xs]
    assert box_way[4] == -1.0  # the shorter way across: the right
    assert min(np.subtract(eased, ramp)) >= -1e-12
    plateau = np.flatnonzero(np.isclose(eased, 0.2 + 0.1))
    assert xs[plateau].min() <= -1.5  # the box's face, held
    assert xs[plateau].max() >= 1.5


@pytest.mark.parametrize(
    ("name", "bound"), [("line-box-eased", 1.30), ("line-polygon-eased", 1.12)]
)
def test_a_fast_line_past_a_box_keeps_its_detour_bound(
    name: str, bound: float, tmp_path: Path
) -> None:
    """gen-124-line with its rock a box and a pentagon (scripts/keep_out_shapes.py):
    at 3.6 m/s under a turn-rate acceleration limit the ramp's foot asked
    the whole turn at once and the robot swung past the ramp's top, 1.66 m
    off its line where the judge allows 1.30 m, and 1.51 where 1.12 is
    allowed; on the eased climb, as round an ellipse, each keeps its bound
    and the independent judge finds it sound."""
    [judged] = judge_all([ZONES / f"{name}.yaml"], tmp_path, workers=1)
    assert (judged.outcome, judged.problems) == ("success", ()), judged.message
    summary = json.loads((tmp_path / name / "summary.json").read_text())
    assert summary["phases"][0]["tracking"]["detour_offset_max"] < bound


@pytest.fixture(scope="module")
def shapes(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The generated set's keep-out circles made boxes and polygons
    (scripts/keep_out_shapes.py)."""
    out = tmp_path_factory.mktemp("shapes")
    assert write_shapes([str(out)]) == 0
    return out


@pytest.mark.slow
def test_generated_missions_past_boxes_and_polygons(shapes: Path, tmp_path: Path) -> None:
    """Four of the generated set with their rock a box or a polygon, which
    failed with the shorter way across taken at each aim: a circle whose
    robot stood at its box (10 m behind at the end), a polyline's turn-rate
    kick of 3.9 rad/s (2.63 allowed) and of 4.6 (3.35), and a circle's 5
    reversals in a second (3 allowed). Each succeeds, sound."""
    names = (
        "gen-016-circle-box",
        "gen-054-polyline-box",
        "gen-130-polyline-poly",
        "gen-163-circle-poly",
    )
    judged = judge_all([shapes / f"{n}.yaml" for n in names], tmp_path, workers=1)
    assert [(j.mission, j.outcome, j.sound) for j in judged] == [
        (n, "success", True) for n in names
    ]


@pytest.mark.sweep
def test_the_generated_set_past_boxes_and_polygons(shapes: Path, tmp_path: Path) -> None:
    """All 106 (docs/paper-notes.md, eq. (28), "The way round a box or
    polygon, decided once"): 95 succeed, where 66 did with the shorter way
    across taken at each aim, 76 with the ramp on the pass's line alone, 77
    with the ramp under acceleration limits and 87 with a park by a corner
    stopped by eq. (28)'s first order ("Back towards the regulator's
    input"); no false alarm, and at most the 2 dishonest successes named
    there."""
    judged = judge_all(sorted(shapes.glob("*.yaml")), tmp_path, workers=2)
    assert len(judged) == 106
    assert sum(j.success for j in judged) >= 95
    assert [j.mission for j in judged if not j.success and j.sound] == []
    dishonest = {j.mission for j in judged if j.success and not j.sound}
    assert dishonest <= {"gen-031-line-poly", "gen-093-ellipse-poly"}
