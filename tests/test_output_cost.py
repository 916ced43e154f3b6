"""A figure's cost does not grow with the number of phases: the number of
artists drawn stays bounded (counted, not timed)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_output_synthetic import circle_run

from wmr_mission.output import plots
from wmr_mission.result import PhaseInfo, RunResult, Transition


def many_phases(count: int) -> RunResult:
    """The synthetic circle cut into ``count`` alternating track and hold phases."""
    run = circle_run()
    phase = (np.arange(run.samples) * count // run.samples).astype(np.int64)
    phases = [
        PhaseInfo(f"p{i}", "track") if i % 2 == 0 else PhaseInfo(f"p{i}", "hold", (i, 0.0, 0.0))
        for i in range(count)
    ]
    starts = np.flatnonzero(np.diff(phase)) + 1
    transitions = [
        Transition(float(run.t[k]), f"p{i}", f"p{i + 1}", "elapsed", 0.1)
        for i, k in enumerate(starts)
    ]
    return replace(run, phase=phase, phases=phases, transitions=transitions)


def artists_drawn(draw: Any, run: RunResult, monkeypatch: pytest.MonkeyPatch) -> int:
    counted = []

    def count(fig: Any, path: Path) -> Path:
        counted.append(sum(len(ax.get_children()) for ax in fig.axes))
        plots.pyplot().close(fig)
        return path

    monkeypatch.setattr(plots, "_save", count)
    draw(run, Path("unused.png"))
    return counted[0]


@pytest.mark.parametrize(
    "draw",
    [plots.draw_xy, plots.draw_states, plots.draw_estimation_error, plots.draw_inputs],
    ids=lambda f: f.__name__,
)
def test_artists_do_not_grow_with_the_phases(draw: Any, monkeypatch: pytest.MonkeyPatch) -> None:
    few = artists_drawn(draw, many_phases(2 * plots.MAX_NAMED_PHASES), monkeypatch)
    many = artists_drawn(draw, many_phases(1000), monkeypatch)
    assert many <= few
