"""Figures of a run: ``xy.png``, ``states.png``, ``estimation_error.png``, ``inputs.png``.

matplotlib is imported inside the functions, with the Agg backend, so that
importing this module (and ``wmr-mission validate``) stays light and no display
is ever needed. Long runs are thinned to at most ``MAX_POINTS_PER_LINE``
points per line: a 360 000-sample run plots in a few seconds.
"""

from __future__ import annotations

import functools
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from wmr_mission.output.metrics import estimation_errors, phase_segments
from wmr_mission.output.reader import RunDirError, load_run
from wmr_mission.output.rundir import atomic_path
from wmr_mission.result import FloatArray, IntArray, RunResult

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

MAX_POINTS_PER_LINE = 20_000
# Beyond this many phase segments, phases are drawn as one collection and go
# unnamed, so a figure costs the same for 10 or 10 000 phases.
MAX_NAMED_PHASES = 40
DPI = 120
STATE_LABELS = {"x": "x [m]", "y": "y [m]", "theta": "theta [rad]"}


def pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    # Long paths rasterised in pieces: a 1-hour run's overdrawn laps otherwise
    # take tens of MB of the renderer's memory at once.
    matplotlib.rcParams["agg.path.chunksize"] = 2000
    # Names are data: a '$' in a mission, phase or region name is drawn as
    # typed, never parsed as math (unbalanced, it would stop the drawing).
    matplotlib.rcParams["text.parse_math"] = False
    import matplotlib.pyplot as plt

    return plt


def thin(start: int, stop: int, max_points: int = MAX_POINTS_PER_LINE) -> IntArray:
    """Sample indices start..stop-1, evenly thinned to at most ``max_points``, last one kept."""
    if stop <= start:
        return np.zeros(0, dtype=np.int64)
    step = max(1, math.ceil((stop - start) / max_points))
    indices = np.arange(start, stop, step, dtype=np.int64)
    if indices[-1] != stop - 1:
        indices = np.append(indices, stop - 1)
    return indices


def finite(values: FloatArray) -> FloatArray:
    """Non-finite values as NaN: matplotlib leaves a gap instead of failing on inf."""
    return np.where(np.isfinite(values), values, np.nan)


def phase_color(index: int) -> Any:
    return _palette()[index % 10]


@functools.cache
def _palette() -> tuple[Any, ...]:
    pyplot()
    import matplotlib

    return tuple(tuple(color) for color in matplotlib.colormaps["tab10"](np.arange(10)))


def _save(fig: Figure, path: Path) -> Path:
    plt = pyplot()
    try:
        with atomic_path(path) as tmp:
            # The layout engine fits legends and labels in one render
            # (bbox_inches="tight" renders each figure twice).
            fig.set_layout_engine("constrained")
            fig.savefig(tmp, format="png", dpi=DPI)
    finally:
        plt.close(fig)
    return path


# --- regions --------------------------------------------------------------


def _region_extent(region: dict[str, Any]) -> tuple[float, float, float, float] | None:
    """Bounding box (xmin, xmax, ymin, ymax) of a bounded region, else None."""
    kind = region.get("type")
    if kind == "ellipse":
        (cx, cy), (a, b) = region["center"], region["semi_axes"]
        phi = float(region.get("rotation") or 0.0)
        half_w = math.hypot(a * math.cos(phi), b * math.sin(phi))
        half_h = math.hypot(a * math.sin(phi), b * math.cos(phi))
        return cx - half_w, cx + half_w, cy - half_h, cy + half_h
    if kind == "circle":
        (cx, cy), r = region["center"], region["radius"]
        return cx - r, cx + r, cy - r, cy + r
    if kind == "box":
        (x0, y0), (x1, y1) = region["min"], region["max"]
        return x0, x1, y0, y1
    if kind == "polygon":
        vertices = np.asarray(region["vertices"], dtype=np.float64)
        return (
            float(vertices[:, 0].min()),
            float(vertices[:, 0].max()),
            float(vertices[:, 1].min()),
            float(vertices[:, 1].max()),
        )
    return None


