"""The figure that explains a run (verdicts.png): its signals are the ones the
verdicts judged, and a failure is drawn with its bound and its time."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
import pytest
from failing import ungated_disturbed

from wmr_mission.output.figures import FIGURE_NAMES, _figure
from wmr_mission.output.result import RunResult
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec import catalog
from wmr_mission.spec.loader import load_mission
from wmr_mission.verdicts.signals import line_of, panel_of, run_signals

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

MISSIONS = Path(__file__).resolve().parent.parent / "missions"


@pytest.fixture(scope="module")
def disturbed() -> RunResult:
    """disturbed with its outliers let through fails: they kick the turn rate
    past its jump bound."""
    result = run_mission(ungated_disturbed())
    assert result.outcome.value == "expect-failed"  # the premise
    return result


def test_the_failed_checks_are_marked_on_the_signals_they_judge(disturbed: RunResult) -> None:
    signals = run_signals(disturbed)
    failed = signals.failed()
    summary = disturbed.judged
    assert summary is not None
    unmet = {(c["phase"], c["metric"]) for c in summary["expectations"] if not c["met"]}
    assert {(c.phase, c.metric) for c in failed} == unmet
    assert unmet  # the premise
    peaks = [check for check in failed if check.peak]
    assert peaks  # the premise: a failure drawn sample by sample
    for check in peaks:
        panel, line = panel_of(check.metric), line_of(check.metric)
        assert panel is not None
        assert line is not None
        values = signals.lines[panel][line]
        start, end = check.span
        judged = signals.judged[line][start:end]
        # The largest judged sample of the drawn signal is the value the verdict found.
        assert np.nanmax(np.abs(values[start:end][judged])) == check.value
        assert check.over.size
        assert np.all(np.abs(values[check.over]) > check.bound)
        assert np.all((check.over >= start) & (check.over < end))
        assert np.all(signals.judged[line][check.over])
    times = [disturbed.t[c.over[0]] for c in failed if c.over.size]
    assert times == sorted(times)  # the first failure in time comes first


def test_a_failing_run_opens_on_its_failure(disturbed: RunResult) -> None:
    assert FIGURE_NAMES[0] == "verdicts"
    figure = _figure(disturbed, "verdicts")
    first = run_signals(disturbed).failed()[0]
    when = float(disturbed.t[first.over[0]])
    assert figure._suptitle is not None
    title = figure._suptitle.get_text()
    assert f"failed {first.phase}: {first.metric}" in title
    assert f"t = {when:.4g} s" in title
    top = figure.axes[0]
    assert panel_of(first.metric) == "jumps"
    assert "change" in top.get_ylabel()
    # the time of the failure drawn across every panel
    for ax in figure.axes:
        assert any(list(line.get_xdata()) == [when, when] for line in ax.get_lines()), (
            ax.get_ylabel()
        )
    # its bound drawn (dashed, red where failed) and the samples beyond it marked
    marked = [line for line in top.get_lines() if line.get_marker() == "x"]
    assert marked
    assert all(y > first.bound for line in marked for y in line.get_ydata())


def test_a_run_that_meets_its_checks_says_so() -> None:
    result = run_mission(load_mission(MISSIONS / "fence.yaml"))
    assert result.succeeded
    signals = run_signals(result)
    assert signals.checks
    assert not signals.failed()
    assert all(c.over.size == 0 for c in signals.checks)
    figure = _figure(result, "verdicts")
    assert figure._suptitle is not None
    assert "every expect check met" in figure._suptitle.get_text()
    # the fence's constraint value is drawn with its bound
    assert any("constraint" in ax.get_ylabel() for ax in figure.axes)


def test_the_zones_panel_draws_the_body_that_clearance_min_judges() -> None:
    """shelf.yaml's robot is a disc of 0.25 m: beside the axle's depth into the
    shelf, the panel draws the body's (the axle's plus the radius), whose
    highest is minus the clearance_min summary.json gives (to its 1e-6 m)."""
    from wmr_mission.verdicts.metrics import judge
    from wmr_mission.verdicts.signals import BODY_DEPTH

    result = run_mission(load_mission(MISSIONS / "shelf.yaml"))
    summary = judge(result, result.mission)
    signals = run_signals(result)
    axle, body = signals.lines["zones"]["depth into a zone"], signals.lines["zones"][BODY_DEPTH]
    drawn = np.isfinite(axle)
    assert drawn.any()
    assert np.array_equal(np.isfinite(body), drawn)
    assert np.allclose(body[drawn] - axle[drawn], 0.25, rtol=0.0, atol=1e-12)
    least = min(
        phase["constraint"]["clearance_min"]
        for phase in summary["phases"]
        if (phase.get("constraint") or {}).get("clearance_min") is not None
    )
    assert abs(float(np.max(body[drawn])) + least) <= 1e-6
    clearances = [check for check in signals.checks if check.metric == "clearance_min"]
    assert clearances  # each drawn at 0 on the body's line
    assert {(check.line, check.level) for check in clearances} == {(BODY_DEPTH, 0.0)}


def test_the_level_words_leave_the_signals_in_view() -> None:
    """The words of a panel's level checks sit above its lines: shelf.yaml's
    speed at its limit (|v| / limit = 1) was hidden behind them."""
    result = run_mission(load_mission(MISSIONS / "shelf.yaml"))
    fig = _figure(result, "verdicts")
    fig.canvas.draw()
    worded = []
    for ax in fig.axes:
        for text in ax.texts:
            if " met: " not in text.get_text():
                continue
            worded.append(ax.get_ylabel().split("\n")[0].split(" [")[0])
            bottom = ax.transAxes.inverted().transform(text.get_window_extent().corners())[:, 1]
            tops = [
                ax.transAxes.inverted().transform(ax.transData.transform((0.0, np.nanmax(y))))[1]
                for line in ax.get_lines()
                if (y := np.asarray(line.get_ydata(), dtype=float)).size and np.isfinite(y).any()
            ]
            if ax.get_yscale() == "linear":
                assert max(tops) < bottom.min(), text.get_text()
    # the inputs' and the jitter's panels (the zones' clearance_min is drawn as its bound)
    assert sorted(worded) == ["|input| / limit", "ω - moving mean"]


@pytest.fixture(scope="module")
def shelf() -> RunResult:
    """shelf.yaml: each lap's track phase bounds the cross-track error twice
    (cross_track_error_max, and detour_offset_max round the shelf), the depth
    into the shelf twice (zone_intrusion_max, clearance_min on the body's),
    and the depth stays about a metre on the allowed side."""
    return run_mission(load_mission(MISSIONS / "shelf.yaml"))


def _panel(figure: Figure, panel: str) -> Axes:
    from wmr_mission.verdicts.signals import PANELS

    return next(ax for ax in figure.axes if ax.get_ylabel() == PANELS[panel])


def test_each_bound_is_named_in_its_panels_legend(shelf: RunResult) -> None:
    """A panel's dashed bounds are named by their metric, one legend entry and
    one dash each: the cross-track error's two bounds of a track phase were both
    "expect max"."""
    from matplotlib.collections import LineCollection

    signals = run_signals(shelf)
    figure = _figure(shelf, "verdicts")
    named = {
        "cross_track": ["cross_track_error_max", "detour_offset_max"],
        "along_track": ["along_track_lag_max"],  # one kind: one entry, its ± bounds
        "zones": ["zone_intrusion_max", "clearance_min"],
        "jumps": ["speed_jump_max", "turn_rate_jump_max"],
    }
    for panel, metrics in named.items():
        ax = _panel(figure, panel)
        legend = ax.get_legend()
        assert legend is not None
        labels = [text.get_text() for text in legend.get_texts()]
        assert "expect max" not in labels
        assert [label for label in labels if label in catalog.CATALOG] == metrics, panel
        # each metric's bounds drawn in a dash of their own, the same in every phase
        (bounds,) = [  # the phases' boundaries are the panel's other lines, upright
            c
            for c in ax.collections
            if isinstance(c, LineCollection)
            and all(segment[0][1] == segment[-1][1] for segment in c.get_segments())
        ]
        segments, dashes = bounds.get_segments(), bounds.get_dashes()
        checks = [c for c in signals.checks if c.peak and panel_of(c.metric) == panel]
        levels = {metric: {c.level for c in checks if c.metric == metric} for metric in metrics}
        assert all(levels.values())  # the premise: each metric bounds the panel
        drawn: dict[str, set[str]] = {metric: set() for metric in metrics}
        for segment, dash in zip(segments, dashes, strict=True):
            level = abs(float(segment[0][1]))
            (metric,) = [m for m in metrics if any(abs(v) == level for v in levels[m])]
            drawn[metric].add(repr(dash))
        assert all(len(kinds) == 1 for kinds in drawn.values()), drawn
        assert len({next(iter(kinds)) for kinds in drawn.values()}) == len(metrics)


def test_the_depth_panel_ticks_each_decade_it_spans(shelf: RunResult) -> None:
    """The depth into the shelf stays about a metre on the allowed side: the
    symlog axis ticks 0, the bound (zone_intrusion_max, 5 mm) and each decade
    between, where a tick at -0.005 was followed by -1 alone."""
    ax = _panel(_figure(shelf, "verdicts"), "zones")
    assert ax.get_yscale() == "symlog"
    low, _ = ax.get_ylim()
    assert low < -1.0  # the premise
    ticks = [float(t) for t in ax.get_yticks()]
    assert {0.0, 0.005, -0.01, -0.1, -1.0} <= set(ticks)
    assert len(ticks) <= 6
    assert [label.get_text() for label in ax.get_yticklabels()] == [f"{t:g}" for t in ticks]


@pytest.mark.parametrize(("low", "high"), [(-300.0, 0.12), (-1.3, 0.1), (-0.002, 2.5)])
def test_a_symlog_axis_keeps_its_ticks_apart(low: float, high: float) -> None:
    """However far the range, a symlog panel ticks 0 and its bound, at most six
    ticks, the others each an eighth of the axis from any, the farthest decade
    first."""
    from matplotlib.figure import Figure as NewFigure

    from wmr_mission.output.figures import _symlog_ticks

    ax = NewFigure().add_subplot()
    ax.set_ylim(low, high)
    ax.set_yscale("symlog", linthresh=0.005, linscale=1.0)
    _symlog_ticks(ax, [0.005], 0.005)
    ticks = [float(t) for t in ax.get_yticks()]
    assert {0.0, 0.005} <= set(ticks)
    assert len(ticks) <= 6
    assert all(low <= t <= high for t in ticks)
    scaled = ax.yaxis.get_transform().transform(np.array([low, high, *ticks]))
    gap = (scaled[1] - scaled[0]) / 8.0
    for tick, at in zip(ticks, scaled[2:], strict=True):
        if tick not in (0.0, 0.005):
            others = np.delete(scaled[2:], ticks.index(tick))
            assert np.min(np.abs(others - at)) >= gap - 1e-12, (tick, ticks)
    farthest = -(10.0 ** np.floor(np.log10(-low))) if -low >= 0.005 else None
    assert farthest is None or farthest in ticks
