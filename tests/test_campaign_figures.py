"""comparison.png, each grid cell side by side: named axes, log-scale tick
labels that never collide, and its title clear of the panels' titles."""

from __future__ import annotations

import itertools

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg

from wmr_mission.campaign.aggregate import Aggregate
from wmr_mission.campaign.comparison import COMPARISON_METRICS
from wmr_mission.campaign.figures import _side_by_side
from wmr_mission.campaign.models import Axis


def _aggregate(low: float, high: float) -> Aggregate:
    """Four cells whose metrics lie between ``low`` and ``high``."""
    rng = np.random.default_rng(0)
    cells = list(itertools.product(range(2), range(2)))
    spread = np.geomspace(low, high, len(cells))
    return Aggregate(
        axes={
            "controller.type": Axis(grid=["paper", "kanayama"]),
            "sensors.noise_std.x": Axis(grid=[0.0, 0.01]),
        },
        cells={cell: [20, 15] for cell in cells},
        cell_metrics={
            cell: {m: list(centre * rng.uniform(0.8, 1.25, 20)) for m in COMPARISON_METRICS}
            for cell, centre in zip(cells, spread, strict=True)
        },
    )


@pytest.mark.parametrize(("low", "high"), [(0.002, 0.009), (0.01, 0.07), (1e-4, 30.0)])
def test_comparison_axes_are_named_and_log_labels_never_collide(low: float, high: float) -> None:
    fig = _side_by_side(_aggregate(low, high))
    assert fig is not None
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    axes = fig.get_axes()
    assert axes[0].get_ylabel() == "controller.type / sensors.noise_std.x"
    assert all(ax.get_xlabel() for ax in axes)
    assert "[m]" in axes[1].get_xlabel()
    logs = [ax for ax in axes if ax.get_xscale() == "log"]
    assert logs  # the metrics lie apart by more than a factor of 4
    for ax in logs:
        shown = [
            label.get_window_extent(renderer)
            for label in ax.get_xticklabels(minor=False) + ax.get_xticklabels(minor=True)
            if label.get_visible() and label.get_text()
        ]
        low_x, high_x = ax.get_window_extent(renderer).x0, ax.get_window_extent(renderer).x1
        shown = [box for box in shown if low_x - 1 <= (box.x0 + box.x1) / 2 <= high_x + 1]
        assert len(shown) >= 2, ax.get_title()  # a scale can be read
        shown.sort(key=lambda box: box.x0)
        for left, right in itertools.pairwise(shown):
            assert left.x1 < right.x0, ax.get_title()


@pytest.mark.parametrize("cells", [2, 4])
def test_comparison_title_stands_above_the_panels_titles(cells: int) -> None:
    aggregate = _aggregate(0.01, 0.07)
    aggregate.cells = dict(list(aggregate.cells.items())[:cells])
    fig = _side_by_side(aggregate)
    assert fig is not None
    renderer = FigureCanvasAgg(fig).get_renderer()
    fig.draw(renderer)
    (title,) = (
        text.get_window_extent(renderer)
        for text in fig.texts
        if text.get_text() == fig.get_suptitle()
    )
    assert title.y1 <= fig.bbox.y1  # within the image
    for ax in fig.get_axes():
        assert ax.title.get_window_extent(renderer).y1 < title.y0, ax.get_title()