def _clip_half_plane(
    box: tuple[float, float, float, float], normal: tuple[float, float], offset: float
) -> FloatArray:
    """The part of a box where ``normal . p <= offset`` (one Sutherland-Hodgman pass)."""
    x0, x1, y0, y1 = box
    corners = [(x0, y0), (x1, y0), (x1, y1), (x0, y1)]
    nx, ny = normal
    kept: list[tuple[float, float]] = []
    for (px, py), (qx, qy) in zip(corners, corners[1:] + corners[:1], strict=True):
        cp, cq = nx * px + ny * py - offset, nx * qx + ny * qy - offset
        if cp <= 0.0:
            kept.append((px, py))
        if cp * cq < 0.0:
            s = cp / (cp - cq)
            kept.append((px + s * (qx - px), py + s * (qy - py)))
    return np.asarray(kept, dtype=np.float64).reshape(-1, 2)


def draw_regions(
    ax: Axes, regions: dict[str, Any], view: tuple[float, float, float, float]
) -> None:
    """Each region as a light patch with its outline; a half-plane is shaded inside ``view``."""
    from matplotlib import patches

    colors = pyplot().get_cmap("Dark2")
    for number, (name, region) in enumerate(regions.items()):
        kind = region.get("type")
        color = colors(number % 8)
        style: dict[str, Any] = {
            "facecolor": (*color[:3], 0.06 if kind == "half-plane" else 0.1),
            "edgecolor": color,
            "linewidth": 1.3,
        }
        label = f"region {name}"
        patch: Any
        if kind == "ellipse":
            (a, b) = region["semi_axes"]
            patch = patches.Ellipse(
                tuple(region["center"]),
                2 * a,
                2 * b,
                angle=math.degrees(float(region.get("rotation") or 0.0)),
                **style,
            )
        elif kind == "circle":
            patch = patches.Circle(tuple(region["center"]), region["radius"], **style)
        elif kind == "box":
            (x0, y0), (x1, y1) = region["min"], region["max"]
            patch = patches.Rectangle((x0, y0), x1 - x0, y1 - y0, **style)
        elif kind == "polygon":
            patch = patches.Polygon(np.asarray(region["vertices"], dtype=np.float64), **style)
        elif kind == "half-plane":
            x0, x1, y0, y1 = view
            # Far beyond the view, so the shading survives the equal-aspect adjustment.
            reach = 10.0 * max(x1 - x0, y1 - y0, 1.0)
            cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
            big = (cx - reach, cx + reach, cy - reach, cy + reach)
            normal = (float(region["normal"][0]), float(region["normal"][1]))
            inside = _clip_half_plane(big, normal, float(region["offset"]))
            if inside.shape[0] < 3:
                continue
            patch = patches.Polygon(inside, **style)
        else:
            continue
        patch.set_label(label)
        ax.add_patch(patch)


# --- xy.png ---------------------------------------------------------------


def view_box(result: RunResult) -> tuple[float, float, float, float]:
    """Data limits of the path, the reference, the targets and bounded regions, with a margin."""
    xs = [result.x, result.x_est, result.x_ref]
    ys = [result.y, result.y_est, result.y_ref]
    targets = [p.target for p in result.phases if p.target is not None]
    if targets:
        xs.append(np.array([t[0] for t in targets], dtype=np.float64))
        ys.append(np.array([t[1] for t in targets], dtype=np.float64))
    for region in result.regions.values():
        extent = _region_extent(region)
        if extent is not None:
            xs.append(np.asarray(extent[:2], dtype=np.float64))
            ys.append(np.asarray(extent[2:], dtype=np.float64))
    # One array at a time: a long run is never copied whole several times over.
    x_ranges = [r for r in map(_finite_range, xs) if r is not None]
    y_ranges = [r for r in map(_finite_range, ys) if r is not None]
    if not x_ranges or not y_ranges:
        return -1.0, 1.0, -1.0, 1.0
    x0, x1 = min(r[0] for r in x_ranges), max(r[1] for r in x_ranges)
    y0, y1 = min(r[0] for r in y_ranges), max(r[1] for r in y_ranges)
    margin = 0.06 * max(x1 - x0, y1 - y0, 0.5)
    return float(x0 - margin), float(x1 + margin), float(y0 - margin), float(y1 + margin)


