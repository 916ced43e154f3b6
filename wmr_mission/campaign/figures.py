"""Figures of a campaign: every trajectory over the regions, metric histograms,
success over the varied axes (a heat map for two), and each cell of the grid
side by side (a head-to-head of controllers or estimators)."""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Any, Final

import numpy as np

from wmr_mission.campaign.aggregate import (
    DRAWN_FAILURES,
    DRAWN_PATHS,
    Aggregate,
    clopper_pearson,
    value_label,
)
from wmr_mission.campaign.comparison import COMPARISON_METRICS, COMPARISON_UNITS
from wmr_mission.campaign.coverage import runs_per_pixel
from wmr_mission.campaign.rows import COLUMNS, METRICS
from wmr_mission.output.figures import draw_regions, new_figure, region_extent, save_figure

__all__ = ["draw_campaign"]

_BINS: Final = 12
_SUCCESS_COLOR: Final = "tab:blue"
_FAILURE_COLOR: Final = "tab:red"
# The part of a colormap used: light enough to show the crowd, still a colour
# (not near-black) at its darkest, and a pixel one run crosses still visible.
_LIGHTEST: Final = 0.35
_DARKEST: Final = 0.9


# The unit of each metric of runs.csv: the catalog's (wmr_mission.spec.catalog),
# then a head-to-head's.
UNITS: Final = {m.name: m.unit for m in COLUMNS if m.unit} | COMPARISON_UNITS
# Failures this many times fewer than the fullest bin's runs are drawn on a
# log scale: on a linear one, 17 failures beside 1963 successes are a line.
_LOG_SCALE_RATIO: Final = 10
# The unit of a varied field, by the last part of its path.
_FIELD_UNITS: Final = {
    "x": "m",
    "y": "m",
    "theta": "rad",
    "dt": "s",
    "v": "m/s",
    "omega": "rad/s",
    "noise_std": "m, m, rad",
}


def draw_campaign(
    aggregate: Aggregate,
    regions: dict[str, Any],
    out_dir: Path,
    formats: Sequence[str] = ("png",),
    bounds: dict[str, tuple[str, float]] | None = None,
    left_out: Sequence[str] = (),
) -> list[Path]:
    """The campaign's figures in ``out_dir``; ``bounds``: the mission-wide
    `expect` bounds of the metrics (``max`` or ``min``, and the number), drawn
    on their histograms; ``left_out``:
    the regions the campaign varies, not among ``regions``, named under the
    trajectories."""
    figures = {
        "trajectories": _trajectories(aggregate, regions, left_out),
        "metrics": _histograms(aggregate, bounds or {}),
    }
    success = _success_over_axes(aggregate)
    if success is not None:
        figures["success"] = success
    compared = _side_by_side(aggregate)
    if compared is not None:
        figures["comparison"] = compared
    written = []
    for name, figure in figures.items():
        for fmt in formats:
            written.append(save_figure(figure, out_dir / f"{name}.{fmt}"))
    return written


def _field_label(path: str) -> str:
    """``robot.initial_state.theta [rad]``: a varied field with its unit, where known."""
    unit = _FIELD_UNITS.get(path.rsplit(".", 1)[-1])
    return f"{path} [{unit}]" if unit else path


