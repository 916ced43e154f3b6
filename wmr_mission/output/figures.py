"""Figures of a run: the path in the plane, states, estimation error, inputs.

Two ways in, one drawing code:

* ``plot_xy``, ``plot_states``, ``plot_estimation_error``, ``plot_inputs`` draw
  on axes a caller gives (or new ones from pyplot) and return them: for
  notebooks. They never change matplotlib's backend.
* ``draw_all`` writes the figure files of a run directory (``xy.png`` ...) on
  figures of their own (``matplotlib.figure.Figure``, no pyplot), in PNG, SVG
  or PDF.

matplotlib is imported inside the functions, so importing this module (and
``wmr-mission validate``) stays light. Long runs are thinned to at most
``MAX_POINTS_PER_LINE`` points per line: a 360 000-sample run plots in a few
seconds.
"""

from __future__ import annotations

import math
import textwrap
import warnings
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np

from wmr_mission.basics import STATES, FloatArray, IntArray
from wmr_mission.geometry.regions import box_corners
from wmr_mission.kernels.resident import (
    LONG_RUN,
    collecting_new_objects_only,
    give_back_compiler_pages,
    give_back_freed_heap,
)
from wmr_mission.output.files import atomic_path
from wmr_mission.verdicts.metrics import (
    convergence_index,
    estimation_errors,
    phase_segments,
    wrap_angle,
)

if TYPE_CHECKING:
    from matplotlib.artist import Artist
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure
    from matplotlib.legend import Legend

    from wmr_mission.record import RunRecord
    from wmr_mission.verdicts.signals import Check, Mask

__all__ = [
    "FIGURE_FORMATS",
    "FIGURE_NAMES",
    "STYLES",
    "draw_all",
    "phase_colors",
    "plot_estimation_error",
    "plot_inputs",
    "plot_states",
    "plot_verdicts",
    "plot_xy",
    "save_figure",
]

MAX_POINTS_PER_LINE = 20_000
DPI = 120
PAD = 0.1  # margin round a figure's drawing [in]
# Points per piece of a long line when drawing files: Agg's memory grows with
# the length of one piece in pixels, so a run of many laps is drawn in pieces.
LINE_PIECE = 1000
# Bottom of the estimation figure's axes: room below for its legend.
ESTIMATION_BOTTOM = 0.14
# Pillow writes the PNGs at zlib level 1: 22 ms for case study 2's xy.png
# against 30 ms at its default, the file 19 % larger (`python
# benchmarks/measure.py png`).
PNG_OPTIONS: dict[str, Any] = {"compress_level": 1}
STATE_LABELS = {"x": "x [m]", "y": "y [m]", "theta": "theta [rad]"}
FIGURE_FORMATS = ("png", "svg", "pdf")
# TrueType (Type 42) fonts in PDF and PostScript, which publishers accept (Type
# 3, matplotlib's default, is refused by IEEE's checker); text as text in SVG.
FONT_RC: dict[str, Any] = {"pdf.fonttype": 42, "ps.fonttype": 42, "svg.fonttype": "none"}


@dataclass(frozen=True)
class Style:
    """How a figure is sized for where it goes: ``width`` [in] of the figure
    (None: as drawn, for a screen), its texts' sizes and its lines' widths
    scaled; colours are never changed (the paper's stay)."""

    width: float | None
    font_scale: float = 1.0
    line_scale: float = 1.0


# One and two columns of a two-column journal (IEEE: 3.5 in and 7.16 in). A
# PNG at another dpi (`plot --dpi 300`) has its text measured, and the axes
# laid out round it, at that resolution: the width moves by 1 to 2 %.
STYLES: dict[str, Style] = {
    "screen": Style(None),
    "one-column": Style(3.5, font_scale=0.75, line_scale=0.6),
    "two-column": Style(7.16, font_scale=0.9, line_scale=0.8),
}
# The range `plot --dpi` takes: below it text is unreadable, above it a
# screen-sized figure (verdicts.png, 10 x 10 in) is over 30 megapixels.
DPI_RANGE = (50, 600)
# The verdicts first: a failing run's figures open on its failure.
FIGURE_NAMES = ("verdicts", "xy", "states", "estimation_error", "inputs")
# The reference is drawn over the path, thin and dark, so a well-tracked path
# does not hide it.
REFERENCE_STYLE: dict[str, Any] = {
    "color": "black",
    "linewidth": 0.8,
    "linestyle": (0, (4, 3)),
    "alpha": 0.8,
    "zorder": 4,
}
# Width of one character of a phase label, as a fraction of a 9-inch axis.
CHARACTER_WIDTH = 0.009
# Rows of the xy legend that fit beside the axes; longer legends take more columns.
LEGEND_ROWS = 20
# The xy figure of a file [in]: the axes, and room at the right for a
# legend of one column, widened by LEGEND_COLUMN_WIDTH for each further column.
XY_WIDTH, XY_LEFT, XY_AXES_WIDTH = 11.5, 0.8, 7.7
LEGEND_COLUMN_WIDTH = 2.8
# Phases the xy legend names; the others are counted in its last entry.
MAX_LEGEND_PHASES = 2 * LEGEND_ROWS
# Heading arrows along the path of the xy figure (evenly by distance), and one at its end.
HEADING_ARROWS = 16
# Phase boundaries drawn over time: about one per pixel of a figure's width.
MAX_PHASE_LINES = 1000
# Places of phase changes numbered on the xy figure, evenly chosen when there are more.
MAX_CHANGE_LABELS = 40
# The fewest characters a legend's label is wrapped to on a narrow figure.
MIN_LABEL_CHARACTERS = 12
# Phases named on a region only some phases keep; more are counted.
MAX_KEEPERS_NAMED = 3


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