def _finite_range(values: FloatArray) -> tuple[float, float] | None:
    """(min, max) of the finite values, None if there are none."""
    kept = values[np.isfinite(values)]
    if kept.size == 0:
        return None
    return float(kept.min()), float(kept.max())


def _sample_at(result: RunResult, time: float) -> int:
    """First sample at or after ``time``."""
    k = int(np.searchsorted(result.t, time - 1e-9 * result.dt, side="left"))
    return min(k, result.samples - 1)


def _draw_path(ax: Axes, result: RunResult) -> None:
    if result.samples == 0:
        return
    every = thin(0, result.samples)
    ax.plot(
        finite(result.x_est[every]),
        finite(result.y_est[every]),
        color="0.55",
        linewidth=0.8,
        linestyle=":",
        label="estimate",
    )
    segments = phase_segments(result.phase)
    if len(segments) > MAX_NAMED_PHASES:
        _draw_path_by_phase(ax, result)
        return
    labelled: set[int] = set()
    for index, start, end in segments:
        color = phase_color(index)
        name = result.phases[index].name
        # Include the next phase's first sample so the coloured pieces join.
        k = thin(start, min(end + 1, result.samples))
        ax.plot(
            finite(result.x[k]),
            finite(result.y[k]),
            color=color,
            linewidth=1.6,
            label=name if index not in labelled else None,
        )
        labelled.add(index)
        ref = thin(start, end)
        if np.isfinite(result.x_ref[ref]).any():
            ax.plot(
                finite(result.x_ref[ref]),
                finite(result.y_ref[ref]),
                color=color,
                linewidth=1.0,
                linestyle="--",
                alpha=0.9,
                label=f"{name} reference",
            )


def _draw_path_by_phase(ax: Axes, result: RunResult) -> None:
    """The path coloured by phase as one collection: thinned over the whole
    run, not per phase."""
    from matplotlib.collections import LineCollection

    k = thin(0, result.samples)
    points = np.column_stack([finite(result.x[k]), finite(result.y[k])])
    pieces = np.stack([points[:-1], points[1:]], axis=1)
    colors = [phase_color(int(index)) for index in result.phase[k[:-1]]]
    ax.add_collection(LineCollection(list(pieces), colors=colors, linewidths=1.6, label="path"))
    reference = np.column_stack([finite(result.x_ref[k]), finite(result.y_ref[k])])
    if np.isfinite(reference).any():
        ax.plot(*reference.T, color="0.3", linewidth=1.0, linestyle="--", label="reference")


def _draw_marks(ax: Axes, result: RunResult) -> None:
    if result.samples == 0:
        return
    targets = sorted({p.target[:2] for p in result.phases if p.target is not None})
    if targets:
        ax.plot(
            *np.array(targets).T,
            marker="+",
            color="black",
            markersize=12,
            mew=1.5,
            linestyle="none",
            label="target",
        )
    changes = [tr for tr in result.transitions if tr.to_phase is not None]
    view = view_box(result)
    near = 0.03 * max(view[1] - view[0], view[3] - view[2])
    if len(changes) > MAX_NAMED_PHASES:
        at = np.array([_sample_at(result, tr.time) for tr in changes], dtype=np.int64)
        ax.plot(
            result.x[at], result.y[at], marker="D", color="black", markersize=3,
            linestyle="none", label="phase change",
        )  # fmt: skip
        changes = []
    labelled: list[tuple[float, float]] = []
    for i, tr in enumerate(changes):
        k = _sample_at(result, tr.time)
        point = (float(result.x[k]), float(result.y[k]))
        # Changes at (nearly) the same place get their labels stacked, not overprinted.
        stacked = sum(math.dist(point, other) < near for other in labelled)
        labelled.append(point)
        ax.plot(
            result.x[k],
            result.y[k],
            marker="D",
            color="black",
            markersize=5,
            linestyle="none",
            label="phase change" if i == 0 else None,
        )
        ax.annotate(
            f"{tr.to_phase} ({tr.condition}, t={tr.time:.2f} s)",
            point,
            xytext=(6, 6 - 11 * stacked),
            textcoords="offset points",
            fontsize=8,
        )
    ax.plot(
        result.x[0],
        result.y[0],
        marker="o",
        markerfacecolor="white",
        markeredgecolor="black",
        markersize=8,
        linestyle="none",
        label="start",
    )
    ax.plot(
        result.x[-1],
        result.y[-1],
        marker="s",
        color="black",
        markersize=7,
        linestyle="none",
        label="end",
    )


