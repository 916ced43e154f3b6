"""A falsification's figures: the objective against the evaluation, and where
the failing runs lie, on each pair of axes."""

from __future__ import annotations

import math
from collections.abc import Sequence
from itertools import combinations
from pathlib import Path
from typing import Any, Final

import numpy as np

from wmr_mission.campaign.falsify.evaluate import PENALTY, Evaluation
from wmr_mission.campaign.falsify.space import Space
from wmr_mission.output.figures import new_figure, save_figure

__all__ = ["MARGINS_FIGURE", "REGION_FIGURE", "draw_falsification"]

MARGINS_FIGURE: Final = "margins.png"
REGION_FIGURE: Final = "region.png"
# Pairs of axes drawn at most: 4 axes make 6 pairs, a panel each.
_MOST_PAIRS: Final = 6


def draw_falsification(
    evaluations: Sequence[Evaluation], space: Space, objective: str | None, out_dir: Path
) -> None:
    _margins(evaluations, objective, out_dir / MARGINS_FIGURE)
    _region(evaluations, space, out_dir / REGION_FIGURE)


def _shown(value: float) -> float:
    """A margin on the figure: -inf (a failure no check measures) at the
    bottom, +inf (no check) left out."""
    return max(value, -PENALTY) if not math.isinf(value) or value < 0 else math.nan


def _margins(evaluations: Sequence[Evaluation], objective: str | None, path: Path) -> None:
    ran = [e for e in evaluations if e.ran]
    # by evaluation number, as evaluations.csv's rows and failing/N.yaml name runs
    index = np.array([e.index for e in ran], dtype=float)
    value = np.array([_shown(e.objective) for e in ran], dtype=float)
    finite = value[np.isfinite(value)]
    # -inf runs are drawn just below the lowest finite margin, marked as such.
    floor = float(min(finite.min(initial=0.0), 0.0)) - 0.25
    value = np.where(value <= -PENALTY, floor, value)
    best = np.minimum.accumulate(np.where(np.isnan(value), np.inf, value)) if len(value) else value
    fig = new_figure((7.0, 3.6))
    ax = fig.add_subplot()
    # a failing run, not an objective below 0: with --objective a run may fail
    # another check with its objective above 0
    failing = np.array([e.falsified for e in ran], dtype=bool)
    ax.scatter(index[~failing], value[~failing], s=9, color="0.45", label="run")
    ax.scatter(index[failing], value[failing], s=14, color="tab:red", label="failing run")
    ax.step(index, best, where="post", color="tab:blue", label="lowest so far")
    ax.axhline(0.0, color="black", linewidth=0.8, linestyle="--")
    if (value == floor).any():
        ax.axhline(floor, color="tab:red", linewidth=0.5, linestyle=":")
        ax.annotate("-inf (timeout, divergence...)", (0, floor), fontsize=7, va="bottom")
    ax.set_xlabel("evaluation")
    ax.set_ylabel(f"margin of {objective}" if objective else "run margin")
    ax.set_title("margin against evaluation: below 0 fails")
    ax.legend(loc="upper right", fontsize=7)
    save_figure(fig, path)


def _coordinate(space: Space, path: str, value: Any) -> float:
    """A value on its axis: a number as it is, a choice by its index."""
    axis = space.campaign.vary[path]
    values = axis.choice if axis.choice is not None else axis.grid
    if values is not None:
        return float(values.index(value))
    return float(value)


def _region(evaluations: Sequence[Evaluation], space: Space, path: Path) -> None:
    ran = [e for e in evaluations if e.ran]
    paths = space.paths
    pairs = list(combinations(range(len(paths)), 2))[:_MOST_PAIRS] or [(0, 0)]
    columns = min(3, len(pairs))
    rows = math.ceil(len(pairs) / columns)
    fig = new_figure((3.4 * columns, 3.0 * rows))
    points = np.array(
        [[_coordinate(space, p, e.values[p]) for p in paths] for e in ran], dtype=float
    ).reshape(len(ran), len(paths))
    failing = np.array([e.falsified for e in ran], dtype=bool)
    for n, (i, j) in enumerate(pairs):
        ax = fig.add_subplot(rows, columns, n + 1)
        x = points[:, i]
        y = points[:, j] if i != j else np.zeros(len(ran))
        ax.scatter(x[~failing], y[~failing], s=6, color="0.6", label="run")
        ax.scatter(x[failing], y[failing], s=12, color="tab:red", label="failing")
        ax.set_xlim(*_extent(space, paths[i]))
        if i != j:
            ax.set_ylim(*_extent(space, paths[j]))
        ax.set_xlabel(_label(space, paths[i]), fontsize=7)
        ax.set_ylabel(_label(space, paths[j]) if i != j else "", fontsize=7)
        ax.tick_params(labelsize=6)
        if n == 0:
            ax.legend(loc="best", fontsize=6)
    fig.suptitle(f"runs on each pair of axes: {int(failing.sum())} failing of {len(ran)}")
    fig.tight_layout()
    save_figure(fig, path)


def _extent(space: Space, path: str) -> tuple[float, float]:
    """The whole axis, so that the failing region shows where it lies in the box."""
    axis = space.campaign.vary[path]
    values = axis.choice if axis.choice is not None else axis.grid
    if values is not None:
        return -0.5, len(values) - 0.5
    extremes = [float(v) for v in axis.extremes()]
    lo, hi = min(extremes), max(extremes)
    pad = 0.02 * (hi - lo) if hi > lo else 0.5
    return lo - pad, hi + pad


def _label(space: Space, path: str) -> str:
    axis = space.campaign.vary[path]
    return f"{path} (index)" if axis.choice is not None or axis.grid is not None else path
