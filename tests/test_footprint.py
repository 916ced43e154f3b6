"""A robot with a body: robot.footprint, keep-out boxes and polygons kept by a
signed-distance row, clearance_min in metres, and IR-SIM's world built from
the mission's zones."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import shapely

from wmr_mission.geometry.regions import box_corners, polygon_row
from wmr_mission.kernels import jit
from wmr_mission.kernels.convex import polygon_distance
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import MissionError, load_mission_text
from wmr_mission.spec.models import PolygonFootprint, RoundFootprint
from wmr_mission.verdicts.check import Check
from wmr_mission.verdicts.metrics import check_expectations, unmet

ROOT = Path(__file__).resolve().parents[1]
SHELF = (ROOT / "missions" / "shelf.yaml").read_text()
# One lap of missions/shelf.yaml: the shelf is met once a lap.
ONE_LAP = SHELF.replace("times: 2", "times: 1")
BODY = "  footprint: {radius: 0.25}\n"
assert BODY in SHELF


def _shelf(text: str = ONE_LAP, body: str = BODY):  # type: ignore[no-untyped-def]
    return load_mission_text(text.replace(BODY, body), "shelf.yaml")


# --- the footprint ---------------------------------------------------------------


def test_a_footprint_is_a_radius_or_a_convex_polygon_in_the_robots_frame() -> None:
    robot = _shelf().robot
    assert robot.footprint == RoundFootprint(radius=0.25)
    assert robot.footprint.reach() == 0.25
    tray = _shelf(
        body="  footprint: {polygon: [[0.3, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.3, -0.2]]}\n"
    )
    assert isinstance(tray.robot.footprint, PolygonFootprint)
    assert tray.robot.footprint.reach() == pytest.approx(math.hypot(0.3, 0.2))
    assert _shelf(body="").robot.footprint is None


@pytest.mark.parametrize(
    ("body", "where", "message"),
    [
        (
            "  footprint: {polygon: [[0.3, 0.2], [-0.2, 0.2], [0, 0], [-0.2, -0.2], "
            "[0.3, -0.2]]}\n",
            "14:24",
            "a footprint polygon must be convex",
        ),
        (
            "  footprint: {polygon: [[0.3, 0], [0, 0], [-0.3, 0]]}\n",
            "14:24",
            "a footprint polygon needs distinct corners that enclose an area",
        ),
        ("  footprint: {radius: -0.25}\n", "14:23", "greater than 0"),
        ("  footprint: {diameter: 0.5}\n", "14:14", "a footprint is {radius: R} or {polygon:"),
    ],
)
def test_a_bad_footprint_is_reported_at_its_place(body: str, where: str, message: str) -> None:
    with pytest.raises(MissionError) as raised:
        _shelf(body=body)
    text = str(raised.value)
    assert f"shelf.yaml:{where}: " in text, text
    assert message in text, text


def test_with_a_footprint_clearance_min_is_0_unless_set() -> None:
    assert _shelf().expect.clearance_min == 0.0
    assert _shelf(body="").expect.clearance_min is None
    own = ONE_LAP.replace("phases:", "expect:\n  clearance_min: 0.1\nphases:", 1)
    assert _shelf(own).expect.clearance_min == 0.1
    off = ONE_LAP.replace("phases:", "expect:\n  clearance_min: null\nphases:", 1)
    assert _shelf(off).expect.clearance_min is None


# --- the signed distance to a convex polygon --------------------------------------

TURNED_BOX = {"type": "box", "center": [1.0, -0.5], "size": [1.0, 0.5], "heading": 0.7}
PENTAGON = [[math.cos(a) * 2 + 3, math.sin(a) * 1.5 - 1] for a in np.linspace(0, 2 * np.pi, 6)[:-1]]


@pytest.mark.parametrize("corners", [box_corners(TURNED_BOX), np.array(PENTAGON)[::-1]])
def test_signed_distance_to_a_polygon_is_shapelys(corners: np.ndarray) -> None:
    """Outside: the distance to the polygon; inside: minus the distance to its
    edge; to 1e-12 of shapely's on random points, and its gradient outside the
    central difference of it (the distance is smooth there)."""
    row = polygon_row(corners)[0]
    outline = shapely.Polygon(corners)
    rng = np.random.default_rng(33)
    low, high = corners.min(axis=0) - 1.5, corners.max(axis=0) + 1.5
    points = rng.uniform(low, high, size=(400, 2))
    outside = 0
    for x, y in points:
        distance, gx, gy = polygon_distance(row, float(x), float(y))
        point = shapely.Point(x, y)
        if outline.contains(point):
            assert distance == pytest.approx(-outline.exterior.distance(point), abs=1e-12)
            continue
        outside += 1
        assert distance == pytest.approx(outline.distance(point), abs=1e-12)
        if distance < 1e-3:
            continue
        h = 1e-6
        dx = (polygon_distance(row, x + h, y)[0] - polygon_distance(row, x - h, y)[0]) / (2 * h)
        dy = (polygon_distance(row, x, y + h)[0] - polygon_distance(row, x, y - h)[0]) / (2 * h)
        assert (gx, gy) == pytest.approx((dx, dy), abs=1e-6)
        assert math.hypot(gx, gy) == pytest.approx(1.0, abs=1e-12)
    assert outside > 200


def test_compiled_signed_distance_has_plain_pythons_bytes() -> None:
    row = polygon_row(box_corners(TURNED_BOX))[0]
    compiled = jit.compiled(polygon_distance)
    rng = np.random.default_rng(7)
    for x, y in rng.uniform(-1.5, 3.0, size=(2000, 2)).tolist():
        ours, theirs = np.array(compiled(row, x, y)), np.array(polygon_distance(row, x, y))
        assert ours.tobytes() == theirs.tobytes(), (x, y)


def test_the_way_round_a_polygon_is_the_least_support_over_the_ramp() -> None:
    """The aim's reach round a keep-out polygon grown by r, found without
    iterating, is the least over the ramp's slopes mu of the grown polygon's
    support function in the direction m + mu t (scipy's bounded minimum of
    that convex function), m the shorter way across, on random polygons,
    aims and headings."""
    from scipy.optimize import minimize_scalar

    from wmr_mission.controllers.constrained_tracking import RAMP_SLOPE, _way_round_polygon

    rng = np.random.default_rng(32)
    moved = 0
    for trial in range(300):
        if trial % 2:
            turn = np.sort(rng.uniform(0.0, 2.0 * np.pi, 5))
            corners = np.column_stack([np.cos(turn) * rng.uniform(0.5, 1.5), np.sin(turn)])
        else:
            box = {"type": "box", "center": rng.uniform(-1, 1, 2).tolist(), "heading": 0.3}
            corners = box_corners({**box, "size": rng.uniform(0.2, 2.0, 2).tolist()})
        r = float(rng.uniform(0.0, 0.6))
        x, y = rng.uniform(-3.0, 3.0, 2).tolist()
        heading = float(rng.uniform(-3.0, 3.0))
        tx, ty = math.cos(heading), math.sin(heading)
        reach, _, _ = _way_round_polygon(polygon_row(corners)[0], r, x, y, tx, ty, 0.0)
        offsets = corners - [x, y]
        t = np.array([tx, ty])
        m = np.array([-ty, tx])
        if (offsets @ m).max() > (-(offsets @ m)).max():
            m = -m

        def support(
            mu: float,
            m: np.ndarray = m,
            t: np.ndarray = t,
            offsets: np.ndarray = offsets,
            r: float = r,
        ) -> float:
            direction = m + mu * t
            return float((offsets @ direction).max() + r * np.hypot(*direction))

        least = minimize_scalar(
            support, bounds=(-RAMP_SLOPE, RAMP_SLOPE), method="bounded", options={"xatol": 1e-12}
        )
        expected = max(min(least.fun, support(-RAMP_SLOPE), support(RAMP_SLOPE)), 0.0)
        assert reach == pytest.approx(expected, abs=1e-9), trial
        moved += reach > 0.0
    assert moved > 30


# --- the shelf patrol --------------------------------------------------------------


def test_the_shelf_is_kept_by_the_body_where_the_axles_rule_would_touch_it() -> None:
    """A robot of radius 0.25 m goes round the shelf with its edge clear; the
    same mission with a point robot keeps the axle 0.14 m from the shelf, so a
    body of 0.25 m on that rule would have gone 0.11 m into it."""
    body = run_mission(_shelf())
    assert body.succeeded, body.message
    summary = body.summary()
    assert 0.0 <= summary["clearance_min"] < 0.2
    assert summary["phases"][0]["constraint"]["clearance_min"] == summary["clearance_min"]
    point = run_mission(_shelf(body=""))
    axle = point.summary()["clearance_min"]  # a point: the axle's own distance
    assert 0.0 < axle < 0.25
    # judged with the body, the point robot's run touches the shelf
    from wmr_mission.verdicts.metrics import run_columns

    point.mission = {**(point.mission or {}), "robot": {"footprint": {"radius": 0.25}}}
    clearance = run_columns(point, point.mission)["clearance_min"]
    assert clearance == pytest.approx(axle - 0.25, abs=1e-6)
    assert clearance < -0.1


def test_a_polygon_body_is_kept_by_its_disc_and_judged_by_its_outline() -> None:
    corners = "[[0.3, 0.2], [-0.2, 0.2], [-0.2, -0.2], [0.3, -0.2]]"
    run = run_mission(_shelf(body=f"  footprint: {{polygon: {corners}}}\n"))
    # (its detour, 0.36 m wide, rejoins the leg where its corner begins: the turn
    # rate jumps there, which the tracking law's corners answer for, not the zone)
    assert "clearance_min" not in run.message
    clearance = run.summary()["clearance_min"]
    # the outline is inside the disc of 0.36 m the zones are kept by: at least as clear
    assert clearance >= 0.0
    disc = run_mission(_shelf(body=f"  footprint: {{radius: {math.hypot(0.3, 0.2)}}}\n"))
    assert clearance >= disc.summary()["clearance_min"]


def test_clearance_min_is_a_lower_bound_in_metres() -> None:
    """clearance_min: 0.2 asks for 0.2 m at least: the shelf run, 0.14 m clear,
    misses it, says so with `min`, its margin is the shortfall over the bound,
    and summary.json's record reads back as the same lower bound."""
    text = ONE_LAP.replace("phases:", "expect:\n  clearance_min: 0.2\nphases:", 1)
    run = run_mission(_shelf(text))
    assert run.outcome.value == "expect-failed"
    checks = [
        c for c in check_expectations(run.summary(), run.mission) if c.metric == "clearance_min"
    ]
    assert [(c.bound, c.lower) for c in checks] == [(0.2, True)]
    value = checks[0].value
    assert value is not None
    assert 0.1 < value < 0.2
    assert not checks[0].met
    assert checks[0].rho == value - 0.2
    assert checks[0].margin == (value - 0.2) / 0.2
    line = f"lap#1: clearance_min = {value:.6g} (min 0.2)"
    assert unmet(checks) == [line]
    assert line in run.message
    (record,) = [c for c in run.summary()["expectations"] if c["metric"] == "clearance_min"]
    assert record["min"] == 0.2
    assert "max" not in record
    assert Check.read(record) == checks[0]


