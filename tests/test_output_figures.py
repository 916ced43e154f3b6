"""What the figures show: phase colours and numbers, goals, the reference on top,
the output error against the eq. (4) bounds, and no pyplot state left behind."""

from __future__ import annotations

import math
from dataclasses import replace
from pathlib import Path

import matplotlib
import matplotlib.pyplot as plt
import numpy as np
import pytest
from matplotlib.colors import is_color_like, to_rgba
from test_output_synthetic import circle_run

from wmr_mission.output.animation import glyph_size
from wmr_mission.output.figures import (
    REFERENCE_STYLE,
    draw_all,
    phase_colors,
    plot_estimation_error,
    plot_inputs,
    plot_states,
    plot_xy,
    view_box,
)
from wmr_mission.output.result import RunResult
from wmr_mission.record import PhaseRecord, Transition
from wmr_mission.spec.models import NAMED_COLORS


def _many_phases(count: int, samples: int = 2001) -> RunResult:
    """circle_run cut into ``count`` phases of equal length."""
    run = circle_run(samples)
    phases = [PhaseRecord(f"leg-{i + 1}", "track") for i in range(count)]
    phase = (np.arange(run.samples) * count // run.samples).astype(np.int64)
    starts = np.flatnonzero(np.diff(phase)) + 1
    transitions = [
        Transition(float(run.t[k]), phases[i].name, phases[i + 1].name, "elapsed", 1.0)
        for i, k in enumerate(starts)
    ]
    return replace(run, phases=phases, phase=phase, transitions=transitions)


def _legend_labels(ax: matplotlib.axes.Axes) -> list[str]:
    legend = ax.get_legend()
    assert legend is not None
    return [text.get_text() for text in legend.get_texts()]


def test_colours_never_repeat_and_the_mission_chooses_its_own() -> None:
    for count in (3, 10, 11, 21, 60):
        colors = [to_rgba(c) for c in phase_colors(_many_phases(count))]
        assert len(set(colors)) == count, count
    run = circle_run()
    run.phases[1] = replace(run.phases[1], color="green")
    colors = phase_colors(run)
    assert colors[1] == "green"
    assert to_rgba(colors[0]) != to_rgba("green")


def test_every_colour_name_the_schema_accepts_is_one_matplotlib_knows() -> None:
    assert all(is_color_like(name) for name in NAMED_COLORS)
    assert len(NAMED_COLORS) == 148 + 10 + 10 + 8


def test_xy_legend_stays_short_with_many_phases() -> None:
    run = _many_phases(21)
    ax = plot_xy(run)
    labels = _legend_labels(ax)
    phase_entries = [label for label in labels if label.split(" ")[0].isdigit()]
    assert phase_entries == [f"{i + 1} leg-{i + 1}" for i in range(21)]
    assert sum("reference" in label for label in labels) == 1  # one entry, not one per phase
    generic = [
        "estimate",
        "reference",
        "heading",
        "phase change (number of the next phase)",
        "start",
        "end",
    ]
    assert labels == phase_entries + [f"region {name}" for name in run.regions] + generic
    legend = ax.get_legend()
    assert legend is not None
    assert legend._ncols == 2  # two columns (matplotlib has no public getter)


def test_heading_arrows_show_a_robot_that_reverses() -> None:
    run = circle_run()
    # Reversing round the same circle: the heading is against the direction of travel.
    backwards = replace(run, theta=run.theta + math.pi)
    for result, along in ((run, 1.0), (backwards, -1.0)):
        ax = plot_xy(result)
        assert "heading" in _legend_labels(ax)
        (arrows,) = [c for c in ax.collections if isinstance(c, matplotlib.quiver.Quiver)]
        u, v = np.asarray(arrows.U), np.asarray(arrows.V)
        assert len(u) >= 16
        # the circle's direction of travel at each arrow's foot (counter-clockwise)
        foot = arrows.get_offsets()
        tangent = np.column_stack((-foot[:, 1], foot[:, 0]))
        assert np.all(along * (u * tangent[:, 0] + v * tangent[:, 1]) > 0)
        plt.close("all")


def test_phases_that_did_not_run_keep_the_numbers_running_on() -> None:
    run = _many_phases(4)
    run.phases.insert(2, PhaseRecord("contingency", "regulate"))
    run = replace(run, phase=np.where(run.phase >= 2, run.phase + 1, run.phase))
    labels = _legend_labels(plot_xy(run))
    phase_entries = [label for label in labels if label.split(" ")[0].isdigit()]
    assert phase_entries == [
        "1 leg-1",
        "2 leg-2",
        "3 contingency (did not run)",
        "4 leg-3",
        "5 leg-4",
    ]
    plt.close("all")


def test_a_geofence_zone_is_drawn_as_kept_out() -> None:
    run = circle_run()
    run = replace(
        run, regions={**run.regions, "pond": {"type": "circle", "center": [0, 0], "radius": 0.3}}
    )
    assert "region pond" in _legend_labels(plot_xy(run))
    fenced = replace(run, mission={"geofence": {"keep_in": [], "keep_out": ["pond"]}})
    assert "region pond (kept out of)" in _legend_labels(plot_xy(fenced))
    plt.close("all")


def test_overlaid_runs_say_each_thing_once_with_their_own_label_and_colour() -> None:
    first, second = circle_run(), circle_run()
    second = replace(second, x=second.x * 1.5, y=second.y * 1.5)
    ax = plot_xy(first, label="nominal", color="tab:blue")
    plot_xy(second, ax=ax, label="wider", color="tab:red")
    labels = _legend_labels(ax)
    assert len(labels) == len(set(labels)), labels
    assert {"nominal", "wider", "start", "end", "estimate"} <= set(labels)
    legend = ax.get_legend()
    assert legend is not None
    lines = {
        t.get_text(): h for t, h in zip(legend.get_texts(), legend.legend_handles, strict=True)
    }
    assert to_rgba(lines["nominal"].get_color()) == to_rgba("tab:blue")
    assert to_rgba(lines["wider"].get_color()) == to_rgba("tab:red")
    # the view holds both runs
    assert ax.get_xlim()[1] >= float(second.x.max())
    plt.close("all")


def test_phase_changes_are_numbered_once_per_place() -> None:
    ax = plot_xy(circle_run())
    texts = sorted(text.get_text() for text in ax.texts)
    # beside the ellipse's tab: only the park keeps it (tests/test_zone_in_some_phases.py)
    assert texts == ["2", "3", "ellipse: kept in by phase park only"]


def test_reference_is_drawn_over_the_path() -> None:
    ax = plot_xy(circle_run())
    reference = [line for line in ax.lines if line.get_linestyle() == "--"]
    path = [lines for lines in ax.collections if lines.get_linewidth()[0] > 2.0]
    assert reference
    assert path
    assert min(line.get_zorder() for line in reference) > max(lines.get_zorder() for lines in path)
    assert REFERENCE_STYLE["color"] == "black"


def test_goals_and_waypoints_are_marked() -> None:
    run = circle_run()
    waypoints = ((1.0, 1.0), (2.0, -1.0), (-1.5, 0.5))
    run.phases[0] = replace(run.phases[0], points=waypoints)
    run.phases[1] = replace(run.phases[1], near=(0.5, 2.5, 0.2))
    ax = plot_xy(run)
    labels = _legend_labels(ax)
    assert "near goal" in labels
    assert "waypoint" in labels
    assert "near goal not reached" not in labels
    marker = next(line for line in ax.lines if line.get_label() == "waypoint")
    assert sorted(zip(marker.get_xdata(), marker.get_ydata(), strict=True)) == sorted(waypoints)
    # The same goal, missed: the phase timed out waiting for it.
    missed = replace(
        run,
        transitions=[Transition(3.0, "orbit", None, "timeout", 3.0)],
    )
    assert "near goal not reached" in _legend_labels(plot_xy(missed))
    view = view_box(run)
    assert view[0] < -1.5 and view[3] > 2.5  # noqa: PT018 - the view holds every goal


def test_estimation_figure_bounds_the_output_error_and_shows_the_true_error() -> None:
    run = circle_run()
    noise = np.random.default_rng(1).normal(0.0, 0.01, run.samples)
    run.x_meas = run.x + noise
    run.y_meas = run.y - noise
    fig = plot_estimation_error(run)
    axes = fig.axes
    assert len(axes) == 6
    x_whole = axes[1]
    lines = {line.get_label(): line for line in x_whole.lines}
    output_error = lines["measurement - estimate"].get_ydata()
    assert np.allclose(output_error, (run.x_meas - run.x_est)[: len(output_error)], equal_nan=True)
    true_error = lines["true - estimate"].get_ydata()
    assert np.allclose(true_error, (run.x - run.x_est)[: len(true_error)])
    bounds = [line for line in x_whole.lines if line.get_label() == "eq. (4) bound"]
    assert [line.get_ydata()[0] for line in bounds] == [-0.05]
    assert all(ax.get_yscale() == "linear" for ax in axes)
    # the start at full scale (1 m), the whole run at the scale of the bounds
    assert axes[0].get_ylim()[1] - axes[0].get_ylim()[0] > 1.0
    assert x_whole.get_ylim()[1] < 0.2
    # theta is not measured: only the true error, and a note
    theta_labels = {line.get_label() for line in axes[5].lines}
    assert "measurement - estimate" not in theta_labels
    assert any("theta not measured" in text.get_text() for text in axes[5].texts)


def test_plot_functions_draw_on_given_axes() -> None:
    run = circle_run()
    fig, ax = plt.subplots()
    assert plot_xy(run, ax=ax) is ax
    fig, axes = plt.subplots(3, 1)
    assert plot_states(run, axes=axes) is fig
    fig, axes = plt.subplots(2, 1)
    assert plot_inputs(run, axes=axes) is fig
    fig, axes = plt.subplots(3, 2)
    assert plot_estimation_error(run, axes=axes) is fig
    with pytest.raises(ValueError, match="expected 6 axes, got 2"):
        plot_estimation_error(run, axes=axes[0])


def test_files_are_drawn_outside_pyplot(tmp_path: Path) -> None:
    plt.close("all")
    backend = matplotlib.get_backend()
    paths = draw_all(circle_run(300), tmp_path, ("svg",))
    assert [p.name for p in paths] == [
        "verdicts.svg",
        "xy.svg",
        "states.svg",
        "estimation_error.svg",
        "inputs.svg",
    ]
    assert plt.get_fignums() == []  # no figure left open in pyplot
    assert matplotlib.get_backend() == backend
    with pytest.raises(ValueError, match="unknown figure format 'gif'"):
        draw_all(circle_run(300), tmp_path, ("gif",))


def test_the_robot_glyph_scales_with_the_scene() -> None:
    small = glyph_size((0.0, 2.0, 0.0, 1.0))
    large = glyph_size((0.0, 200.0, -50.0, 50.0))
    assert large / small == pytest.approx(100.0)
    assert math.isclose(small, 0.08)


def test_a_run_directory_from_before_the_measurement_column_still_plots(tmp_path: Path) -> None:
    from wmr_mission.output.reader import load_run
    from wmr_mission.output.rundir import write_run

    write_run(circle_run(200), tmp_path, plots=False, animate=False)
    csv = tmp_path / "trajectory.csv"
    rows = [line.split(",") for line in csv.read_text().splitlines()]
    measured = [rows[0].index(name) for name in ("x_meas", "y_meas", "theta_meas")]
    older = [[cell for i, cell in enumerate(row) if i not in measured] for row in rows]
    csv.write_text("\n".join(",".join(row) for row in older) + "\n")
    run = load_run(tmp_path)
    assert run.samples == 200
    assert np.isnan(run.x_meas).all()
    assert plot_estimation_error(run).axes


def test_names_are_drawn_as_typed_without_changing_the_settings() -> None:
    run = circle_run(200)
    run.phases[0] = replace(run.phases[0], name="$x")
    run.mission_name = "$\\frac{1$"
    with matplotlib.rc_context({"text.parse_math": True}):
        ax = plot_xy(run)
        ax.figure.canvas.draw()  # an unbalanced '$' parsed as math would raise here
        assert matplotlib.rcParams["text.parse_math"] is True
    assert "1 $x" in _legend_labels(ax)