def draw_xy(result: RunResult, path: Path) -> Path:
    """The path in the plane, coloured by phase, like the paper's Fig. 2 and 3."""
    plt = pyplot()
    fig, ax = plt.subplots(figsize=(9, 6.5))
    view = view_box(result)
    draw_regions(ax, result.regions, view)
    _draw_path(ax, result)
    _draw_marks(ax, result)
    ax.set_xlim(view[0], view[1])
    ax.set_ylim(view[2], view[3])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{result.mission_name}: path in the plane ({result.outcome.value})")
    ax.grid(True, linewidth=0.4, alpha=0.5)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    return _save(fig, path)


# --- time plots -----------------------------------------------------------


def _mark_phases(axes: list[Axes], result: RunResult) -> None:
    """Phase boundaries as vertical lines; names written above the top plot."""
    segments = phase_segments(result.phase)
    if len(segments) > MAX_NAMED_PHASES:
        # Thousands of boundaries would only fill the plot: none are drawn.
        return
    span = float(result.t[-1] - result.t[0]) if result.samples else 0.0
    row, previous = 0, -math.inf
    for number, (index, start, _end) in enumerate(segments):
        time = float(result.t[start])
        if number > 0:
            for ax in axes:
                ax.axvline(time, color="0.4", linewidth=0.8, linestyle=":")
        # Names of phases that start close together go on staggered rows.
        row = (row + 1) % 3 if time - previous < 0.12 * span else 0
        previous = time
        axes[0].text(
            time,
            1.02 + 0.09 * row,
            f" {result.phases[index].name}",
            transform=axes[0].get_xaxis_transform(),
            fontsize=8,
            color=phase_color(index),
            va="bottom",
            ha="left",
        )


def _draw_measurements(
    ax: Axes, t: FloatArray, values: FloatArray, label: str = "measurement"
) -> None:
    """The measurements as dots (none where lost, between periods or unmeasured)."""
    seen = np.isfinite(values)
    if seen.any():
        ax.plot(
            t[seen], values[seen], linestyle="none", marker=".", markersize=2.0,
            color="tab:gray", alpha=0.6, label=label, zorder=1,
        )  # fmt: skip


def draw_states(result: RunResult, path: Path) -> Path:
    """True state against its estimate over time."""
    plt = pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True)
    k = thin(0, result.samples)
    t = result.t[k]
    for index, (ax, state) in enumerate(zip(axes, ("x", "y", "theta"), strict=True)):
        _draw_measurements(ax, t, result.measurement_column(index)[k])
        ax.plot(t, finite(getattr(result, state)[k]), color="tab:blue", linewidth=1.2, label="true")
        ax.plot(
            t,
            finite(getattr(result, f"{state}_est")[k]),
            color="tab:orange",
            linewidth=1.0,
            linestyle="--",
            label="estimate",
        )
        ax.set_ylabel(STATE_LABELS[state])
        ax.grid(True, linewidth=0.4, alpha=0.5)
    axes[0].legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    _mark_phases(list(axes), result)
    fig.suptitle(f"{result.mission_name}: states and estimates")
    return _save(fig, path)


