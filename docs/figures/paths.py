"""Draw the figures of docs/mission-format.md, "Paths drawn through points".

    python docs/figures/paths.py

writes docs/images/path-*.png, keep-out-xy.png and shelf-xy.png and prints the overshoot
numbers quoted beside them (tests/test_routes.py asserts the same numbers).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np
from pydantic import TypeAdapter
from scipy.interpolate import CubicSpline
from scipy.spatial import ConvexHull

from wmr_mission import load_mission, run_mission
from wmr_mission.geometry import paths
from wmr_mission.geometry.paths import PathSpec
from wmr_mission.geometry.routes import RouteTrajectory
from wmr_mission.output.figures import plot_xy
from wmr_mission.spec.models import Mission

ROOT = Path(__file__).resolve().parents[2]
IMAGES = ROOT / "docs" / "images"
PATROL = np.array([[1, 0], [7, 0.5], [8, 5], [4, 6], [0.5, 4]], dtype=float)
LAWNMOWER = np.array(
    [[1, 1], [9, 1], [9, 2], [1, 2], [1, 3], [9, 3], [9, 4], [1, 4], [1, 5], [9, 5]], dtype=float
)
FIELD = [[0, 0], [12, 0], [13, 6], [4, 8], [-1, 4]]
MISSION = Mission.model_validate(
    {
        "version": 1,
        "name": "figures",
        "regions": {"field": {"type": "polygon", "vertices": FIELD}},
        "phases": [{"name": "wait", "hold": {}, "until": {"elapsed": 1}}],
    }
)


def curve(spec: dict[str, Any]) -> tuple[np.ndarray, np.ndarray]:
    path = paths.trajectory(
        TypeAdapter(PathSpec).validate_python(spec), MISSION.path_context(), (0.0, 0.0, 0.0)
    )
    duration = path.period if isinstance(path, RouteTrajectory) else path.length / path.speed
    x, y, _, _ = path.sample(np.linspace(0.0, duration, 20001))
    return x, y


def old_spline(points: np.ndarray, closed: bool) -> tuple[np.ndarray, np.ndarray]:
    """The former waypoint curve: natural (or periodic) cubic spline in chord length."""
    nodes = np.vstack([points, points[:1]]) if closed else points
    knots = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(nodes, axis=0).T))])
    spline = CubicSpline(knots, nodes, bc_type="periodic" if closed else "natural")
    xy = spline(np.linspace(0.0, knots[-1], 20001))
    return xy[:, 0], xy[:, 1]


def outside_hull(points: np.ndarray, x: np.ndarray, y: np.ndarray) -> float:
    equations = ConvexHull(points).equations
    return max(0.0, float((np.column_stack([x, y]) @ equations[:, :2].T + equations[:, 2]).max()))


def hull_outline(points: np.ndarray) -> np.ndarray:
    hull = ConvexHull(points)
    corners = points[hull.vertices]
    return np.vstack([corners, corners[:1]])


def waypoints_figure() -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    for ax, (name, points, closed) in zip(
        axes, [("patrol", PATROL, True), ("lawnmower", LAWNMOWER, False)], strict=True
    ):
        spec = {"type": "waypoints", "points": points.tolist(), "speed": 1.0,
                "closed": closed, "start": "first"}  # fmt: skip
        new_x, new_y = curve(spec)
        old_x, old_y = old_spline(points, closed)
        new, old = outside_hull(points, new_x, new_y), outside_hull(points, old_x, old_y)
        print(f"waypoints {name}: outside the hull by {new:.2f} m (former spline {old:.2f} m)")
        hull = hull_outline(points)
        ax.fill(hull[:, 0], hull[:, 1], color="0.92", label="hull of the points")
        ax.plot(old_x, old_y, "--", color="0.5", label=f"former spline (out by {old:.2f} m)")
        ax.plot(new_x, new_y, color="C0", label=f"waypoints (out by {new:.2f} m)")
        ax.plot(points[:, 0], points[:, 1], "ko", ms=4, label="points")
        ax.set_title(f"waypoints: {name}")
        ax.set_aspect("equal")
        ax.legend(fontsize=7, loc="upper right")
    fig.tight_layout()
    fig.savefig(IMAGES / "path-waypoints.png", dpi=90)
    plt.close(fig)


def polyline_figure() -> None:
    fig, ax = plt.subplots(figsize=(6, 4.5))
    hull = hull_outline(PATROL)
    ax.fill(hull[:, 0], hull[:, 1], color="0.92", label="hull of the points")
    for radius, style in ((0.0, "C1"), (1.0, "C0"), (2.5, "C2")):
        spec = {"type": "polyline", "points": PATROL.tolist(), "speed": 1.0, "closed": True,
                "corner_radius": radius, "start": "first"}  # fmt: skip
        x, y = curve(spec)
        label = "corner_radius: 0 (turns in place)" if radius == 0 else f"corner_radius: {radius}"
        ax.plot(x, y, color=style, label=label)
        out = outside_hull(PATROL, x, y)
        print(f"polyline corner_radius {radius}: outside the hull by {out:.1e} m")
    ax.plot(PATROL[:, 0], PATROL[:, 1], "ko", ms=4, label="points")
    ax.set_title("polyline (closed)")
    ax.set_aspect("equal")
    ax.legend(fontsize=7, loc="center")
    fig.tight_layout()
    fig.savefig(IMAGES / "path-polyline.png", dpi=90)
    plt.close(fig)


def coverage_figure() -> None:
    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    field = np.array(FIELD + FIELD[:1], dtype=float)
    for ax, direction in zip(axes, (0.0, 0.5), strict=True):
        spec = {"type": "coverage", "region": "field", "spacing": 1.0, "direction": direction,
                "speed": 1.0, "start": "first"}  # fmt: skip
        x, y = curve(spec)
        ax.fill(field[:, 0], field[:, 1], color="0.92", label="field")
        ax.plot(x, y, color="C0", label="coverage path")
        ax.plot(x[:1], y[:1], "ko", ms=5, label="start")
        ax.set_title(f"coverage: spacing 1, direction {direction}, turn radius 0.5 (default)")
        ax.set_aspect("equal")
        ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(IMAGES / "path-coverage.png", dpi=90)
    plt.close(fig)


# One example of each path type, as the mission-format reference writes it.
EXAMPLES: list[tuple[dict[str, Any], float]] = [
    ({"type": "line", "start": [0, 0], "heading": 0.5, "speed": 1}, 5.0),
    ({"type": "circle", "center": [0, 0], "radius": 2, "angular_rate": 1, "start": 0}, 6.3),
    ({"type": "ellipse", "center": [0, 0], "semi_axes": [5.5, 3], "angular_rate": "0.4*pi",
      "start": 0}, 5.0),
    ({"type": "spiral", "initial_radius": 2, "growth_rate": 0.5, "angular_rate": "0.4*pi"}, 2.0),
    ({"type": "elliptical-spiral", "center": [0, 0], "semi_axes": [5.5, 3], "decay_rate": 0.2,
      "angular_rate": "0.4*pi", "start": 0}, 15.0),
    ({"type": "expression", "x": "3*sin(0.5*t)", "y": "2*sin(t)"}, 12.6),
    ({"type": "waypoints", "points": PATROL.tolist(), "speed": 1, "closed": True,
      "start": "first"}, 0.0),
    ({"type": "polyline", "points": PATROL.tolist(), "speed": 1, "closed": True,
      "corner_radius": 1.0, "start": "first"}, 0.0),
    ({"type": "coverage", "region": "field", "spacing": 1.0, "speed": 1, "start": "first"}, 0.0),
]  # fmt: skip


def path_types_figure() -> None:
    fig, axes = plt.subplots(3, 3, figsize=(11, 9.5))
    for ax, (spec, duration) in zip(axes.ravel(), EXAMPLES, strict=True):
        if duration > 0.0:
            path = paths.trajectory(
                TypeAdapter(PathSpec).validate_python(spec), MISSION.path_context(), (0, 0, 0)
            )
            x, y, _, _ = path.sample(np.linspace(0.0, duration, 2001))
        else:
            x, y = curve(spec)
        ax.plot(x, y, color="C0")
        ax.plot(x[:1], y[:1], "ko", ms=4)
        if "points" in spec:
            points = np.array(spec["points"], dtype=float)
            ax.plot(points[:, 0], points[:, 1], "k.", ms=6)
        if spec["type"] == "coverage":
            field = np.array(FIELD + FIELD[:1], dtype=float)
            ax.plot(field[:, 0], field[:, 1], color="0.6", lw=0.8)
        ax.set_title(spec["type"], fontsize=10)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
    fig.tight_layout()
    fig.savefig(IMAGES / "path-types.png", dpi=80)
    plt.close(fig)


def keep_out_figure() -> None:
    result = run_mission(load_mission(ROOT / "missions" / "keep-out.yaml"))
    inside = 1.2 - np.hypot(result.x - 5.0, result.y - 0.4)
    print(f"keep-out: deepest sample inside the pond {inside.max():.4f} m (negative: never)")
    fig, ax = plt.subplots(figsize=(9, 6.5))
    plot_xy(result, ax=ax)
    fig.savefig(IMAGES / "keep-out-xy.png", dpi=120, bbox_inches="tight")
    plt.close(fig)


def shelf_figure() -> None:
    result = run_mission(load_mission(ROOT / "missions" / "shelf.yaml"))
    print(f"shelf: the body's clearance_min {result.summary()['clearance_min']:.3f} m")
    fig, ax = plt.subplots(figsize=(9, 6.5))
    plot_xy(result, ax=ax)
    fig.savefig(IMAGES / "shelf-xy.png", dpi=120, bbox_inches="tight")
    plt.close(fig)


if __name__ == "__main__":
    path_types_figure()
    waypoints_figure()
    polyline_figure()
    coverage_figure()
    keep_out_figure()
    shelf_figure()