def _trajectories(
    aggregate: Aggregate, regions: dict[str, Any], left_out: Sequence[str] = ()
) -> Any:
    """Small multiples: the successes and the failures on panels of their own,
    each darker where more of its runs pass; neither hides the other."""
    fig = new_figure((11.0, 4.0))
    paths = aggregate.drawn
    points = [p for _, p in paths if p.size] or [np.zeros((2, 1), dtype=np.float32)]
    xs = np.concatenate([p[0] for p in points])
    ys = np.concatenate([p[1] for p in points])
    finite = np.isfinite(xs) & np.isfinite(ys)
    xs, ys = xs[finite], ys[finite]
    extents = [e for e in (region_extent(r) for r in regions.values()) if e is not None]
    x0 = min([float(np.percentile(xs, 0.5)) if xs.size else -1.0] + [e[0] for e in extents])
    x1 = max([float(np.percentile(xs, 99.5)) if xs.size else 1.0] + [e[1] for e in extents])
    y0 = min([float(np.percentile(ys, 0.5)) if ys.size else -1.0] + [e[2] for e in extents])
    y1 = max([float(np.percentile(ys, 99.5)) if ys.size else 1.0] + [e[3] for e in extents])
    margin = 0.06 * max(x1 - x0, y1 - y0, 0.5)
    view = (x0 - margin, x1 + margin, y0 - margin, y1 + margin)
    failed = aggregate.runs - aggregate.succeeded
    axes = fig.subplots(1, 2, sharex=True, sharey=True)
    for ax, outcome, colormap, count, name in (
        (axes[0], True, "Blues", aggregate.succeeded, "successes"),
        (axes[1], False, "Reds", failed, "failures"),
    ):
        draw_regions(ax, regions, view)
        ax.set_xlim(view[0], view[1])
        ax.set_ylim(view[2], view[3])
        ax.set_aspect("equal", adjustable="box")
        # Every run as one image, a pixel of the image per pixel of the axes:
        # the runs through each pixel, darker where more pass.
        ax.apply_aspect()
        box = ax.get_window_extent()
        shape = (max(1, round(box.height)), max(1, round(box.width)))
        mine = [p for ok, p in paths if ok is outcome]
        counts = runs_per_pixel(mine, view, shape)
        ax.imshow(
            _shaded(counts, colormap),
            extent=view,
            origin="lower",
            interpolation="nearest",
            zorder=2,
        )
        drawn = f", {len(mine)} drawn" if len(mine) < count else ""
        ax.set_title(f"{name}: {count} of {aggregate.runs} runs{drawn}", fontsize=10)
        ax.set_xlabel("x [m]")
        ax.grid(True, alpha=0.3)
    axes[0].set_ylabel("y [m]")
    cap = (
        f"; at most {DRAWN_PATHS} successes and {DRAWN_FAILURES} failures drawn"
        if len(paths) < aggregate.runs
        else ""
    )
    fig.suptitle(f"True paths, darker where more runs pass{cap}", fontsize=11)
    if left_out:  # each run had its own: none drawn
        names = ", ".join(left_out)
        fig.text(0.5, 0.01, f"not drawn: {names}, varied by the campaign", ha="center", fontsize=9)
    return fig


def _shaded(counts: np.ndarray, colormap: str) -> np.ndarray:
    """RGBA pixels: transparent where no run passes, else the colormap from
    light (one run, still visible) to dark (the most runs through a pixel),
    on a log scale so that a lone run and a crowd both show."""
    from matplotlib import colormaps

    pixels = np.zeros((*counts.shape, 4))
    passed = counts > 0
    level = np.log1p(counts[passed]) / np.log1p(max(int(counts.max()), 1))
    pixels[passed] = colormaps[colormap](_LIGHTEST + (_DARKEST - _LIGHTEST) * level)
    return pixels