def phase_colors(result: RunRecord) -> list[Any]:
    """One colour per phase: the mission's `plot.phase_colors`, else a palette.

    Up to 10 phases take matplotlib's tab10; more take evenly spaced colours of
    a continuous map, visited with a stride so that neighbours differ: colours
    never repeat.
    """
    from matplotlib import colormaps

    count = len(result.phases)
    if count <= 10:
        palette = [colormaps["tab10"](i) for i in range(count)]
    else:
        spread = colormaps["turbo"](np.linspace(0.05, 0.95, count))
        stride = next(s for s in range(max(2, count // 3), count) if math.gcd(s, count) == 1)
        palette = [tuple(spread[(i * stride) % count]) for i in range(count)]
    return [
        info.color if info.color is not None else palette[i] for i, info in enumerate(result.phases)
    ]


def new_figure(figsize: tuple[float, float]) -> Figure:
    """A figure outside pyplot: no backend, no global state, nothing to close."""
    from matplotlib.figure import Figure

    return Figure(figsize=figsize, dpi=DPI)


def _pyplot_figure(figsize: tuple[float, float]) -> Figure:
    """A figure from pyplot, with whatever backend the caller uses (a notebook's)."""
    import matplotlib.pyplot as plt

    figure: Figure = plt.figure(figsize=figsize)
    return figure


def names_as_typed(drawn: Artist) -> None:
    """Names are data: a '$' in a mission, phase or region name is drawn as typed,
    never parsed as math (unbalanced, it would stop the drawing). Set on the
    figure's texts, not in rcParams, so that a notebook's settings stay its own.

    The axes' axis (ticks and axis labels) are passed over: they hold numbers
    and fixed words, and walking them would make every tick before the figure
    has its final size, ticks the drawing then throws away.
    """
    from matplotlib.axis import Axis
    from matplotlib.text import Text

    for child in drawn.get_children():
        if isinstance(child, Text):
            child.set_parse_math(False)
        elif not isinstance(child, Axis):
            names_as_typed(child)


def save_figure(fig: Figure, path: Path, dpi: int = DPI) -> Path:
    """Write ``fig`` in the format its suffix names, cropped to what is drawn
    with a margin of PAD inches, through a temporary file; ``dpi`` sets a
    PNG's pixels (and the resolution of what a PDF or SVG rasterizes)."""
    from matplotlib import rc_context

    options: dict[str, Any] = {"pil_kwargs": PNG_OPTIONS} if path.suffix == ".png" else {}
    # Long lines in pieces: a line round many laps would otherwise take Agg
    # tens of megabytes of scanline cells. Fonts as publishers take them.
    settings: dict[Any, Any] = {"agg.path.chunksize": LINE_PIECE, **FONT_RC}
    with atomic_path(path) as tmp, rc_context(settings):
        fig.savefig(
            tmp, format=path.suffix[1:], dpi=dpi, bbox_inches="tight", pad_inches=PAD, **options
        )
    return path


# --- regions --------------------------------------------------------------


def region_extent(region: dict[str, Any]) -> tuple[float, float, float, float] | None:
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
    if kind in ("box", "polygon"):
        vertices = (
            box_corners(region)
            if kind == "box"
            else np.asarray(region["vertices"], dtype=np.float64)
        )
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


class Keeping(NamedTuple):
    """How a run keeps one region: ``side``, ``inside`` or ``outside`` (``both``
    when its phases differ); ``phases``, the phases that keep it (as written,
    each once, in run order) when a phase that ran does not, else None: kept
    throughout, by every phase that ran or by the geofence."""

    side: str
    phases: tuple[str, ...] | None = None


def region_sides(result: RunRecord) -> dict[str, Keeping]:
    """Per constrained region (by a phase or by the geofence), how the robot keeps it."""
    fence = (result.mission or {}).get("geofence") or {}
    kept = [(name, "inside") for name in fence.get("keep_in", ())]
    kept += [(name, "outside") for name in fence.get("keep_out", ())]
    fenced = {name for name, _ in kept}
    for info in result.phases:
        kept += list(info.constraints)
    sides: dict[str, str] = {}
    for name, side in kept:
        sides[name] = side if sides.get(name, side) == side else "both"
    ran = set(np.unique(result.phase).tolist()) if result.samples else set()
    keeping: dict[str, Keeping] = {}
    for name, side in sides.items():
        keepers = [i for i, info in enumerate(result.phases) if _keeps(info.constraints, name)]
        if name in fenced or ran <= set(keepers):
            keeping[name] = Keeping(side)
        else:  # a lap runs as name#lap: named once, as the mission writes it
            written = (result.phases[i].name.split("#", 1)[0] for i in keepers)
            keeping[name] = Keeping(side, tuple(dict.fromkeys(written)))
    return keeping


def _keeps(constraints: tuple[tuple[str, str], ...], region: str) -> bool:
    return any(name == region for name, _ in constraints)


def keeping_words(keeping: Keeping) -> str:
    """How a region is kept, in words: ``kept out of``, ``kept in``; a region
    only some phases keep names them, ``kept out by phase B only``."""
    if keeping.phases is None:
        return {"outside": "kept out of", "inside": "kept in"}.get(keeping.side, "")
    how = {"outside": "kept out", "inside": "kept in"}.get(keeping.side, "kept in or out")
    names = keeping.phases
    if len(names) > MAX_KEEPERS_NAMED:
        shown = names[: MAX_KEEPERS_NAMED - 1]
        listed = f"{', '.join(shown)} and {len(names) - len(shown)} more"
    else:
        listed = ", ".join(names)
    return f"{how} by phase{'s' if len(names) > 1 else ''} {listed} only"


def draw_regions(
    ax: Axes,
    regions: dict[str, Any],
    view: tuple[float, float, float, float],
    sides: Mapping[str, Keeping] | None = None,
) -> None:
    """Each region as a patch with its outline; a half-plane is shaded inside ``view``.

    ``sides`` (:func:`region_sides`): a zone kept out of is hatched and
    reddish, a zone kept in light grey, a region no phase constrains only
    outlined: a keep-out pond and a keep-in yard do not look alike. Greys and a
    faint red, so that regions never compete with the phases' colours. A zone
    only some phases keep is named on the figure with those phases
    (``rock: kept out by phase B only``): a path that crosses it in another
    phase broke no rule, and the hatching alone would say it did.
    """
    from matplotlib import patches

    sides = sides or {}
    for name, region in regions.items():
        kind = region.get("type")
        keeping = sides.get(name)
        side = None if keeping is None else keeping.side
        style: dict[str, Any] = {
            "facecolor": (0.5, 0.5, 0.5, 0.07 if kind == "half-plane" else 0.1),
            "edgecolor": "0.35",
            "linewidth": 1.0,
            "zorder": 1,
        }
        if side == "outside":
            style |= {"facecolor": (0.84, 0.15, 0.16, 0.12), "hatch": "///", "edgecolor": "0.3"}
        elif side is None and sides:
            style |= {"facecolor": "none", "linestyle": ":"}
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
        elif kind == "box" and region.get("min") is not None:
            (x0, y0), (x1, y1) = region["min"], region["max"]
            patch = patches.Rectangle((x0, y0), x1 - x0, y1 - y0, **style)
        elif kind == "box":  # turned by its heading
            patch = patches.Polygon(box_corners(region), **style)
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
        words = "" if keeping is None else keeping_words(keeping)
        patch.set_label(f"region {name}" + (f" ({words})" if words else ""))
        ax.add_patch(patch)
        if keeping is not None and keeping.phases is not None:
            _name_on_region(ax, region, view, f"{name}: {words}")


def _name_on_region(
    ax: Axes, region: dict[str, Any], view: tuple[float, float, float, float], text: str
) -> None:
    """``text`` as a tab on a bounded region: above its top corner on the side
    of the view's middle, where a path round the region is not and the text
    runs into the view (a half-plane: at the middle of its part of ``view``)."""
    extent = region_extent(region)
    if extent is not None and extent[0] < (view[0] + view[1]) / 2:
        at, align, ha = (extent[0], extent[3]), "bottom", "left"
    elif extent is not None:
        at, align, ha = (extent[1], extent[3]), "bottom", "right"
    else:
        normal = (float(region["normal"][0]), float(region["normal"][1]))
        seen = _clip_half_plane(view, normal, float(region["offset"]))
        if seen.shape[0] < 3:
            return
        at, align, ha = (float(seen[:, 0].mean()), float(seen[:, 1].mean())), "center", "center"
    tab = ax.annotate(
        text,
        at,
        xytext=(0, 3 if align == "bottom" else 0),
        textcoords="offset points",
        ha=ha,
        va=align,
        fontsize=8,
        color="0.15",
        zorder=8,
        bbox={"boxstyle": "round,pad=0.2", "facecolor": "white", "alpha": 0.75, "linewidth": 0},
    )
    # Inside the axes: a layout that made room for it would shrink the axes,
    # and with them its room, until a narrow figure has no axes left.
    tab.set_in_layout(False)


# --- the path in the plane ------------------------------------------------


def view_box(result: RunRecord) -> tuple[float, float, float, float]:
    """Data limits of the path, the reference, goals and bounded regions, with a margin."""
    xs = [result.x, result.x_est, result.x_ref]
    ys = [result.y, result.y_est, result.y_ref]
    marks = [p.target[:2] for p in result.phases if p.target is not None]
    marks += [p.near[:2] for p in result.phases if p.near is not None]
    marks += [point for p in result.phases for point in p.points]
    if marks:
        xs.append(np.array([m[0] for m in marks], dtype=np.float64))
        ys.append(np.array([m[1] for m in marks], dtype=np.float64))
    for region in result.regions.values():
        extent = region_extent(region)
        if extent is not None:
            xs.append(np.asarray(extent[:2], dtype=np.float64))
            ys.append(np.asarray(extent[2:], dtype=np.float64))
    x_range, y_range = _finite_range(xs), _finite_range(ys)
    if x_range is None or y_range is None:
        return -1.0, 1.0, -1.0, 1.0
    (x0, x1), (y0, y1) = x_range, y_range
    margin = 0.06 * max(x1 - x0, y1 - y0, 0.5)
    return x0 - margin, x1 + margin, y0 - margin, y1 + margin


def _finite_range(arrays: list[FloatArray]) -> tuple[float, float] | None:
    """Smallest and largest finite value of the arrays, one array at a time
    (a long run's columns are not copied together)."""
    low, high = math.inf, -math.inf
    for values in arrays:
        kept = values[np.isfinite(values)]
        if kept.size:
            low, high = min(low, float(kept.min())), max(high, float(kept.max()))
    return (low, high) if low <= high else None


def _sample_at(result: RunRecord, time: float) -> int:
    """First sample at or after ``time``."""
    k = int(np.searchsorted(result.t, time - 1e-9 * result.dt, side="left"))
    return min(k, result.samples - 1)


def _draw_path(ax: Axes, result: RunRecord, colors: list[Any]) -> None:
    """The estimate, the true path coloured by phase (one collection, whatever
    the number of phases) and the reference (one line, broken between phases)."""
    from matplotlib.collections import LineCollection

    every = thin(0, result.samples)
    ax.plot(
        finite(result.x_est[every]),
        finite(result.y_est[every]),
        color="0.5",
        linewidth=0.8,
        linestyle=":",
        label="estimate",
        zorder=3,
    )
    segments = phase_segments(result)
    starts = np.array([entry.start for entry in segments], dtype=np.int64)
    # Thinned once for the whole run, each phase's first and last sample kept.
    kept = np.union1d(every, np.concatenate((starts, np.maximum(starts - 1, 0))))
    cuts = np.searchsorted(kept, starts[1:])
    x, y = finite(result.x[kept]), finite(result.y[kept])
    # Each phase's line runs to the next phase's first sample, so the coloured
    # lines join; it is cut into pieces of LINE_PIECE points (for Agg's memory).
    pieces, piece_colors = [], []
    for (index, *_), a, b in zip(segments, np.r_[0, cuts], np.r_[cuts, kept.size - 1], strict=True):
        for start in range(a, max(a + 1, b), LINE_PIECE - 1):
            stop = min(start + LINE_PIECE, b + 1)
            pieces.append(np.column_stack((x[start:stop], y[start:stop])))
            piece_colors.append(colors[index])
    ax.add_collection(
        LineCollection(
            pieces,
            colors=piece_colors,
            linewidths=2.2,
            capstyle="round",
            joinstyle="round",
            zorder=2,
        ),
        autolim=False,
    )
    x_ref, y_ref = (
        np.insert(finite(result.x_ref[kept]), cuts, np.nan),
        np.insert(finite(result.y_ref[kept]), cuts, np.nan),
    )
    if np.isfinite(x_ref).any():
        ax.plot(x_ref, y_ref, label="reference", **REFERENCE_STYLE)


def _phase_handles(result: RunRecord, colors: list[Any]) -> list[Any]:
    """One legend entry per phase, numbered as on the figure (those that did
    not run say so)."""
    from matplotlib.lines import Line2D

    ran = set(np.unique(result.phase).tolist()) if result.samples else set()
    every = range(len(result.phases))
    shown = every if len(every) <= MAX_LEGEND_PHASES else every[: MAX_LEGEND_PHASES - 1]
    handles = [
        Line2D([], [], color=colors[i], linewidth=2.2, label=f"{i + 1} {result.phases[i].name}")
        if i in ran
        # listed all the same, so that the numbers run on: 1, 2, 3, 4 (did not run), 5
        else Line2D(
            [], [], linestyle="none", label=f"{i + 1} {result.phases[i].name} (did not run)"
        )
        for i in shown
    ]
    if len(shown) < len(every):
        last = len(every)
        more = f"... {last - len(shown)} more, to {last} {result.phases[-1].name}"
        handles.append(Line2D([], [], linestyle="none", label=more))
    return handles


def _draw_goals(ax: Axes, result: RunRecord, size: float) -> None:
    """Regulate targets, `near` goals (a circle of their tolerance) and path
    points: one artist per kind, however many phases."""
    from matplotlib import patches
    from matplotlib.collections import PatchCollection

    targets = sorted({p.target[:2] for p in result.phases if p.target is not None})
    if targets:
        ax.plot(
            [t[0] for t in targets],
            [t[1] for t in targets],
            marker="+",
            color="black",
            markersize=12,
            mew=1.5,
            linestyle="none",
            label="target",
            zorder=6,
        )
    missed = _missed_goal(result)
    goals = sorted({p.near for p in result.phases if p.near is not None})
    reached = [goal for goal in goals if goal != missed]
    for chosen, color, label in (
        (reached, "black", "near goal"),
        ([goal for goal in goals if goal == missed], "tab:red", "near goal not reached"),
    ):
        if not chosen:
            continue
        # A tolerance circle too small to see is left out.
        circles = [patches.Circle((gx, gy), r) for gx, gy, r in chosen if r >= 0.005 * size]
        if circles:
            ax.add_collection(
                PatchCollection(
                    circles,
                    facecolors="none",
                    edgecolors=color,
                    linewidths=0.8,
                    linestyles="--",
                    zorder=6,
                ),
                autolim=False,
            )
        ax.plot(
            [g[0] for g in chosen],
            [g[1] for g in chosen],
            marker="x",
            color=color,
            markersize=7,
            mew=1.5,
            linestyle="none",
            label=label,
            zorder=6,
        )
    points = sorted({point for p in result.phases for point in p.points})
    if points:
        ax.plot(
            [p[0] for p in points],
            [p[1] for p in points],
            marker="o",
            markersize=4,
            markerfacecolor="white",
            markeredgecolor="0.2",
            linestyle="none",
            label="waypoint",
            zorder=5,
        )


def _missed_goal(result: RunRecord) -> tuple[float, float, float] | None:
    """The `near` goal of a phase that timed out waiting for it."""
    for tr in result.transitions:
        if tr.to_phase is None and tr.condition == "timeout":
            info = next((p for p in result.phases if p.name == tr.from_phase), None)
            if info is not None and info.near is not None:
                return info.near
    return None


def _change_places(
    result: RunRecord, radius: float
) -> list[tuple[tuple[float, float], dict[int, None]]]:
    """Each place of phase changes and the numbers of the phases entered there,
    in order: a change within ``radius`` of an earlier place joins the first such place."""
    number = {info.name: i + 1 for i, info in enumerate(result.phases)}
    places: list[tuple[tuple[float, float], dict[int, None]]] = []  # numbers kept in order
    # Places by grid cell of side ``radius``: those near a point are in the 3 x 3 cells round it.
    cells: dict[tuple[int, int], list[int]] = {}
    for tr in result.transitions:
        if tr.to_phase is None or tr.condition == "update":  # updates: _draw_updates
            continue
        k = _sample_at(result, tr.time)
        point = (float(result.x[k]), float(result.y[k]))
        if not all(math.isfinite(v) for v in point):
            continue
        cx, cy = math.floor(point[0] / radius), math.floor(point[1] / radius)
        near = [
            i
            for dx in (-1, 0, 1)
            for dy in (-1, 0, 1)
            for i in cells.get((cx + dx, cy + dy), ())
            if math.dist(places[i][0], point) < radius
        ]
        if not near:
            cells.setdefault((cx, cy), []).append(len(places))
            places.append((point, {}))
        places[min(near, default=len(places) - 1)][1][number[str(tr.to_phase)]] = None
    return places


def _draw_changes(ax: Axes, result: RunRecord, size: float) -> None:
    """Each phase change as a dot labelled with the number of the phase it enters;
    changes at (nearly) one place share one label ("2,3"). At most
    MAX_CHANGE_LABELS places are labelled, evenly chosen, so that the drawing
    costs the same however many phases there are."""
    places = _change_places(result, 0.04 * size)
    if not places:
        return
    ax.plot(
        [point[0] for point, _ in places],
        [point[1] for point, _ in places],
        marker="o",
        color="black",
        markersize=3.5,
        linestyle="none",
        label="phase change (number of the next phase)",
        zorder=7,
    )
    for point, numbers in places[:: math.ceil(len(places) / MAX_CHANGE_LABELS)]:
        shown = list(numbers) if len(numbers) <= 4 else [*list(numbers)[:3], "..."]
        ax.annotate(
            ",".join(str(n) for n in shown),
            point,
            xytext=(4, 4),
            textcoords="offset points",
            fontsize=7,
            zorder=8,
            bbox={
                "boxstyle": "round,pad=0.15",
                "facecolor": "white",
                "edgecolor": "none",
                "alpha": 0.8,
            },
        )


def _draw_updates(ax: Axes, result: RunRecord) -> None:
    """Where each update's reference took over (docs/mission-format.md,
    "References that change on-line"), labelled with its number."""
    updates = [tr for tr in result.transitions if tr.condition == "update"]
    if not updates:
        return
    points = [_sample_at(result, tr.time) for tr in updates]
    ax.plot(
        [result.x[k] for k in points],
        [result.y[k] for k in points],
        marker="D",
        color="darkorange",
        markeredgecolor="black",
        markersize=6,
        linestyle="none",
        label="update (number of the reference taking over)",
        zorder=8,
    )
    for k, tr in zip(points[:MAX_CHANGE_LABELS], updates, strict=False):
        ax.annotate(
            f"ref {tr.value:g}",
            (float(result.x[k]), float(result.y[k])),
            xytext=(5, -11),
            textcoords="offset points",
            fontsize=7,
            zorder=9,
        )


def _draw_reactions(ax: Axes, result: RunRecord) -> None:
    """Each reaction that fired (a retry, a goto, a contingency, ...) where the
    robot was, labelled with the reaction as written; at most
    MAX_CHANGE_LABELS labels."""
    fired = [tr for tr in result.transitions if tr.reaction is not None]
    if not fired:
        return
    points = [_sample_at(result, tr.time) for tr in fired]
    ax.plot(
        [result.x[k] for k in points],
        [result.y[k] for k in points],
        marker="X",
        color="crimson",
        markeredgecolor="white",
        markersize=9,
        linestyle="none",
        label="reaction fired",
        zorder=9,
    )
    for tr, k in list(zip(fired, points, strict=True))[:MAX_CHANGE_LABELS]:
        ax.annotate(
            f"{tr.condition}: {tr.reaction}",
            (float(result.x[k]), float(result.y[k])),
            xytext=(6, -10),
            textcoords="offset points",
            fontsize=7,
            color="crimson",
            zorder=9,
            bbox={
                "boxstyle": "round,pad=0.15",
                "facecolor": "white",
                "edgecolor": "none",
                "alpha": 0.8,
            },
        )


def _draw_headings(ax: Axes, result: RunRecord, size: float) -> None:
    """The robot's heading as arrows, evenly along the path by distance and at
    its end: an arrow against the direction of travel is the robot reversing
    (a reverse-in dock), an arrow turning on the spot a turn in place."""
    finite = np.isfinite(result.x) & np.isfinite(result.y) & np.isfinite(result.theta)
    if finite.all():  # the columns themselves: a long run's are not copied
        x, y, theta = result.x, result.y, result.theta
    else:
        kept = np.flatnonzero(finite)
        if kept.size == 0:
            return  # a run diverged from its first sample
        x, y, theta = result.x[kept], result.y[kept], result.theta[kept]
    del finite
    # The distance travelled, in place: a long run's arrays a few at a time.
    steps, across = np.diff(x), np.diff(y)
    with np.errstate(all="ignore"):  # a diverging tail: its steps count for nothing
        np.hypot(steps, across, out=steps)
    del across
    steps[~np.isfinite(steps)] = 0.0
    travelled = np.empty(x.size)
    travelled[0] = 0.0
    np.cumsum(steps, out=travelled[1:])
    del steps
    stations = np.linspace(0.0, float(travelled[-1]), HEADING_ARROWS)
    at = np.unique(np.append(np.searchsorted(travelled, stations), x.size - 1).clip(0, x.size - 1))
    length = 0.035 * size
    ax.quiver(
        x[at],
        y[at],
        np.cos(theta[at]) * length,
        np.sin(theta[at]) * length,
        angles="xy",
        scale_units="xy",
        scale=1.0,
        width=0.004,
        color="0.15",
        zorder=5,
    )
    # A quiver has no legend entry of its own: a stand-in with the arrow's look.
    ax.plot(
        [],
        [],
        marker=r"$\rightarrow$",
        markersize=10,
        color="0.15",
        linestyle="none",
        label="heading",
    )


def _draw_footprint(ax: Axes, result: RunRecord) -> None:
    """The robot's body (robot.footprint) where its heading arrows are: what
    keeps the zones, where the path is only its axle's centre."""
    from matplotlib import patches

    footprint = ((result.mission or {}).get("robot") or {}).get("footprint")
    kept = np.flatnonzero(np.isfinite(result.x) & np.isfinite(result.y) & np.isfinite(result.theta))
    if not footprint or kept.size == 0:
        return
    x, y, theta = result.x[kept], result.y[kept], result.theta[kept]
    travelled = np.concatenate(([0.0], np.cumsum(np.hypot(np.diff(x), np.diff(y)))))
    stations = np.linspace(0.0, float(travelled[-1]), HEADING_ARROWS)
    at = np.unique(np.searchsorted(travelled, stations).clip(0, x.size - 1))
    style: dict[str, Any] = {
        "facecolor": "none",
        "edgecolor": "0.45",
        "linewidth": 0.7,
        "zorder": 4,
    }
    for k in at:
        patch: Any
        if "radius" in footprint:
            patch = patches.Circle((x[k], y[k]), float(footprint["radius"]), **style)
        else:
            corners = np.asarray(footprint["polygon"], dtype=np.float64)
            c, s = math.cos(theta[k]), math.sin(theta[k])
            placed = np.column_stack(
                [
                    x[k] + c * corners[:, 0] - s * corners[:, 1],
                    y[k] + s * corners[:, 0] + c * corners[:, 1],
                ]
            )
            patch = patches.Polygon(placed, **style)
        ax.add_patch(patch)
    patch.set_label("body (robot.footprint)")


def _draw_ends(ax: Axes, result: RunRecord) -> None:
    ax.plot(
        result.x[0],
        result.y[0],
        marker="o",
        markerfacecolor="white",
        markeredgecolor="black",
        markersize=8,
        linestyle="none",
        label="start",
        zorder=7,
    )
    ax.plot(
        result.x[-1],
        result.y[-1],
        marker="s",
        color="black",
        markersize=6,
        linestyle="none",
        label="end",
        zorder=7,
    )


def _xy_on(ax: Axes, result: RunRecord, label: str | None = None, color: Any = None) -> int:
    """Draw the path in the plane on ``ax`` (over a run drawn there before, if
    any); return the legend's columns."""
    overlay = ax.has_data()
    colors = phase_colors(result) if color is None else [color] * len(result.phases)
    view = view_box(result)
    if overlay:  # the view holds the runs drawn before
        (x0, x1), (y0, y1) = ax.get_xlim(), ax.get_ylim()
        view = (min(view[0], x0), max(view[1], x1), min(view[2], y0), max(view[3], y1))
    size = max(view[1] - view[0], view[3] - view[2])
    draw_regions(ax, result.regions, view, region_sides(result))
    if result.samples:
        _draw_path(ax, result, colors)
        _draw_headings(ax, result, size)
        _draw_footprint(ax, result)
        _draw_changes(ax, result, size)
        _draw_updates(ax, result)
        _draw_reactions(ax, result)
        _draw_ends(ax, result)
    _draw_goals(ax, result, size)
    if label is not None:  # an artist, so that a later overlay's legend keeps it
        ax.plot([], [], color=colors[0] if colors else "black", linewidth=2.2, label=label)
    ax.set_xlim(view[0], view[1])
    ax.set_ylim(view[2], view[3])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_title(f"{result.mission_name}: path in the plane ({result.outcome.value})")
    ax.grid(True, linewidth=0.4, alpha=0.5)
    # One colour per run (color=...) tells runs apart, not phases.
    phases = _phase_handles(result, colors) if color is None else []
    others, labels = ax.get_legend_handles_labels()
    # Each thing once: overlaid runs each draw a start, an end, regions...
    unique = dict(zip(labels, others, strict=True))
    handles = [*phases, *unique.values()]
    columns = math.ceil(len(handles) / LEGEND_ROWS)
    ax.legend(
        handles=handles,
        labels=[h.get_label() for h in phases] + list(unique),
        loc="upper left",
        bbox_to_anchor=(1.01, 1.0),
        fontsize=8,
        frameon=False,
        ncols=columns,
        title="phases" if phases else None,
        title_fontsize=8,
        alignment="left",
    )
    names_as_typed(ax)
    return columns


def plot_xy(
    result: RunRecord, ax: Axes | None = None, *, label: str | None = None, color: Any = None
) -> Axes:
    """The path in the plane, coloured by phase, over the regions (the paper's Fig. 2, 3).

    Draws on ``ax``, or on a new pyplot figure; returns the axes. To overlay
    runs on one axes, call it once per run: ``color`` draws this run's path in
    one colour (default: a colour per phase), ``label`` names it in the legend;
    the legend says each thing once and the view holds every run.
    """
    if ax is None:
        ax = _pyplot_figure((9, 6.5)).add_subplot()
    _xy_on(ax, result, label=label, color=color)
    return ax


# --- over time ------------------------------------------------------------


def _mark_phases(axes: Sequence[Axes], result: RunRecord, colors: list[Any]) -> None:
    """Phase boundaries as dotted lines (one collection per axes); above the top
    plot, each phase's number, and its name where its stretch is wide enough to
    hold it (the labels need room, so there are never more than about 50)."""
    from matplotlib.collections import LineCollection

    segments = phase_segments(result)
    t0 = float(result.t[0]) if result.samples else 0.0
    span = float(result.t[-1] - t0) if result.samples > 1 else 1.0
    changes = result.t[[entry.start for entry in segments[1:]]]
    # At most one line per MAX_PHASE_LINES-th of the run: more would only fill it in.
    _, apart = np.unique(np.floor((changes - t0) / span * MAX_PHASE_LINES), return_index=True)
    changes = changes[apart]
    # From the bottom to the top of each axes (x in data, y in axes units), as
    # axvline draws them; they leave the data limits alone.
    lines = [((time, 0.0), (time, 1.0)) for time in changes.tolist()]
    for ax in axes:
        ax.add_collection(
            LineCollection(
                lines,
                transform=ax.get_xaxis_transform(),
                colors="0.45",
                linewidths=0.7,
                linestyles=":",
            ),
            autolim=False,
        )
    free_from = -math.inf  # where the previous label ends [s]
    for index, start, end, _ in segments:
        time = float(result.t[start])
        stop = float(result.t[end - 1])
        name = result.phases[index].name
        # Label text takes about CHARACTER_WIDTH of the axis width per character.
        full, short = f"{index + 1} {name}", str(index + 1)
        at = max(time, free_from)  # pushed right past its neighbour's label
        chosen = None
        for label in (full, short):
            width = CHARACTER_WIDTH * (len(label) + 1) * span
            # The name only inside its own stretch; the number at least at its start.
            if at + width <= stop or (label == short and at == time):
                chosen = label
                break
        if chosen is None:
            continue  # no room: the xy legend names it
        free_from = at + width
        axes[0].text(
            at,
            1.02,
            chosen,
            transform=axes[0].get_xaxis_transform(),
            fontsize=7.5,
            color=colors[index],
            va="bottom",
            ha="left",
            clip_on=False,
        )


def _figure_axes(
    axes: Sequence[Axes] | None, shape: tuple[int, int], figsize: tuple[float, float]
) -> tuple[Figure, list[Axes]]:
    if axes is not None:
        chosen = list(np.asarray(axes, dtype=object).ravel())
        if len(chosen) != shape[0] * shape[1]:
            raise ValueError(f"expected {shape[0] * shape[1]} axes, got {len(chosen)}")
        return chosen[0].get_figure(), chosen
    figure = _pyplot_figure(figsize)
    made = figure.subplots(*shape, sharex="col", squeeze=False)
    return figure, list(made.ravel())


def _states_on(fig: Figure, axes: list[Axes], result: RunRecord) -> None:
    k = thin(0, result.samples)
    t = result.t[k]
    for ax, state in zip(axes, STATES, strict=True):
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
    # Beside the axes: a legend inside covers data.
    axes[0].legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    axes[-1].set_xlabel("t [s]")
    _mark_phases(axes, result, phase_colors(result))
    fig.suptitle(f"{result.mission_name}: states and estimates")
    names_as_typed(fig)


def plot_states(result: RunRecord, axes: Sequence[Axes] | None = None) -> Figure:
    """True state against its estimate over time: three axes (x, y, theta); returns the figure."""
    fig, chosen = _figure_axes(axes, (3, 1), (9, 7.5))
    _states_on(fig, chosen, result)
    return fig


def _start_window(result: RunRecord) -> float:
    """Seconds shown in the start column: five times the time the estimate
    takes to converge, at least 20 samples, at most the run."""
    if result.samples < 2:
        return 1.0
    duration = float(result.t[-1] - result.t[0])
    converged = convergence_index(estimation_errors(result))
    settle = float(result.t[converged] - result.t[0]) if converged is not None else duration
    return min(duration, max(5.0 * settle, 20.0 * result.dt, 0.1))


def _errors_at(result: RunRecord, state: str, k: IntArray) -> tuple[FloatArray, FloatArray]:
    """Measurement - estimate and true - estimate of ``state`` at samples ``k``
    (the heading's wrapped, as verdicts.metrics.estimation_errors has it)."""
    estimate = getattr(result, f"{state}_est")[k]
    true_error = getattr(result, state)[k] - estimate
    if state == "theta":
        true_error = wrap_angle(true_error)
    return finite(getattr(result, f"{state}_meas")[k] - estimate), finite(true_error)


def _estimation_on(fig: Figure, axes: list[Axes], result: RunRecord) -> None:
    """Left: the start, at full scale; right: the whole run, at the scale of the bounds.

    Eq. (4) bounds the output error, measurement - estimate, so the bounds are
    drawn with that; true - estimate, the estimation error, is drawn beside it,
    inside the estimator's own +-3 std where it holds one (the EKF's covariance).
    """
    from wmr_mission.fields import type_name
    from wmr_mission.output.covariance import band_estimator, estimate_std

    window = _start_window(result)
    spread = estimate_std(result)
    holder = band_estimator(result)  # the estimator, by its kind's name: "EKF" for `type: ekf`
    holder_name = type_name(holder.settings).upper() if holder is not None else ""
    early = thin(0, int(np.searchsorted(result.t, result.t[0] + window, side="right")))
    every = thin(0, result.samples)
    for row, (state, bounds) in enumerate(zip(STATES, result.error_bounds, strict=True)):
        unit = "rad" if state == "theta" else "m"
        measured = bool(np.isfinite(getattr(result, f"{state}_meas")).any())
        sensed = getattr(result, f"{state}_meas")
        for column, k in enumerate((early, every)):
            ax = axes[2 * row + column]
            _output_error, true_error = _errors_at(result, state, k)
            if measured:
                # At the samples measured (a slower sensor leaves NaN between
                # them): thinned among those, else the line would have no points.
                stop = int(k[-1]) + 1 if k.size else 0
                at = np.flatnonzero(np.isfinite(sensed[:stop]))
                at = at[thin(0, at.size)]
                ax.plot(
                    result.t[at],
                    _errors_at(result, state, at)[0],
                    color="tab:blue",
                    linewidth=1.8,
                    label="measurement - estimate",
                )
            # Dashed on top: without noise the two coincide, and both stay visible.
            ax.plot(
                result.t[k],
                true_error,
                color="tab:orange",
                linewidth=1.0,
                linestyle=(0, (3, 2)),
                label="true - estimate",
                zorder=3,
            )
            if spread is not None:
                band = 3.0 * spread[k, row]
                # Over the measurement's noise, under true - estimate; edged, so
                # that it reads as its legend's colour over the blue too.
                ax.fill_between(
                    result.t[k], -band, band, facecolor="tab:orange", alpha=0.25,
                    edgecolor="none", label=f"{holder_name} +-3 std (its covariance)", zorder=2.5,
                )  # fmt: skip
                for edge in (-band, band):
                    ax.plot(result.t[k], edge, color="tab:orange", linewidth=0.8, zorder=2.6)
            for i, bound in enumerate(bounds):
                if math.isfinite(bound):
                    ax.axhline(
                        bound,
                        color="tab:red",
                        linewidth=1.0,
                        linestyle="--",
                        label="eq. (4) bound" if i == 0 else None,
                    )
            ax.axhline(0.0, color="0.3", linewidth=0.5)
            ax.grid(True, linewidth=0.4, alpha=0.5)
        # The whole run at the scale of the bounds and of the error after the start.
        late = every[result.t[every] > result.t[0] + window]
        reach = [abs(b) for b in bounds if math.isfinite(b)]
        if spread is not None and np.isfinite(spread[late, row]).any():
            reach.append(3.0 * float(np.nanmax(spread[late, row])))
        for tail in _errors_at(result, state, late):
            tail = tail[np.isfinite(tail)]
            if tail.size:
                reach.append(float(np.abs(tail).max()))
        top = 1.3 * max(max(reach, default=0.0), 1e-6)
        axes[2 * row + 1].set_ylim(-top, top)
        axes[2 * row].set_ylabel(f"{state} error [{unit}]")
        if not measured:
            axes[2 * row + 1].text(
                0.99,
                0.04,
                f"{state} not measured",
                ha="right",
                transform=axes[2 * row + 1].transAxes,
                fontsize=8,
            )
    # Padded: the phase labels sit between the titles and the plots. At the
    # axes' top (y=1): nothing else is drawn above them, so matplotlib need not
    # measure the axes' tick labels once more to find room.
    axes[0].set_title(f"start: first {window:.3g} s, full scale", fontsize=9, pad=14, y=1.0)
    bounded = any(math.isfinite(b) for bounds in result.error_bounds for b in bounds)
    scale = "of the bounds" if bounded else "of the error after the start"
    axes[1].set_title(f"whole run, at the scale {scale}", fontsize=9, pad=14, y=1.0)
    handles, labels = axes[1].get_legend_handles_labels()
    for ax in axes:
        handles_here, labels_here = ax.get_legend_handles_labels()
        for handle, label in zip(handles_here, labels_here, strict=True):
            if label not in labels:
                handles.append(handle)
                labels.append(label)
    fig.legend(
        handles,
        labels,
        loc="lower center",
        ncols=3,
        fontsize=8,
        frameon=False,
        bbox_to_anchor=(0.5, 0.0),
    )
    axes[-2].set_xlabel("t [s]")
    axes[-1].set_xlabel("t [s]")
    _mark_phases([axes[1], axes[3], axes[5]], result, phase_colors(result))
    # eq. (4) bounds only the constrained observer's output error; the EKF has
    # its covariance instead (a registered `spread`); others have neither.
    if bounded:
        title = "estimation error; eq. (4) bounds measurement - estimate"
    elif spread is not None:
        title = f"estimation error; shaded: the {holder_name}'s +-3 std of true - estimate"
    else:
        title = "estimation error (no bounds: the estimator has none)"
    fig.suptitle(f"{result.mission_name}: {title}")
    names_as_typed(fig)


def plot_estimation_error(result: RunRecord, axes: Sequence[Axes] | None = None) -> Figure:
    """Measurement - estimate against the eq. (4) bounds, and true - estimate, per state:
    six axes (3 rows x: start, whole run); returns the figure."""
    fig, chosen = _figure_axes(axes, (3, 2), (11, 7.5))
    if axes is None:
        fig.subplots_adjust(bottom=ESTIMATION_BOTTOM)
    _estimation_on(fig, chosen, result)
    return fig


def _inputs_on(fig: Figure, axes: list[Axes], result: RunRecord) -> None:
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
        ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, frameon=False)
    axes[-1].set_xlabel("t [s]")
    _mark_phases(axes, result, phase_colors(result))
    fig.suptitle(f"{result.mission_name}: inputs")
    names_as_typed(fig)


def plot_inputs(result: RunRecord, axes: Sequence[Axes] | None = None) -> Figure:
    """Linear speed and turn rate with their limits: two axes; returns the figure."""
    fig, chosen = _figure_axes(axes, (2, 1), (9, 5.5))
    _inputs_on(fig, chosen, result)
    return fig


# --- the verdicts ---------------------------------------------------------

# Panels' height and the room above them for the title and the failure [in].
PANEL_HEIGHT, VERDICT_HEADER = 1.45, 1.1
# Failing samples marked per check at most (evenly chosen).
MAX_MARKS = 2000
# Level checks written in words on a panel at most; the others counted.
MAX_WORDS = 3
FAILED_COLOR = "tab:red"
SIGNAL_COLORS = ("tab:blue", "tab:orange", "tab:green")
FAINT = 0.3  # a signal's samples its checks do not bound (an entry, a detour)
# Each bound metric of a panel its own dash, in the order its checks come: a
# track phase bounds the cross-track error twice (cross_track_error_max, and
# detour_offset_max on its detours), the legend tells which line is which.
BOUND_DASHES: tuple[Any, ...] = ("--", "-.", (0, (5.0, 1.5, 1.0, 1.5, 1.0, 1.5)), (0, (1.0, 1.5)))
# Ticks of a symlog panel (depth, constraint value) at most, and their least
# spacing as a share of the axis: the labels stay apart.
MAX_SYMLOG_TICKS, SYMLOG_TICK_GAP = 6, 1.0 / 8.0


@dataclass(frozen=True)
class VerdictLines:
    """What verdicts.png draws of a run's error signals (verdicts.signals.Signals):
    each line at the thinned samples and at its check's marked samples, and
    its range; a long run's signals at every sample are not kept for it."""

    checks: list[Check]
    failed: list[Check]
    # panel -> line -> its finite values at thin(0, samples)
    thinned: dict[str, dict[str, FloatArray]]
    # panel -> line -> (least, largest) of its finite values; None: none finite
    ranges: dict[str, dict[str, tuple[float, float] | None]]
    # id of a peak check -> its line's finite values at the samples marked beyond it
    marked: dict[int, FloatArray]
    # line -> its samples at thin(0, samples) bounded by no check, drawn faint
    unjudged: dict[str, Mask]


def verdict_lines(result: RunRecord) -> VerdictLines:
    """The run's error signals (verdicts.signals.run_signals) as verdicts.png draws them."""
    from wmr_mission.verdicts.signals import panel_of, run_signals

    signals = run_signals(result)
    k = thin(0, result.samples)
    thinned = {p: {n: finite(v[k]) for n, v in lines.items()} for p, lines in signals.lines.items()}
    ranges = {p: {n: _range(v) for n, v in lines.items()} for p, lines in signals.lines.items()}
    marked = {}
    for check in signals.checks:
        panel, name = panel_of(check.metric), str(check.line)
        values = signals.lines.get(panel or "", {}).get(name)
        if check.peak and check.over.size and values is not None:
            marked[id(check)] = finite(values[check.over[thin(0, check.over.size, MAX_MARKS)]])
    unjudged = {}
    for name in {n for lines in signals.lines.values() for n in lines}:
        hidden = signals.unjudged(name)
        if hidden is not None and hidden[k].any():
            unjudged[name] = hidden[k]
    return VerdictLines(signals.checks, signals.failed(), thinned, ranges, marked, unjudged)


def _range(values: FloatArray) -> tuple[float, float] | None:
    kept = values[np.isfinite(values)]
    return (float(kept.min()), float(kept.max())) if kept.size else None


def _verdicts_on(fig: Figure, result: RunRecord, signals: VerdictLines | None = None) -> None:
    """The error signals the `expect` checks bound, over time, one panel each:
    the bounds drawn over their phases, the samples beyond them marked, the
    first failure's time drawn across every panel; failing panels on top.
    ``signals``: the run's, computed already (else here)."""
    from matplotlib.collections import LineCollection
    from matplotlib.lines import Line2D

    from wmr_mission.verdicts.signals import PANELS, panel_of

    if signals is None:
        signals = verdict_lines(result)
    failed = signals.failed
    shown = [
        p
        for p in PANELS
        if p in signals.thinned or any(panel_of(c.metric) == p for c in signals.checks)
    ]
    failing = (panel_of(c.metric) for c in failed)
    first_failing = list(dict.fromkeys(p for p in failing if p is not None))
    order = first_failing + [p for p in shown if p not in first_failing]
    if not order:
        order = ["saturation"]
    fig.set_size_inches(9.0, PANEL_HEIGHT * len(order) + VERDICT_HEADER)
    t = result.t
    first: Check | None = next((c for c in failed if c.first_over is not None), None)
    # A failure in a short phase is drawn on its phase alone at the top: on
    # the whole run it would be a spike at an edge.
    zoom = _zoom(result, first) if len(order) > 1 else None
    grid = fig.add_gridspec(len(order), 1)
    axes = [fig.add_subplot(grid[0])]
    for row in range(1, len(order)):
        shared = axes[1] if row > 1 and zoom is not None else axes[0] if zoom is None else None
        axes.append(fig.add_subplot(grid[row], sharex=shared))
    for ax in axes[:-1]:
        if ax is not axes[0] or zoom is None:
            ax.tick_params(labelbottom=False)
    k = thin(0, result.samples)
    for ax, panel in zip(axes, order, strict=True):
        drawn = signals.thinned.get(panel, {})
        colors = {name: SIGNAL_COLORS[i % 3] for i, name in enumerate(drawn)}
        faint = False
        for name, values in drawn.items():
            hidden = signals.unjudged.get(name)
            if hidden is not None:  # the whole line faint, its judged samples over it
                ax.plot(t[k], values, color=colors[name], linewidth=1.0, alpha=FAINT)
                values = np.where(hidden, np.nan, values)
                faint = True
            ax.plot(t[k], values, color=colors[name], linewidth=1.0, label=name)
        checks = [c for c in signals.checks if panel_of(c.metric) == panel]
        kinds = list(dict.fromkeys(_bound_kind(c) for c in checks if c.peak))
        dashes = {kind: BOUND_DASHES[i % len(BOUND_DASHES)] for i, kind in enumerate(kinds)}
        bounds, bound_colors, bound_dashes = [], [], []
        for check in (c for c in checks if c.peak):
            name = str(check.line)
            start, end = check.span
            ends = (float(t[start]), float(t[max(end - 1, start)]))
            signs = (1.0, -1.0) if check.metric == "along_track_lag_max" else (1.0,)
            for sign in signs:
                bounds.append([(ends[0], sign * check.level), (ends[1], sign * check.level)])
                bound_colors.append(FAILED_COLOR if not check.met else colors.get(name, "0.2"))
                bound_dashes.append(dashes[_bound_kind(check)])
            if check.over.size and name in drawn:
                marks = check.over[thin(0, check.over.size, MAX_MARKS)]
                ax.plot(
                    t[marks],
                    signals.marked[id(check)],
                    linestyle="none",
                    marker="x",
                    markersize=4,
                    color=FAILED_COLOR,
                    zorder=6,
                )
        if bounds:
            ax.add_collection(
                LineCollection(
                    bounds, colors=bound_colors, linewidths=1.2, linestyles=bound_dashes
                ),
                autolim=True,
            )
        worded = _level_words(ax, [c for c in checks if not c.peak])
        for check in (c for c in checks if not c.met and not c.peak):
            start, end = check.span
            ax.axvspan(
                float(t[start]), float(t[max(end - 1, start)]), color=FAILED_COLOR, alpha=0.08
            )
        if panel == "saturation":
            ax.axhline(1.0, color="0.2", linewidth=0.8, linestyle=":")
        _verdict_limits(ax, signals.ranges.get(panel, {}), checks)
        if worded and panel not in ("zones", "constraint"):
            _below_words(ax, worded)
        if panel in ("zones", "constraint"):
            # Metres far on the allowed side and millimetres beyond the edge, both
            # readable: linear within the bound of 0, logarithmic beyond.
            levels = [c.level for c in checks if c.peak]
            near = min([level for level in levels if level > 0], default=1e-3)
            ax.set_yscale("symlog", linthresh=near, linscale=1.0)
            _symlog_ticks(ax, levels, near)
        ax.set_ylabel(PANELS[panel], fontsize=8)
        ax.grid(True, linewidth=0.4, alpha=0.5)
        handles, labels = ax.get_legend_handles_labels()
        for kind in kinds:  # each bound by its metric's name, as `expect` writes it
            handles.append(Line2D([], [], color="0.2", linestyle=dashes[kind], linewidth=1.2))
            labels.append(kind)
        if any(c.over.size for c in checks):
            handles.append(Line2D([], [], color=FAILED_COLOR, linestyle="none", marker="x"))
            labels.append("beyond it")
        if faint:
            handles.append(Line2D([], [], color="0.2", linewidth=1.0, alpha=FAINT))
            labels.append("not judged")
        if handles:
            ax.legend(
                handles,
                labels,
                loc="upper left",
                bbox_to_anchor=(1.01, 1.0),
                fontsize=7,
                frameon=False,
            )
    axes[-1].set_xlabel("t [s]")
    if result.samples:
        axes[-1].set_xlim(float(t[0]), float(t[-1]))
    if zoom is not None and first is not None:
        axes[0].set_xlim(*zoom)
        name = first.phase if first.phase is not None else "the run"
        axes[0].set_title(
            f"{name}, t = {zoom[0]:.4g} .. {zoom[1]:.4g} s (the panels below: the whole run)",
            fontsize=8,
            loc="right",
        )
    if first is not None and first.first_over is not None:
        when = float(t[first.first_over])
        for ax in axes:
            ax.axvline(when, color=FAILED_COLOR, linewidth=1.0, alpha=0.7)
        axes[0].annotate(
            f"t = {when:.4g} s",
            (when, 0.0),
            xycoords=axes[0].get_xaxis_transform(),
            xytext=(3, 3),
            textcoords="offset points",
            color=FAILED_COLOR,
            fontsize=8,
        )
    _mark_phases(axes if zoom is None else axes[1:], result, phase_colors(result))
    fig.suptitle(
        _verdict_title(result, signals.checks, failed, first), fontsize=10, x=0.02, ha="left"
    )
    fig.subplots_adjust(
        top=1.0 - VERDICT_HEADER / (PANEL_HEIGHT * len(order) + VERDICT_HEADER) + 0.1 / len(order),
        hspace=0.35,
    )
    names_as_typed(fig)


def _bound_kind(check: Check) -> str:
    """The metric a peak check bounds, as the catalog names it (``detour_offset_max``)."""
    return check.metric.split(".", 1)[0]


def _symlog_ticks(ax: Axes, levels: Sequence[float], near: float) -> None:
    """Ticks of a symlog y axis linear within ``near`` of 0 that read across the
    range it shows: 0 and ``near`` where it is a bound's level, then the other
    bounds' ``levels``, then the decades beyond ``near`` (metres far on the
    allowed side), the farthest first, each at least SYMLOG_TICK_GAP of the
    axis from the ticks before it, MAX_SYMLOG_TICKS in all."""
    low, high = ax.get_ylim()
    decades: list[float] = []
    for side, far in ((-1.0, -low), (1.0, high)):
        if far >= near:
            top, bottom = math.floor(math.log10(far)), math.ceil(math.log10(near))
            decades += [side * 10.0**e for e in range(top, bottom - 1, -1)]
    decades.sort(key=lambda value: (-abs(value), value))
    forced = [0.0, near] if near in levels else [0.0]
    wanted = [*forced, *sorted(levels, key=abs), *decades]
    wanted = [v for v in dict.fromkeys(wanted) if low <= v <= high]
    scaled = ax.yaxis.get_transform().transform(np.array([low, high, *wanted], dtype=float))
    gap = SYMLOG_TICK_GAP * abs(float(scaled[1] - scaled[0]))
    kept: list[tuple[float, float]] = []
    for value, at in zip(wanted, scaled[2:], strict=True):
        apart = all(abs(float(at) - other) >= gap for _, other in kept)
        if value in forced or (apart and len(kept) < MAX_SYMLOG_TICKS):
            kept.append((value, float(at)))
    ticks = sorted(value for value, _ in kept)
    ax.set_yticks(ticks, [f"{value:g}" for value in ticks])


def _zoom(result: RunRecord, first: Any) -> tuple[float, float] | None:
    """The time span [s] the top panel shows: the first failure's phase, padded,
    when it is under a third of the run; else None (the whole run)."""
    if first is None or not result.samples or first.phase is None:
        return None
    start, end = first.span
    low, high = float(result.t[start]), float(result.t[max(end - 1, start)])
    run = float(result.t[-1] - result.t[0])
    if high - low >= run / 3.0 or high <= low:
        return None
    pad = 0.05 * (high - low)
    return max(float(result.t[0]), low - pad), min(float(result.t[-1]), high + pad)


def _verdict_title(
    result: RunRecord, checks: Sequence[Any], failed: Sequence[Any], first: Any
) -> str:
    """The run, its outcome and, for a failure, the first check it failed and when."""
    head = f"{result.mission_name}: {result.outcome.value}"
    if failed:
        lead = first if first is not None else failed[0]
        when = ""
        if lead.first_over is not None:
            when = f", first beyond it at t = {float(result.t[lead.first_over]):.4g} s"
        more = f"\n(and {len(failed) - 1} more failed checks)" if len(failed) > 1 else ""
        return f"{head}\nfailed {lead.words()}{when}{more}"
    if checks:
        return f"{head}\nevery expect check met ({len(checks)})"
    if not result.succeeded:
        return f"{head}\n{result.message}"
    return f"{head}\nno expect checks"


def _level_words(ax: Axes, checks: Sequence[Any]) -> int:
    """Level checks (an RMS, a share, a time) at the panel's top: the failed
    ones in words, the met ones counted; the lines written."""
    if not checks:
        return 0
    failed = [c for c in checks if not c.met]
    words = [f"NOT MET {c.words()}" for c in failed[:MAX_WORDS]]
    if len(failed) > MAX_WORDS:
        words.append(f"and {len(failed) - MAX_WORDS} more not met")
    met = len(checks) - len(failed)
    if met:
        names = sorted({c.metric for c in checks if c.met})
        words.append(f"{met} met: " + ", ".join(names))
    ax.text(
        0.005,
        0.96,
        "\n".join(words),
        transform=ax.transAxes,
        fontsize=6.5,
        va="top",
        ha="left",
        color=FAILED_COLOR if failed else "0.25",
        bbox={"facecolor": "white", "edgecolor": "none", "alpha": 0.7, "pad": 1.0},
        zorder=8,
    )
    return len(words)


# [share of a panel's height] a line of the level words takes, its padding included
WORDS_LINE = 0.12


def _below_words(ax: Axes, lines: int) -> None:
    """The panel's top raised so that its signals and bounds stay below its
    ``lines`` of level words (an input at its limit was hidden behind them)."""
    low, high = ax.get_ylim()
    ax.set_ylim(low, low + (high - low) / max(0.3, 0.94 - WORDS_LINE * lines))


def _verdict_limits(
    ax: Axes, ranges: Mapping[str, tuple[float, float] | None], checks: Sequence[Any]
) -> None:
    """The y range: the signals' (``ranges``: each line's finite least and
    largest value) and the bounds (both signs for a signed signal)."""
    bounds = [c.level for c in checks if c.peak]
    signed = [c.level for c in checks if c.metric == "along_track_lag_max"]
    spans = [span for span in ranges.values() if span is not None]
    if not spans and not bounds:
        return
    high = max([span[1] for span in spans] + bounds + [0.0])
    low = min([span[0] for span in spans] + [-b for b in signed] + [0.0])
    margin = 0.08 * (high - low if high > low else 1.0)
    ax.set_ylim(low - margin, high + margin)


def plot_verdicts(result: RunRecord) -> Figure:
    """The error signals the `expect` checks bound, over time, with the bounds and
    the failing samples (``verdicts.png``); returns the figure (from pyplot)."""
    fig = _pyplot_figure((9.0, 6.0))
    _verdicts_on(fig, result)
    return fig


# --- files ----------------------------------------------------------------


def _figure(result: RunRecord, name: str, signals: VerdictLines | None = None) -> Figure:
    """The figure of a run's file ``name`` (one of FIGURE_NAMES); ``signals``:
    the run's verdict signals, computed already (else when needed)."""
    if name == "verdicts":
        fig = new_figure((9.0, 6.0))
        _verdicts_on(fig, result, signals)
    elif name == "xy":
        fig = new_figure((XY_WIDTH, 6.5))
        columns = _xy_on(fig.add_subplot(), result)
        # Room on the canvas for the legend at the right, a column's width each.
        width = XY_WIDTH + LEGEND_COLUMN_WIDTH * (columns - 1)
        fig.set_size_inches(width, 6.5)
        fig.subplots_adjust(left=XY_LEFT / width, right=(XY_LEFT + XY_AXES_WIDTH) / width)
    elif name == "states":
        fig = new_figure((9, 7.5))
        _states_on(fig, list(fig.subplots(3, 1, sharex=True)), result)
    elif name == "estimation_error" and _estimate_is_exact(result):
        # Six flat lines at zero say less than one sentence.
        fig = new_figure((9, 1.2))
        fig.text(
            0.5,
            0.5,
            f"{result.mission_name}: the estimate equals the true state at every sample "
            "(no noise, no initial error): no estimation error to draw",
            ha="center",
            va="center",
            fontsize=10,
        )
        names_as_typed(fig)
    elif name == "estimation_error":
        fig = new_figure((11, 7.5))
        fig.subplots_adjust(bottom=ESTIMATION_BOTTOM)
        _estimation_on(fig, list(fig.subplots(3, 2, sharex="col").ravel()), result)
    else:
        fig = new_figure((9, 5.5))
        _inputs_on(fig, list(fig.subplots(2, 1, sharex=True)), result)
    return fig


def restyle(fig: Figure, style: Style) -> Figure:
    """``fig`` at ``style``'s width, its height in proportion, texts and lines
    scaled (sizes are in points: absolute, so a figure made narrower keeps
    text it can hold only when the text is made smaller with it)."""
    from matplotlib.lines import Line2D
    from matplotlib.text import Text

    if style.width is None:
        return fig
    width, height = fig.get_size_inches()
    rows, columns = _grid(fig)
    # In proportion, yet each row of axes an inch high at least with room for the titles.
    fig.set_size_inches(style.width, max(height * style.width / width, 1.0 * rows + 1.0))
    for ax in fig.axes:
        ax.tick_params(labelsize=10.0 * style.font_scale, width=0.8 * style.line_scale)
    for text in fig.findobj(Text):
        text.set_fontsize(float(text.get_fontsize()) * style.font_scale)
    titles = [
        (getattr(fig, "_suptitle", None), 1),
        *((text, 1) for text in fig.texts),
        *((ax.title, columns) for ax in fig.axes),
    ]
    for title, share in ((t, n) for t, n in titles if t is not None and t.get_text()):
        # About half an em a character: wrapped to the width it has.
        characters = int(style.width / share * 72.0 / (0.55 * float(title.get_fontsize())))
        lines = title.get_text().split("\n")
        title.set_text("\n".join(textwrap.fill(line, characters) for line in lines))
    _legends_below(fig, style.width)
    for line in fig.findobj(Line2D):
        line.set_linewidth(line.get_linewidth() * style.line_scale)
        line.set_markersize(line.get_markersize() * style.line_scale)
    # The layouts made for a screen's size are laid out again for this one.
    fig.set_layout_engine("constrained", h_pad=0.02, w_pad=0.02)
    with warnings.catch_warnings(record=True) as said:
        warnings.simplefilter("always")
        _crop_to(fig, style.width)
    if any("constrained_layout not applied" in str(w.message) for w in said):
        # Too narrow to lay out again: the screen's layout, at the width asked.
        fig.set_layout_engine("none")
        _crop_to(fig, style.width)
    return fig


def _grid(fig: Figure) -> tuple[int, int]:
    """The rows and columns of the figure's grid of axes."""
    rows, columns = 1, 1
    for ax in fig.axes:
        spec = ax.get_subplotspec()
        if spec is not None:
            grid = spec.get_gridspec()
            rows, columns = max(rows, grid.nrows), max(columns, grid.ncols)
    return rows, columns


def _legends_below(fig: Figure, width: float) -> None:
    """Legends beside the axes put below them, in two columns (their labels
    wrapped to fit ``width`` [in]), and the figure's own in one: a column's
    width has no room beside."""
    for own in list(fig.legends):
        own.remove()

        def below(labels: list[str], own: Any = own) -> Legend:
            texts = own.get_texts()
            return fig.legend(
                own.legend_handles,
                labels,
                loc="outside lower center",
                ncols=1,
                fontsize=texts[0].get_fontsize() if texts else 6,
                frameon=False,
            )

        _fitted(below, own.get_texts(), 1, width)
    for ax in fig.axes:
        beside = ax.get_legend()
        if beside is None or beside.get_bbox_to_anchor().x0 < ax.get_window_extent().x1:
            continue

        def under(labels: list[str], ax: Axes = ax, legend: Any = beside) -> Legend:
            title = legend.get_title()
            return ax.legend(
                legend.legend_handles,
                labels,
                loc="upper center",
                bbox_to_anchor=(0.5, -0.15),
                ncols=2,
                fontsize=legend.get_texts()[0].get_fontsize() if legend.get_texts() else 6,
                frameon=False,
                title=title.get_text() or None,
                title_fontsize=title.get_fontsize(),
            )

        _fitted(under, beside.get_texts(), 2, width)


def _fitted(
    make: Callable[[list[str]], Legend], texts: Sequence[Any], columns: int, width: float
) -> None:
    """The legend ``make`` draws of ``texts``' labels in ``columns``, each label
    wrapped so that the legend is at most ``width`` [in] less the crop's margins:
    first by half an em a character, then, measured, narrower until it fits (a
    wider legend would leave the crop no width to reach: the figure would
    shrink to nothing round it)."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    size = float(texts[0].get_fontsize()) if texts else 6.0
    labels = [text.get_text() for text in texts]
    # half an em a character, less the room of a legend's handle
    characters = max(MIN_LABEL_CHARACTERS, int(width / columns * 72.0 / (0.55 * size)) - 6)
    while True:
        legend = make([textwrap.fill(label, characters) for label in labels])
        figure = legend.get_figure(root=True)
        assert figure is not None  # drawn on this figure
        renderer = FigureCanvasAgg(figure).get_renderer()  # type: ignore[no-untyped-call]
        wide = legend.get_window_extent(renderer).width / figure.dpi
        if wide <= width - 2 * PAD or characters <= MIN_LABEL_CHARACTERS:
            return
        legend.remove()
        characters = max(MIN_LABEL_CHARACTERS, int(characters * 0.9))


def _crop_to(fig: Figure, target: float) -> None:
    """The canvas sized so that the figure cropped to what is drawn is ``target`` wide [in]."""
    from matplotlib.backends.backend_agg import FigureCanvasAgg

    # What is written is cropped to what is drawn, a legend beside the axes
    # included: the canvas is sized so that the crop has the target width.
    previous: tuple[float, float] | None = None  # (canvas width, crop width) before
    for _ in range(8):  # the texts keep their size: the crop's width is about a*w + b
        canvas = FigureCanvasAgg(fig)
        canvas.draw()  # type: ignore[no-untyped-call]  # laid out as it will be written
        renderer = canvas.get_renderer()  # type: ignore[no-untyped-call]
        drawn = fig.get_tightbbox(renderer).width + 2 * PAD
        width, height = fig.get_size_inches()
        if abs(drawn - target) < 0.01:
            break
        slope = 1.0
        if previous is not None and abs(width - previous[0]) > 1e-6:
            slope = max((drawn - previous[1]) / (width - previous[0]), 0.1)
        previous = (width, drawn)
        grown = max(width + (target - drawn) / slope, 0.3 * width) / width
        # both ways: an axes of equal aspect widens only with its height
        fig.set_size_inches(width * grown, height * grown)


def _estimate_is_exact(result: RunRecord) -> bool:
    """Whether the estimate equals the true state at every sample, and every
    measurement too (a noise-free run that starts from the true state)."""
    for state in STATES:
        truth = getattr(result, state)
        if not np.array_equal(getattr(result, f"{state}_est"), truth):
            return False
        sensed = getattr(result, f"{state}_meas")
        measured = np.isfinite(sensed)
        if not np.array_equal(sensed[measured], truth[measured]):
            return False
    return result.samples > 0


def draw_all(
    result: RunRecord,
    out_dir: Path,
    formats: Sequence[str] = ("png",),
    style: str = "screen",
    dpi: int | None = None,
) -> list[Path]:
    """Write the figures (FIGURE_NAMES) into ``out_dir`` in each format, sized
    by ``style`` (one of STYLES), at ``dpi`` (default: DPI); return their paths."""
    directory = Path(out_dir)
    unknown = [f for f in formats if f not in FIGURE_FORMATS]
    if unknown:
        raise ValueError(f"unknown figure format {unknown[0]!r}; expected one of png, svg, pdf")
    if style not in STYLES:
        raise ValueError(f"unknown style {style!r}; expected one of {', '.join(STYLES)}")
    if dpi is not None and not DPI_RANGE[0] <= dpi <= DPI_RANGE[1]:
        raise ValueError(f"dpi {dpi}: expected {DPI_RANGE[0]} to {DPI_RANGE[1]}")
    # verdicts.png explains a run on a screen: its panels and their words need
    # the room; the style sizes the others, the paper's figures.
    styled = {name: STYLES["screen" if name == "verdicts" else style] for name in FIGURE_NAMES}
    # The verdicts' signals first, once, before matplotlib is loaded: their
    # temporaries over every sample and matplotlib's modules are never
    # resident together (a long run's peak memory, docs/performance.md).
    long_run = result.samples >= LONG_RUN
    if not long_run:
        return _draw_each(result, directory, formats, styled, dpi or DPI, long_run)
    give_back_freed_heap()  # the judge's temporaries, freed
    # The judge's compiled passes, loaded from the cache after the run gave the
    # compiler's pages back, read 10 MB of them in again (the 1-hour run).
    give_back_compiler_pages()
    with collecting_new_objects_only():
        return _draw_each(result, directory, formats, styled, dpi or DPI, long_run)


def _draw_each(
    result: RunRecord,
    directory: Path,
    formats: Sequence[str],
    styled: Mapping[str, Style],
    dpi: int,
    long_run: bool,
) -> list[Path]:
    """draw_all's figures, ``long_run``: giving the heap back before each."""
    signals: VerdictLines | None = verdict_lines(result)
    written = []
    for fmt in formats:
        for name in FIGURE_NAMES:
            if long_run:  # the figure drawn before (cyclic garbage), the signals' temporaries
                give_back_freed_heap()
            fig = restyle(_figure(result, name, signals), styled[name])
            written.append(save_figure(fig, directory / f"{name}.{fmt}", dpi))
            del fig
            if name == "verdicts" and fmt == formats[-1]:
                signals = None  # drawn for the last time: the other figures need none
    return written