def draw_estimation_error(result: RunResult, path: Path) -> Path:
    """Estimation error (true - estimate) per state with the output-error bounds of eq. (4)."""
    plt = pyplot()
    fig, axes = plt.subplots(3, 1, figsize=(9, 7.5), sharex=True)
    k = thin(0, result.samples)
    t = result.t[k]
    errors = estimation_errors(result)
    for index, (ax, state, bounds) in enumerate(
        zip(axes, ("x", "y", "theta"), result.error_bounds, strict=True)
    ):
        # The measurement's own error (true - measured) beside the estimate's.
        measured = result.measurement_column(index)[k]
        _draw_measurements(ax, t, getattr(result, state)[k] - measured, "measurement error")
        ax.plot(t, finite(errors[state][k]), color="tab:blue", linewidth=1.2, label="error")
        for i, bound in enumerate(bounds):
            if math.isfinite(bound):
                ax.axhline(
                    bound,
                    color="tab:red",
                    linewidth=1.0,
                    linestyle="--",
                    label="eq. (4) bound" if i == 0 else None,
                )
        # Linear near zero, logarithmic beyond: the 1 m start and the 0.05 band both show.
        ax.set_yscale("symlog", linthresh=0.01)
        reach = np.abs(np.concatenate([errors[state][k], np.asarray(bounds)]))
        reach = reach[np.isfinite(reach)]
        top = 1.5 * max(float(reach.max()) if reach.size else 0.0, 0.1)
        ax.set_ylim(-top, top)
        ax.set_ylabel(f"{state} error [{'rad' if state == 'theta' else 'm'}]")
        ax.grid(True, linewidth=0.4, alpha=0.5)
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    _mark_phases(list(axes), result)
    fig.suptitle(f"{result.mission_name}: estimation error (true - estimate)")
    return _save(fig, path)


def draw_inputs(result: RunResult, path: Path) -> Path:
    """Linear speed and turn rate with their limits."""
    plt = pyplot()
    fig, axes = plt.subplots(2, 1, figsize=(9, 5.5), sharex=True)
    k = thin(0, result.samples)
    t = result.t[k]
    for ax, name, label, limit in zip(
        axes,
        ("v", "omega"),
        ("v [m/s]", "omega [rad/s]"),
        result.limits,
        strict=True,
    ):
        values = finite(getattr(result, name)[k])
        ax.plot(t, values, color="tab:blue", linewidth=1.0, drawstyle="steps-post", label=name)
        if math.isfinite(limit):
            unit = label.split(" ")[1].strip("[]")
            peak = float(np.nanmax(np.abs(values))) if np.isfinite(values).any() else 0.0
            # Far-away limits would flatten the signal: name them instead of drawing them.
            shown = peak >= 0.5 * limit
            for sign in (1.0, -1.0):
                ax.axhline(
                    sign * limit,
                    color="tab:red",
                    linewidth=1.0,
                    linestyle="--",
                    label=(f"limit ±{limit:g} {unit}" + ("" if shown else " (off scale)"))
                    if sign > 0
                    else None,
                )
            if not shown and np.isfinite(values).any():
                low, high = np.nanmin(values), np.nanmax(values)
                margin = max(0.1 * (high - low), 0.05 * limit)
                ax.set_ylim(low - margin, high + margin)
        ax.set_ylabel(label)
        ax.grid(True, linewidth=0.4, alpha=0.5)
        ax.legend(loc="upper right", fontsize=8)
    axes[-1].set_xlabel("t [s]")
    _mark_phases(list(axes), result)
    fig.suptitle(f"{result.mission_name}: inputs")
    return _save(fig, path)


def draw_all(result: RunResult, out_dir: Path) -> list[Path]:
    """Write the four figures into ``out_dir``; return their paths."""
    directory = Path(out_dir)
    return [
        draw_xy(result, directory / "xy.png"),
        draw_states(result, directory / "states.png"),
        draw_estimation_error(result, directory / "estimation_error.png"),
        draw_inputs(result, directory / "inputs.png"),
    ]


def replot_command(run_dir: Path) -> int:
    """``wmr-mission plot RUN_DIR``: re-draw the figures from the saved data."""
    try:
        result = load_run(run_dir)
        paths = draw_all(result, run_dir)
    except (RunDirError, OSError) as exc:
        print(f"{run_dir}: {exc}", file=sys.stderr)
        return 1
    for path in paths:
        print(path)
    return 0