# --- IR-SIM ----------------------------------------------------------------------


def test_irsim_world_holds_the_shelf_and_the_robot_keeps_it() -> None:
    pytest.importorskip("irsim", reason="IR-SIM not installed: pip install 'wmr-mission[irsim]'")
    from wmr_mission.backends.irsim import IrSimPlant
    from wmr_mission.sim.plan import plan_mission
    from wmr_mission.spec.loader import validate_mission

    mission = validate_mission(_shelf())
    plant = IrSimPlant(plan_mission(mission, None))
    [shelf] = plant.obstacle_geometries()
    assert shelf.equals(shapely.box(1.25, -0.85, 1.75, 0.15))
    assert plant.describe()["settings"]["robot_shape"] == {"name": "circle", "radius": 0.25}
    run = run_mission(mission, plant=plant)
    # its detour, 18 micrometres wider than the estimate's (the true robot is
    # IR-SIM's), is within the verdict's bound (tests/test_detour_bound.py)
    assert run.succeeded, run.message
    assert run.backend is not None
    assert run.backend["settings"]["obstacles"] == ["shelf"]
    assert not plant.collided
    assert run.summary()["clearance_min"] >= 0.0


def test_validate_warns_of_a_start_the_body_overlaps_a_zone_from() -> None:
    """The axle at (0, 0) is outside the shelf moved to 0.1 m ahead of it, but
    a body of 0.25 m overlaps it: `validate` warns at the start, and not
    for a point robot."""
    from wmr_mission.spec.loader import check_mission_text

    near = ONE_LAP.replace(
        "min: [1.25, -0.85], max: [1.75, 0.15]", "min: [0.1, -0.85], max: [0.6, 0.15]"
    )
    _, found = check_mission_text(near, "shelf.yaml")
    warnings = [d for d in found if d.severity == "warning"]
    assert [(d.line, d.message) for d in warnings] == [
        (
            12,
            "robot.initial_state (0, 0) is 0.1 m from keep-out zone 'shelf', nearer than the "
            "robot's body reaches (0.25 m, robot.footprint): the body overlaps the zone there",
        )
    ]
    _, found = check_mission_text(near.replace(BODY, ""), "shelf.yaml")
    assert [d for d in found if d.severity == "warning"] == []


