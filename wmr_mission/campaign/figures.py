"""Figures of a campaign: every trajectory over the regions, metric histograms,
success over the varied axes (a heat map for two), and each cell of the grid
side by side (a head-to-head of controllers or estimators)."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, Final

import numpy as np

from wmr_mission.campaign.aggregate import DRAWN_PATHS, Aggregate, clopper_pearson, value_label
from wmr_mission.campaign.comparison import COMPARISON_METRICS
from wmr_mission.campaign.coverage import runs_per_pixel
from wmr_mission.campaign.rows import METRICS
from wmr_mission.output.figures import draw_regions, new_figure, region_extent, save_figure

__all__ = ["draw_campaign"]

_BINS: Final = 12
_SUCCESS_COLOR: Final = "tab:blue"
_FAILURE_COLOR: Final = "tab:red"
# The part of a colormap used: light enough to show the crowd, still a colour
# (not near-black) at its darkest, and a pixel one run crosses still visible.
_LIGHTEST: Final = 0.35
_DARKEST: Final = 0.9


def draw_campaign(
    aggregate: Aggregate, regions: dict[str, Any], out_dir: Path, formats: Sequence[str] = ("png",)
) -> list[Path]:
    figures = {
        "trajectories": _trajectories(aggregate, regions),
        "metrics": _histograms(aggregate),
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


def _trajectories(aggregate: Aggregate, regions: dict[str, Any]) -> Any:
    fig = new_figure((7.0, 5.5))
    ax = fig.add_subplot()
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
    draw_regions(ax, regions, view)
    ax.set_xlim(view[0], view[1])
    ax.set_ylim(view[2], view[3])
    ax.set_aspect("equal", adjustable="box")
    # Every run as one image, a pixel of the image per pixel of the axes: the
    # runs through each pixel, darker where more pass; failures over successes.
    ax.apply_aspect()
    box = ax.get_window_extent()
    shape = (max(1, round(box.height)), max(1, round(box.width)))
    for outcome, colormap, order in ((True, "Blues", 2), (False, "Reds", 3)):
        counts = runs_per_pixel([p for ok, p in paths if ok is outcome], view, shape)
        ax.imshow(
            _shaded(counts, colormap),
            extent=view,
            origin="lower",
            interpolation="nearest",
            zorder=order,
        )
    ax.plot([], [], color=_SUCCESS_COLOR, label=f"success ({aggregate.succeeded})")
    ax.plot([], [], color=_FAILURE_COLOR, label=f"failure ({aggregate.runs - aggregate.succeeded})")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    drawn = len(paths)
    shown = "every run" if drawn >= aggregate.runs else f"{drawn} of {aggregate.runs} runs"
    cap = f" (at most {DRAWN_PATHS} successes drawn)" if drawn < aggregate.runs else ""
    ax.set_title(f"True paths, {shown}{cap}, darker where more pass; failures in red")
    ax.legend(loc="upper right", fontsize="small")
    ax.grid(True, alpha=0.3)
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


def _histograms(aggregate: Aggregate) -> Any:
    fig = new_figure((9.0, 2.6 * ((len(METRICS) + 1) // 2)))
    for index, name in enumerate(METRICS):
        ax = fig.add_subplot((len(METRICS) + 1) // 2, 2, index + 1)
        values = np.asarray(aggregate.metric_values.get(name, []), dtype=float)
        ok = np.asarray(aggregate.success, dtype=bool)[: values.size]
        finite = np.isfinite(values)
        if not finite.any():
            ax.text(0.5, 0.5, "no values", ha="center", va="center", transform=ax.transAxes)
        else:
            # Stacked as two filled outlines, failures on top of successes:
            # one artist each where bars would be sixty rectangles.
            edges = np.histogram_bin_edges(values[finite], bins=30)
            successes, _ = np.histogram(values[finite & ok], bins=edges)
            failures, _ = np.histogram(values[finite & ~ok], bins=edges)
            # An outline, so that a bin of one run among thousands still shows.
            for counts, color, label in (
                (successes + failures, _FAILURE_COLOR, "failure"),
                (successes, _SUCCESS_COLOR, "success"),
            ):
                ax.stairs(counts, edges, fill=True, color=color, linewidth=1.0, label=label)
            handles, labels = ax.get_legend_handles_labels()
            ax.legend(handles[::-1], labels[::-1], fontsize="x-small")
        missing = int((~finite).sum())
        ax.set_title(name + (f" ({missing} runs without a value)" if missing else ""), fontsize=9)
        ax.set_ylabel("runs")
    # Fixed margins: fitting them to the texts would cost a second drawing.
    fig.subplots_adjust(left=0.08, right=0.98, bottom=0.04, top=0.96, wspace=0.2, hspace=0.35)
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
        ax.bar((ex[1:] + ex[:-1]) / 2, rate, width=np.diff(ex) * 0.9, color=_SUCCESS_COLOR)
        ax.set_xlabel(axes[0])
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
                    if count[i, j]:
                        ax.text(
                            (ex[i] + ex[i + 1]) / 2,
                            (ey[j] + ey[j + 1]) / 2,
                            f"{rate[i, j]:.0%}\n{int(count[i, j])}",
                            ha="center",
                            va="center",
                            fontsize=8,
                        )
        ax.set_xlabel(axes[0])
        ax.set_ylabel(axes[1])
        _label_axis(aggregate, axes[0], ax.xaxis)
        _label_axis(aggregate, axes[1], ax.yaxis)
        ax.set_title("Success rate over two varied axes")
    return fig


def _side_by_side(aggregate: Aggregate) -> Any | None:
    """Each grid cell side by side: its success rate with its 95 % interval
    (Clopper-Pearson), and the median and 5-95 % range of the comparison
    metrics over its runs (wmr_mission.campaign.comparison)."""
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
    fig = new_figure((3.2 * len(panels), 0.9 + 0.32 * len(cells)))
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
                ax.set_xscale("log")
        ax.set_title(panel, fontsize=9)
        ax.set_yticks(positions, names if index == 0 else [""] * len(cells), fontsize=8)
        ax.invert_yaxis()
        ax.grid(axis="x", alpha=0.3)
    fig.subplots_adjust(left=0.18, right=0.99, bottom=0.12, top=0.85, wspace=0.15)
    return fig
