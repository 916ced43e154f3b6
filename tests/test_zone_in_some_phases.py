"""A zone that one phase keeps out of and another drives through: the figures
name the phases that keep it, and summary.json says which phases its
``clearance_min`` is the least over (the verdicts judge the zone only where it
is kept, docs/mission-format.md)."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from wmr_mission import mission_from_text, run_mission
from wmr_mission.output import animation
from wmr_mission.output.figures import (
    Keeping,
    keeping_words,
    plot_xy,
    region_sides,
)
from wmr_mission.output.result import RunResult

# Phase A's path runs through the rock, 0.65 m deep at its middle; phase B keeps out of it.
ROCK_IN_ONE_PHASE = """
version: 1
name: rock-in-one-phase
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 2, omega: 3}
regions:
  rock: {type: circle, center: [3, 0.35], radius: 1.0}
phases:
  - name: A
    track:
      path: {type: polyline, points: [[0, 0], [6, 0]], speed: 1.0}
    until: {near: {point: [6, 0], tolerance: 0.05}}
    timeout: 20
  - name: B
    regulate: {target: {x: 6, y: 4, theta: 1.5708}}
    constraints: [{stay_outside: rock}]
    until: {settled: {position: 0.02, heading: 0.02}}
    timeout: 30
"""
SCOPED = "rock: kept out by phase B only"


@pytest.fixture(scope="module")
def rock_run() -> RunResult:
    result = run_mission(mission_from_text(ROCK_IN_ONE_PHASE))
    assert result.outcome.value == "success"
    return result


def _texts(ax: Any) -> list[str]:
    return [text.get_text() for text in ax.texts]


def _legend_labels(ax: Any) -> list[str]:
    return [text.get_text() for text in ax.get_legend().get_texts()]


def test_the_run_went_into_the_zone_in_the_phase_that_does_not_keep_it(
    rock_run: RunResult,
) -> None:
    in_a = rock_run.phase == 0
    depth = 1.0 - np.hypot(rock_run.x[in_a] - 3.0, rock_run.y[in_a] - 0.35)
    assert depth.max() == pytest.approx(0.65, abs=1e-3)  # the premise
    summary = rock_run.summary()
    # the documented rule, unchanged: the zone is judged where a phase keeps it
    (a, b) = summary["phases"]
    assert a["constraint"]["clearance_min"] is None
    assert summary["clearance_min"] == b["constraint"]["clearance_min"] > 1.9


def test_the_summary_says_which_phases_the_run_clearance_covers(rock_run: RunResult) -> None:
    summary = rock_run.summary()
    assert summary["clearance_phases"] == ["B"]
    keys = list(summary)
    assert keys.index("clearance_phases") == keys.index("clearance_min") + 1


def test_the_xy_figure_names_the_phases_that_keep_the_zone(rock_run: RunResult) -> None:
    ax = plot_xy(rock_run)
    assert SCOPED in _texts(ax)
    assert "region rock (kept out by phase B only)" in _legend_labels(ax)
    assert "region rock (kept out of)" not in _legend_labels(ax)


def test_the_animation_names_them_too(
    rock_run: RunResult, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    drawn_on: list[Any] = []
    draw = animation.draw_regions

    def spied(ax: Any, *args: Any) -> None:
        drawn_on.append(ax)
        draw(ax, *args)

    monkeypatch.setattr(animation, "draw_regions", spied)
    animation.write_animation(rock_run, tmp_path / "animation.gif", max_frames=2)
    (ax,) = drawn_on
    assert SCOPED in _texts(ax)


def test_a_zone_kept_throughout_is_drawn_as_before(rock_run: RunResult) -> None:
    keeps = (("rock", "outside"),)
    everywhere = replace(rock_run, phases=[replace(p, constraints=keeps) for p in rock_run.phases])
    assert region_sides(everywhere) == {"rock": Keeping("outside")}
    ax = plot_xy(everywhere)
    assert not any(text.startswith("rock") for text in _texts(ax))
    assert "region rock (kept out of)" in _legend_labels(ax)
    fenced = replace(rock_run, mission={"geofence": {"keep_in": [], "keep_out": ["rock"]}})
    assert region_sides(fenced) == {"rock": Keeping("outside")}
    assert not any(text.startswith("rock") for text in _texts(plot_xy(fenced)))


def test_a_repeated_phase_is_named_once_as_written(rock_run: RunResult) -> None:
    (a, b) = rock_run.phases
    lapped = replace(rock_run, phases=[a, replace(b, name="B#1")])
    assert region_sides(lapped) == {"rock": Keeping("outside", ("B",))}
    assert keeping_words(Keeping("inside", ("B",))) == "kept in by phase B only"
    many = Keeping("outside", ("B", "C", "D", "E"))
    assert keeping_words(many) == "kept out by phases B, C and 2 more only"