def test_a_run_whose_body_touches_a_zone_fails_by_default() -> None:
    """A robot held 0.1 m from the shelf with a body of 0.25 m: its axle
    never enters the shelf (zone_intrusion_max met), its body overlaps it by
    0.15 m, and the default clearance_min (0 m with a footprint) fails it."""
    text = """
version: 1
name: touch
robot:
  limits: {v: 1, omega: 2}
  footprint: {radius: 0.25}
regions:
  shelf: {type: box, center: [0.35, 0], size: [0.5, 1]}
phases:
  - name: wait
    hold: {}
    constraints: [{stay_outside: shelf}]
    until: {elapsed: 0.5}
"""
    run = run_mission(load_mission_text(text, "touch.yaml"))
    summary = run.summary()
    assert summary["phases"][0]["constraint"]["intrusion_max"] == 0.0
    assert summary["clearance_min"] == pytest.approx(-0.15, abs=1e-6)
    assert run.outcome.value == "expect-failed"
    assert "wait: clearance_min = -0.15 (min 0)" in run.message


def test_validate_names_the_side_of_a_path_through_a_box_centre() -> None:
    """The shelf moved onto the leg's line, its centre on it: both ways across
    are as long, and the robot goes round on the left by rule, which
    `validate` says in a note; off the centre, no note (the shorter way is
    the mission's choice)."""
    from wmr_mission.spec.loader import check_mission_text

    through = ONE_LAP.replace(
        "{type: box, min: [1.25, -0.85], max: [1.75, 0.15]}",
        "{type: box, center: [1.5, 0], size: [0.5, 1]}",
    )
    _, found = check_mission_text(through, "shelf.yaml")
    notes = [d.message for d in found if d.severity == "note"]
    assert notes == [
        "the path runs through the centre of keep-out zone 'shelf': the robot goes round it on "
        "the left of its direction of travel, by the zone filter's rule; move the path off the "
        "centre, towards the side it should take, to choose"
    ]
    _, found = check_mission_text(ONE_LAP, "shelf.yaml")
    assert [d for d in found if d.severity == "note"] == []


