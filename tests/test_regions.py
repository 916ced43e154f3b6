from __future__ import annotations

import math
from typing import Literal

import numpy as np
import pytest
from pydantic import TypeAdapter

from wmr_mission.geometry.regions import (
    ELLIPSE_ROW,
    HALF_PLANE_ROW,
    POLYGON_ROW,
    RegionSpec,
    constraint_rows,
    is_convex,
    region_outline,
    region_value,
    row_gradients,
    row_values,
)

REGION = TypeAdapter(RegionSpec)

PAPER_ELLIPSE = REGION.validate_python({"type": "ellipse", "semi_axes": [5.5, 3]})
ROTATED_ELLIPSE = REGION.validate_python(
    {"type": "ellipse", "center": [1, -2], "semi_axes": [3, 1.5], "rotation": 0.7}
)
CIRCLE = REGION.validate_python({"type": "circle", "center": [2, 1], "radius": 1.5})
BOX = REGION.validate_python({"type": "box", "min": [-1, -2], "max": [3, 1]})
TRIANGLE_CLOCKWISE = REGION.validate_python(
    {"type": "polygon", "vertices": [[0, 0], [0, 2], [3, 0]]}
)
HEXAGON = REGION.validate_python(
    {
        "type": "polygon",
        "vertices": [[math.cos(k * math.pi / 3), math.sin(k * math.pi / 3)] for k in range(6)],
    }
)
HALF_PLANE = REGION.validate_python({"type": "half-plane", "normal": [3, 4], "offset": 10})

ALL_REGIONS = [PAPER_ELLIPSE, ROTATED_ELLIPSE, CIRCLE, BOX, TRIANGLE_CLOCKWISE, HEXAGON, HALF_PLANE]
OUTSIDE_ALLOWED = [PAPER_ELLIPSE, ROTATED_ELLIPSE, CIRCLE, HALF_PLANE]


def test_ellipse_value_is_eq_33() -> None:
    x = np.array([0.0, 5.5, 0.0, 6.0, 1.0])
    y = np.array([0.0, 0.0, 3.0, 0.0, 1.0])
    expected = (x / 5.5) ** 2 + (y / 3) ** 2 - 1
    np.testing.assert_allclose(region_value(PAPER_ELLIPSE, x, y), expected, atol=1e-15)


@pytest.mark.parametrize(
    ("region", "inside", "outside"),
    [
        (PAPER_ELLIPSE, (5.0, 0.5), (0.0, 3.1)),
        (ROTATED_ELLIPSE, (1 + 2.5 * math.cos(0.7), -2 + 2.5 * math.sin(0.7)), (1.0, 0.0)),
        (CIRCLE, (2.0, 2.4), (3.2, 2.2)),
        (BOX, (2.9, -1.9), (3.1, 0.0)),
        (TRIANGLE_CLOCKWISE, (0.5, 0.5), (2.0, 1.0)),
        (HEXAGON, (0.0, 0.8), (0.0, 0.9)),
        (HALF_PLANE, (0.0, 0.0), (2.0, 1.1)),
    ],
)
def test_signs_inside_and_outside(
    region: RegionSpec, inside: tuple[float, float], outside: tuple[float, float]
) -> None:
    assert region_value(region, *inside) < 0
    assert region_value(region, *outside) > 0


def test_polygon_and_half_plane_values_are_signed_distances() -> None:
    assert region_value(BOX, 0.0, 0.0) == pytest.approx(-1.0)  # nearest edge y = 1
    assert region_value(BOX, 5.0, 0.0) == pytest.approx(2.0)
    # the triangle's hypotenuse from (0, 2) to (3, 0): distance of the origin is 6/sqrt(13)
    assert region_value(TRIANGLE_CLOCKWISE, 3.0, 2.0) == pytest.approx(6 / math.sqrt(13))
    assert region_value(HALF_PLANE, 0.0, 0.0) == pytest.approx(-2.0)  # |n| = 5
    assert region_value(HALF_PLANE, 3.0, 4.0) == pytest.approx(3.0)


def test_region_value_is_vectorised() -> None:
    x = np.zeros((2, 3))
    for region in ALL_REGIONS:
        assert region_value(region, x, x).shape == (2, 3)


def _random_points(rng: np.random.Generator, count: int = 200) -> np.ndarray:
    return rng.uniform(-7.0, 7.0, size=(count, 2))


@pytest.mark.parametrize("region", ALL_REGIONS)
def test_inside_rows_agree_with_region_value(region: RegionSpec, rng: np.random.Generator) -> None:
    kind, params = constraint_rows(region, "inside")
    assert kind.dtype == np.int64
    assert params.dtype == np.float64
    assert params.shape == (len(kind), 6)
    for x, y in _random_points(rng):
        worst = row_values(kind, params, x, y).max()
        assert np.sign(worst) == np.sign(region_value(region, x, y))


@pytest.mark.parametrize("region", OUTSIDE_ALLOWED)
def test_outside_rows_have_the_opposite_sign(region: RegionSpec, rng: np.random.Generator) -> None:
    kind, params = constraint_rows(region, "outside")
    for x, y in _random_points(rng):
        worst = row_values(kind, params, x, y).max()
        assert np.sign(worst) == -np.sign(region_value(region, x, y))