def _histograms(aggregate: Aggregate, bounds: dict[str, tuple[str, float]]) -> Any:
    """Per metric with values: its runs by value, failures stacked on
    successes (on a log scale, and in front, where they are few), the
    mission's bound drawn; the metrics no run has are named."""
    from matplotlib.ticker import MaxNLocator

    ok_all = np.asarray(aggregate.success, dtype=bool)
    shown: list[tuple[str, np.ndarray]] = []
    empty: list[tuple[str, np.ndarray]] = []
    for name in METRICS:
        values = np.asarray(aggregate.metric_values.get(name, []), dtype=float)
        (shown if np.isfinite(values).any() else empty).append((name, values))
    rows = max(1, (len(shown) + 1) // 2)
    fig = new_figure((9.0, 2.6 * rows + 0.4))
    # As many bins as the runs can fill: about the square root of their number.
    bins = int(np.clip(round(math.sqrt(max(aggregate.runs, 1))), 4, 30))
    for index, (name, values) in enumerate(shown):
        ax = fig.add_subplot(rows, 2, index + 1)
        ok = ok_all[: values.size]
        finite = np.isfinite(values)
        edges = np.histogram_bin_edges(values[finite], bins=bins)
        successes, _ = np.histogram(values[finite & ok], bins=edges)
        failures, _ = np.histogram(values[finite & ~ok], bins=edges)
        # Two filled outlines, failures stacked on successes: one artist each
        # where bars would be many rectangles; a bin of one run still shows.
        for counts, color, label in (
            (successes + failures, _FAILURE_COLOR, f"failure ({int(failures.sum())})"),
            (successes, _SUCCESS_COLOR, f"success ({int(successes.sum())})"),
        ):
            ax.stairs(counts, edges, fill=True, color=color, linewidth=1.0, label=label)
        few = failures.any() and (successes + failures).max() > _LOG_SCALE_RATIO * failures.max()
        if few:  # the failures on their own, in front, where a log scale shows them
            ax.stairs(failures, edges, fill=True, color=_FAILURE_COLOR, linewidth=1.0)
            ax.set_yscale("symlog", linthresh=1.0)
            ax.set_ylim(bottom=0.0)
        if name in bounds:
            side, bound = bounds[name]
            said = f"expect {side} {bound:g}"
            ax.axvline(bound, color="black", linestyle="--", linewidth=1.0, label=said)
        handles, labels = ax.get_legend_handles_labels()
        ax.legend(handles[::-1], labels[::-1], fontsize="x-small")
        missing = int((~finite).sum())
        ax.set_title(name + (f" ({missing} runs without a value)" if missing else ""), fontsize=9)
        ax.set_xlabel(f"[{UNITS.get(name, '')}]" if UNITS.get(name) else "", fontsize=8)
        ax.set_ylabel("runs (log scale)" if few else "runs")
        ax.xaxis.set_major_locator(MaxNLocator(nbins=5))  # long tick labels never meet
    if empty:
        fig.text(
            0.01,
            0.005,
            "no run has a value of: " + ", ".join(n for n, _ in empty),
            fontsize=8,
            va="bottom",
        )
    # Fixed margins: fitting them to the texts would cost a second drawing.
    fig.subplots_adjust(
        left=0.08, right=0.98, bottom=0.1 / rows + 0.04, top=0.95, wspace=0.2, hspace=0.55
    )
    return fig


def _shown_axes(aggregate: Aggregate) -> list[str]:
    """The first two axes that vary: grid axes first, then choice, uniform, normal."""
    order = {"grid": 0, "choice": 1, "uniform": 2, "normal": 3}
    chosen = []
    for path in sorted(aggregate.paths, key=lambda p: order[aggregate.axes[p].kind]):
        values = np.asarray(aggregate.axis_values.get(path, []), dtype=float)
        if values.size and np.isfinite(values).all() and np.ptp(values) > 0:
            chosen.append(path)
    return chosen[:2]


def _edges(aggregate: Aggregate, path: str, values: np.ndarray) -> np.ndarray:
    if path in aggregate.discrete:  # one bin per listed value, centred on its index
        return np.arange(len(aggregate.labels(path)) + 1) - 0.5
    return np.linspace(values.min(), values.max(), _BINS + 1)


def _label_axis(aggregate: Aggregate, path: str, axis: Any) -> None:
    if path in aggregate.discrete:
        # Values are data: a '$' in one is drawn as typed, never parsed as math.
        labels = [label.replace("$", r"\$") for label in aggregate.labels(path)]
        axis.set_ticks(range(len(labels)), labels)


def _success_over_axes(aggregate: Aggregate) -> Any | None:
    axes = _shown_axes(aggregate)
    if not axes:
        return None
    ok = np.asarray(aggregate.success, dtype=float)
    fig = new_figure((7.0, 5.0))
    ax = fig.add_subplot()
    first = np.asarray(aggregate.axis_values[axes[0]], dtype=float)
    ex = _edges(aggregate, axes[0], first)
    if len(axes) == 1:
        index = np.clip(np.searchsorted(ex, first, side="right") - 1, 0, ex.size - 2)
        count = np.bincount(index, minlength=ex.size - 1)
        hits = np.bincount(index, weights=ok, minlength=ex.size - 1)
        rate = np.divide(hits, count, out=np.full(count.shape, np.nan), where=count > 0)
        centres = (ex[1:] + ex[:-1]) / 2
        ax.bar(centres, rate, width=np.diff(ex) * 0.9, color=_SUCCESS_COLOR)
        for x, runs, share in zip(centres, count, rate, strict=True):
            words = f"{int(runs)} runs" if runs else "no runs"
            ax.text(
                x,
                (0.0 if np.isnan(share) else share) + 0.01,
                words,
                ha="center",
                va="bottom",
                fontsize=7,
            )
        ax.set_xlabel(_field_label(axes[0]))
        _label_axis(aggregate, axes[0], ax.xaxis)
        ax.set_ylabel("success rate")
        ax.set_ylim(0, 1.05)
        ax.set_title("Success rate over the varied axis")
    else:
        second = np.asarray(aggregate.axis_values[axes[1]], dtype=float)
        ey = _edges(aggregate, axes[1], second)
        count, _, _ = np.histogram2d(first, second, bins=[ex, ey])
        hits, _, _ = np.histogram2d(first, second, bins=[ex, ey], weights=ok)
        rate = np.divide(hits, count, out=np.full(count.shape, np.nan), where=count > 0)
        mesh = ax.pcolormesh(ex, ey, rate.T, cmap="RdYlGn", vmin=0.0, vmax=1.0)
        fig.colorbar(mesh, ax=ax, label="success rate")
        if rate.size <= 64:  # few cells: write each rate and its number of runs
            for i in range(rate.shape[0]):
                for j in range(rate.shape[1]):
                    words = f"{rate[i, j]:.0%}\nof {int(count[i, j])}" if count[i, j] else "no runs"
                    ax.text(
                        (ex[i] + ex[i + 1]) / 2,
                        (ey[j] + ey[j + 1]) / 2,
                        words,
                        ha="center",
                        va="center",
                        fontsize=8,
                    )
        ax.set_xlabel(_field_label(axes[0]))
        ax.set_ylabel(_field_label(axes[1]))
        _label_axis(aggregate, axes[0], ax.xaxis)
        _label_axis(aggregate, axes[1], ax.yaxis)
        ax.set_title("Success rate over two varied axes")
    return fig


def _side_by_side(aggregate: Aggregate) -> Any | None:
    """Each grid cell side by side: its success rate with its 95 % interval
    (Clopper-Pearson), and the median (dot) and 5-95 % range (bar) of the
    comparison metrics over its runs (wmr_mission.campaign.comparison)."""
    grid = [(path, axis.grid) for path, axis in aggregate.axes.items() if axis.grid is not None]
    cells = sorted(aggregate.cells)
    if not grid or len(cells) < 2:
        return None
    names = [
        "/".join(value_label(values[i]) for (_, values), i in zip(grid, cell, strict=True))
        for cell in cells
    ]
    names = [name.replace("$", r"\$") for name in names]  # data, never parsed as math
    positions = np.arange(len(cells))
    panels = ("success rate", *COMPARISON_METRICS)
    # the overall title above the panels' own: constrained layout keeps room for both
    fig = new_figure((3.2 * len(panels), 1.2 + 0.32 * len(cells)))
    fig.set_layout_engine("constrained", wspace=0.02)
    for index, panel in enumerate(panels):
        ax = fig.add_subplot(1, len(panels), index + 1)
        if panel == "success rate":
            rates, low, high = [], [], []
            for cell in cells:
                runs, succeeded = aggregate.cells[cell]
                lo, hi = clopper_pearson(succeeded, runs)
                rates.append(succeeded / runs)
                low.append(succeeded / runs - lo)
                high.append(hi - succeeded / runs)
            ax.barh(positions, rates, xerr=[low, high], color=_SUCCESS_COLOR, capsize=3)
            ax.set_xlim(0, 1.05)
        else:
            smallest = np.inf
            for y, cell in zip(positions, cells, strict=True):
                values = np.asarray(aggregate.cell_metrics[cell].get(panel, []), dtype=float)
                values = values[np.isfinite(values)]
                if values.size == 0:
                    continue
                lo, median, hi = np.percentile(values, [5, 50, 95])
                smallest = min(smallest, lo)
                ax.plot([lo, hi], [y, y], color=_SUCCESS_COLOR, linewidth=2)
                ax.plot([median], [y], "o", color="black", markersize=4)
            if 0.0 < smallest < np.inf:  # cells apart by orders of magnitude
                _log_axis(ax)
        ax.set_title(panel, fontsize=9)
        ax.set_xlabel(_COMPARISON_AXES[panel], fontsize=8)
        ax.set_yticks(positions, names if index == 0 else [""] * len(cells), fontsize=8)
        if index == 0:
            ax.set_ylabel(" / ".join(path for path, _ in grid), fontsize=8)
        ax.invert_yaxis()
        ax.grid(axis="x", alpha=0.3)
    fig.suptitle(
        "each grid cell: its success rate, and the median (dot) and 5-95 % range (bar) of "
        "each metric over its runs",
        fontsize=9,
    )
    return fig


# The x axis of each panel of comparison.png: what is drawn, in what unit.
_COMPARISON_AXES: Final = {
    "success rate": "runs that succeeded (bar), 95 % interval",
    "reference_error_rms": "distance to the reference [m]",
    "run_turn_rate_jitter": "turn-rate jitter, whole run [rad/s]",
    "input_saturation": "share of samples at a limit",
    "reference_capture_time": "time to stay within 5 cm of the reference [s]",
}


def _log_axis(ax: Any) -> None:
    """A log x axis whose labels never collide: over more than two decades, a
    label at no more than four powers of ten (10^k); within two, at 1, 2 and
    5 times them as plain numbers; minor ticks unlabelled."""
    from matplotlib.ticker import FuncFormatter, LogLocator, NullFormatter

    ax.set_xscale("log")
    low, high = ax.get_xlim()
    if math.log10(high / low) > 2.0:
        ax.xaxis.set_major_locator(LogLocator(base=10.0, numticks=4))
    else:
        ax.xaxis.set_major_locator(LogLocator(base=10.0, subs=(1.0, 2.0, 5.0), numticks=6))
        ax.xaxis.set_major_formatter(FuncFormatter(lambda value, _: f"{value:g}"))
    ax.xaxis.set_minor_formatter(NullFormatter())