def test_validate_warns_of_a_target_the_body_reaches_out_of_its_keep_in_from() -> None:
    """A park 0.1 m inside the yard's east edge with a body of 0.25 m: the axle
    can stop there, the body cannot stay in the yard. `validate` warns at the
    target, for the phase's own keep-in and the geofence's alike, and not
    for a target with room or for a point robot."""
    from wmr_mission.spec.loader import check_mission_text

    text = """version: 1
name: yard
robot:
  limits: {v: 1, omega: 2}
  footprint: {radius: 0.25}
regions:
  yard: {type: box, min: [-1, -1], max: [2, 1]}
  east: {type: half-plane, normal: [1, 0], offset: 2}
phases:
  - name: park
    regulate: {target: {x: 1.9, y: 0, theta: 0}}
    constraints: [{stay_inside: yard}]
    until: {settled: {position: 0.02, heading: 0.02}}
    timeout: 20
"""
    _, found = check_mission_text(text, "yard.yaml")
    assert [(d.line, d.message) for d in found if d.severity == "warning"] == [
        (
            11,
            "the target (1.9, 0) is 0.1 m inside the edge of keep-in region 'yard', nearer "
            "than the robot's body reaches (0.25 m, robot.footprint): the body reaches out "
            "of it there",
        )
    ]
    fenced = text.replace("    constraints: [{stay_inside: yard}]\n", "").replace(
        "phases:", "geofence: {keep_in: [east]}\nphases:"
    )
    _, found = check_mission_text(fenced, "yard.yaml")
    assert [d.message for d in found if d.severity == "warning"] == [
        "the target (1.9, 0) is 0.1 m inside the edge of keep-in region 'east', nearer "
        "than the robot's body reaches (0.25 m, robot.footprint): the body reaches out "
        "of it there"
    ]
    for edge, region in ((text, "yard"), (fenced, "east")):  # on the edge: no room at all
        _, found = check_mission_text(edge.replace("x: 1.9", "x: 2"), "yard.yaml")
        assert [d.message for d in found if d.severity == "warning"] == [
            f"the target (2, 0) is 0 m inside the edge of keep-in region {region!r}, nearer "
            "than the robot's body reaches (0.25 m, robot.footprint): the body reaches out "
            "of it there"
        ]
    roomy = text.replace("x: 1.9", "x: 1.5")
    _, found = check_mission_text(roomy, "yard.yaml")
    assert [d for d in found if d.severity == "warning"] == []
    point = text.replace("  footprint: {radius: 0.25}\n", "")
    _, found = check_mission_text(point, "yard.yaml")
    assert [d for d in found if d.severity == "warning"] == []