def test_row_layout_matches_the_architecture_table() -> None:
    kind, params = constraint_rows(ROTATED_ELLIPSE, "outside")
    assert kind.tolist() == [ELLIPSE_ROW]
    np.testing.assert_allclose(params, [[1, -2, 3, 1.5, 0.7, -1]])
    kind, params = constraint_rows(CIRCLE, "inside")
    np.testing.assert_allclose(params, [[2, 1, 1.5, 1.5, 0, 1]])
    kind, params = constraint_rows(HALF_PLANE, "inside")
    assert kind.tolist() == [HALF_PLANE_ROW]
    np.testing.assert_allclose(params, [[0.6, 0.8, 2, 0, 0, 0]])
    kind, params = constraint_rows(BOX, "inside")
    assert kind.tolist() == [HALF_PLANE_ROW] * 4
    kind, params = constraint_rows(HEXAGON, "inside")
    assert len(kind) == 6
    np.testing.assert_allclose(np.hypot(params[:, 0], params[:, 1]), 1.0)


@pytest.mark.parametrize("region", [BOX, TRIANGLE_CLOCKWISE])
def test_stay_outside_of_a_box_or_polygon_is_one_signed_distance_row(region: RegionSpec) -> None:
    """Its outside is not convex, so no half-plane rows describe it: one
    polygon row, minus the signed distance (tests/test_footprint.py checks
    the distance against shapely)."""
    kind, params = constraint_rows(region, "outside")
    assert kind.tolist() == [POLYGON_ROW]
    corners = int(params[0, 0])
    assert corners == (4 if region is BOX else 3)
    assert params.shape == (1, 4 + 5 * corners)  # kernels.convex: a header, 5 a corner
    assert row_values(kind, params, 100.0, 100.0)[0] < -100.0


@pytest.mark.parametrize(
    ("region", "side"),
    [(region, "inside") for region in ALL_REGIONS]
    + [(region, "outside") for region in OUTSIDE_ALLOWED],
)
def test_gradients_match_central_differences(
    region: RegionSpec, side: Literal["inside", "outside"], rng: np.random.Generator
) -> None:
    kind, params = constraint_rows(region, side)
    h = 1e-6
    for x, y in _random_points(rng, 20):
        gradient = row_gradients(kind, params, x, y)
        assert gradient.shape == (len(kind), 2)
        dx = (row_values(kind, params, x + h, y) - row_values(kind, params, x - h, y)) / (2 * h)
        dy = (row_values(kind, params, x, y + h) - row_values(kind, params, x, y - h)) / (2 * h)
        np.testing.assert_allclose(gradient, np.column_stack([dx, dy]), rtol=1e-6, atol=1e-6)


@pytest.mark.parametrize(
    ("vertices", "convex"),
    [
        ([[0, 0], [1, 0], [0, 1]], True),
        ([[0, 0], [0, 1], [1, 0]], True),  # clockwise
        ([[0, 0], [1, 0], [1, 1], [0, 1]], True),
        ([[0, 0], [0.5, 0], [1, 0], [1, 1], [0, 1]], True),  # a straight-through vertex
        ([[0, 0], [2, 0], [1, 0.5], [2, 2], [0, 2]], False),  # a notch
        ([[0, 0], [1, 0], [0, 1], [1, 1]], False),  # self-intersecting bow tie
        ([[0, 0], [1, 1], [2, 2]], False),  # no area
        ([[0, 0], [1, 0], [1, 0], [0, 1]], False),  # repeated point
        ([[0, 0], [1, 0]], False),
        (
            [[math.cos(4 * math.pi * k / 5), math.sin(4 * math.pi * k / 5)] for k in range(5)],
            False,  # pentagram: every turn agrees, but it winds twice
        ),
    ],
)
def test_is_convex(vertices: list[list[float]], convex: bool) -> None:
    assert is_convex(vertices) is convex


@pytest.mark.parametrize("region", [PAPER_ELLIPSE, ROTATED_ELLIPSE, CIRCLE])
def test_outline_of_ellipses_lies_on_the_boundary(region: RegionSpec) -> None:
    x, y = region_outline(region, n=100)
    assert x.shape == (100,)
    np.testing.assert_allclose(region_value(region, x, y), 0.0, atol=1e-12)
    assert (x[0], y[0]) == pytest.approx((x[-1], y[-1]))


@pytest.mark.parametrize("region", [BOX, TRIANGLE_CLOCKWISE, HEXAGON])
def test_outline_of_polygons_is_closed_and_on_the_boundary(region: RegionSpec) -> None:
    x, y = region_outline(region)
    assert (x[0], y[0]) == (x[-1], y[-1])
    np.testing.assert_allclose(region_value(region, x, y), 0.0, atol=1e-12)


def test_outline_of_a_half_plane_is_clipped_to_the_extent() -> None:
    x, y = region_outline(HALF_PLANE, extent=(-10, 10, -10, 10))
    assert len(x) == 2
    np.testing.assert_allclose(3 * x + 4 * y, 10.0)
    assert np.all(np.abs(x) <= 10 + 1e-12)
    assert np.all(np.abs(y) <= 10 + 1e-12)
    assert np.any(np.isclose(np.abs(x), 10) | np.isclose(np.abs(y), 10))
    x, y = region_outline(HALF_PLANE, extent=(-1, 0, -1, 0))  # the line misses this box
    assert len(x) == 0
    vertical = REGION.validate_python({"type": "half-plane", "normal": [1, 0], "offset": 2})
    x, y = region_outline(vertical, extent=(-5, 5, -3, 3))
    np.testing.assert_allclose(x, [2, 2])
    np.testing.assert_allclose(sorted(y), [-3, 3])