def test_validate_tells_a_polygon_body_that_overlaps_a_zone_from_its_disc_alone() -> None:
    """A tray 0.5 m long and 0.36 m wide, its farthest corner 0.35 m from its
    axle, parked 0.2 m short of a shelf: facing the shelf its nose overlaps
    it; turned a quarter, its side clears it by 0.02 m, and only the disc the
    controller keeps out of the shelf overlaps it, so the robot stops short.
    `validate` says which, for a keep-out zone and a keep-in region alike."""
    from wmr_mission.spec.loader import check_mission_text

    text = """version: 1
name: tray
robot:
  limits: {v: 1, omega: 2}
  footprint: {polygon: [[0.3, 0.18], [-0.2, 0.18], [-0.2, -0.18], [0.3, -0.18]]}
regions:
  shelf: {type: box, min: [1.2, -1], max: [2, 1]}
  yard: {type: half-plane, normal: [1, 0], offset: 1.2}
phases:
  - name: park
    regulate: {target: {x: 1, y: 0, theta: HEADING}}
    constraints: [{stay_outside: shelf}]
    until: {settled: {position: 0.02, heading: 0.02}}
    timeout: 20
"""

    def warnings(heading: str, side: str = "stay_outside: shelf") -> list[tuple[int, str]]:
        mission = text.replace("HEADING", heading).replace("stay_outside: shelf", side)
        _, found = check_mission_text(mission, "tray.yaml")
        return [(d.line, d.message) for d in found if d.severity == "warning"]

    assert warnings("0") == [
        (
            11,
            "the target (1, 0) is 0.2 m from keep-out zone 'shelf', nearer than the robot's "
            "body reaches (0.35 m, robot.footprint): the body overlaps the zone there",
        )
    ]
    assert warnings("1.5708") == [
        (
            11,
            "the target (1, 0) is 0.2 m from keep-out zone 'shelf', nearer than the disc round "
            "the robot's body reaches (0.35 m, robot.footprint's farthest corner): the body "
            "itself, at heading 1.5708, clears it there, but the controller keeps that disc "
            "out of the zone, so the robot stops short of the target",
        )
    ]
    assert warnings("0", "stay_inside: yard") == [
        (
            11,
            "the target (1, 0) is 0.2 m inside the edge of keep-in region 'yard', nearer than "
            "the robot's body reaches (0.35 m, robot.footprint): the body reaches out of it "
            "there",
        )
    ]
    assert warnings("1.5708", "stay_inside: yard") == [
        (
            11,
            "the target (1, 0) is 0.2 m inside the edge of keep-in region 'yard', nearer than "
            "the disc round the robot's body reaches (0.35 m, robot.footprint's farthest "
            "corner): the body itself, at heading 1.5708, stays inside it there, but the "
            "controller keeps that disc inside the region, so the robot stops short of the target",
        )
    ]


OVERLAP = """
version: 1
name: overlap
robot:
  initial_state: {x: 1.85, y: 0, theta: 3.14159}
  limits: {v: 1, omega: 2}
  footprint: BODY
regions:
  wall: {type: box, min: [2.0, -1], max: [2.5, 1]}
phases:
  - name: away
    track: {path: {type: line, start: current, heading: 3.14159, speed: 0.5}}
    constraints: [{stay_outside: wall}]
    until: {elapsed: 2}
"""


@pytest.mark.parametrize(
    "body", ["{radius: 0.3}", "{polygon: [[0.2, 0.3], [-0.2, 0.3], [-0.2, -0.3], [0.2, -0.3]]}"]
)
def test_a_failed_clearance_min_is_marked_where_the_body_was_too_near(body: str) -> None:
    """A body that starts overlapping a wall and drives away from it: its
    clearance_min check fails at t = 0 and until the body is clear, each
    sample's clearance measured by shapely apart; verdicts.png's first failure
    in time is it, drawn on the body's depth with its bound at 0."""
    from wmr_mission.verdicts.clearance import body_clearances
    from wmr_mission.verdicts.signals import BODY_DEPTH, mark_first_violations, run_signals
    from wmr_mission.verdicts.zones import zones_of

    run = run_mission(load_mission_text(OVERLAP.replace("BODY", body), "overlap.yaml"))
    summary = run.summary()
    (check,) = [c for c in run_signals(run).checks if c.metric == "clearance_min"]
    assert not check.met
    assert (check.line, check.level) == (BODY_DEPTH, 0.0)
    # each pose's body against the wall, by shapely alone
    footprint = run.mission["robot"]["footprint"]
    wall = shapely.box(2.0, -1.0, 2.5, 1.0)
    if "radius" in footprint:
        body_at = [shapely.Point(x, y).buffer(0.3, 256) for x, y in zip(run.x, run.y, strict=True)]
    else:
        corners = np.asarray(footprint["polygon"])
        body_at = [
            shapely.Polygon(
                np.column_stack(
                    [
                        x + math.cos(t) * corners[:, 0] - math.sin(t) * corners[:, 1],
                        y + math.sin(t) * corners[:, 0] + math.cos(t) * corners[:, 1],
                    ]
                )
            )
            for x, y, t in zip(run.x, run.y, run.theta, strict=True)
        ]
    touching = np.array([body.intersects(wall) for body in body_at])
    assert touching[0]
    assert not touching[-1]
    assert check.over.tolist() == np.flatnonzero(touching).tolist()
    # the sample by sample clearance's least is summary.json's clearance_min
    zones = zones_of(run.phases[0].constraints, run.regions)
    each = body_clearances(run.x, run.y, run.theta, zones, footprint)
    assert float(np.min(each)) == summary["clearance_min"]
    far = ~touching
    distance = np.array([body.distance(wall) for body in body_at])
    assert np.abs(each[far] - distance[far]).max() < 1e-5  # a round body: 256 segments a quarter
    mark_first_violations(summary, run)
    (record,) = [c for c in summary["expectations"] if c["metric"] == "clearance_min"]
    assert record["first_violation"] == {"time": 0.0, "sample": 0}
    assert run_signals(run).failed()[0].metric == "clearance_min"
    # at least 0.2 m asked: drawn at -0.2 m of depth, marked wherever nearer than 0.2 m
    asked = OVERLAP.replace("BODY", body).replace(
        "phases:", "expect:\n  clearance_min: 0.2\nphases:"
    )
    run = run_mission(load_mission_text(asked, "overlap.yaml"))
    (check,) = [c for c in run_signals(run).checks if c.metric == "clearance_min"]
    assert check.level == -0.2
    nearer = np.array([body.distance(wall) for body in body_at]) < 0.2 - 1e-5
    assert nearer.sum() > touching.sum()  # more samples than those touching
    assert set(np.flatnonzero(nearer)) <= set(check.over.tolist())
    assert set(check.over.tolist()) <= set(np.flatnonzero(distance < 0.2 + 1e-5))
