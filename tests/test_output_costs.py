"""What the outputs of a run cost: the summary is computed once, memory grows
with the samples and not with a whole copy of them, the figures' artists do
not grow with the number of phases, and a figure that fails never loses the
data. Counts and allocated bytes, never wall-clock time."""

from __future__ import annotations

import json
import math
import tracemalloc
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from matplotlib.figure import Figure
from test_output_figures import _many_phases
from test_output_synthetic import circle_run

import wmr_mission.commands.plot as plot_command
import wmr_mission.output.figures as plots_module
import wmr_mission.output.rundir as rundir_module
import wmr_mission.verdicts.metrics as metrics_module
from wmr_mission.api import load_mission, run_mission
from wmr_mission.commands.run import run_command
from wmr_mission.output.figures import MAX_LEGEND_PHASES
from wmr_mission.output.files import json_text, write_json
from wmr_mission.output.reader import load_run
from wmr_mission.output.result import RunResult
from wmr_mission.output.rundir import CLAIM_FILE, SUMMARY_FILE, write_run, write_trajectory
from wmr_mission.record import PhaseRecord
from wmr_mission.verdicts.metrics import LOCAL_WINDOW, distance_to_path, summarize
from wmr_mission.verdicts.nearest import TREE_POSITIONS, NearestPoints

MISSION = """version: 1
name: short
robot: {dt: 0.01, limits: {v: 10, omega: 20}}
estimator: {type: constrained-observer}
phases:
  - name: lap
    track: {path: {type: circle, center: [0, 1], radius: 1, angular_rate: 1}}
    until: {elapsed: 1.0}
  - name: park
    regulate: {target: {x: 0, y: 0, theta: 0}}
    until: {elapsed: 0.5}
"""


def _laps(samples: int) -> RunResult:
    """circle_run as one track phase round and round its circle (about 80 laps
    in 100 000 samples), the reference 0.01 m off the path."""
    run = circle_run(samples)
    return replace(
        run,
        phases=[PhaseRecord("laps", "track")],
        phase=np.zeros(samples, dtype=np.int64),
        x_ref=run.x + 0.01,
        y_ref=run.y.copy(),
        constraint=np.full(samples, np.nan),
        transitions=[],
    )


def _peak_bytes(work: Any) -> int:
    tracemalloc.start()
    try:
        work()
        return tracemalloc.get_traced_memory()[1]
    finally:
        tracemalloc.stop()


# --- the summary, once ----------------------------------------------------------


def test_run_computes_the_summary_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`run` judges the run (run_mission), writes summary.json and prints the
    table: one summary for the three."""
    calls = []
    real = metrics_module.summarize

    def counted(*args: Any, **kwargs: Any) -> dict[str, Any]:
        calls.append(args)
        return real(*args, **kwargs)

    monkeypatch.setattr(metrics_module, "summarize", counted)
    monkeypatch.setattr(rundir_module, "summarize", counted)
    mission = tmp_path / "short.yaml"
    mission.write_text(MISSION)
    out = tmp_path / "run"
    assert run_command(mission, out=out, seed=None, plots=False, animate=False) == 0
    assert len(calls) == 1
    written = load_run(out)
    assert written.samples == 151
    assert "lap" in capsys.readouterr().out


def test_run_checks_and_plans_the_mission_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """`run` checks the mission once, as it loads it, and plans it once: the
    runner takes the plan, and the judge the mission as loaded, never checked
    (dumped and loaded again) nor planned again."""
    from wmr_mission.sim import plan as plan_module
    from wmr_mission.sim import runner as runner_module

    calls: dict[str, int] = {"checked again": 0, "planned": 0}
    real_check, real_plan = runner_module.validate_mission, plan_module.plan_mission

    def checked(*args: Any, **kwargs: Any) -> Any:
        calls["checked again"] += 1
        return real_check(*args, **kwargs)

    def planned(*args: Any, **kwargs: Any) -> Any:
        calls["planned"] += 1
        return real_plan(*args, **kwargs)

    monkeypatch.setattr(runner_module, "validate_mission", checked)
    monkeypatch.setattr(plan_module, "plan_mission", planned)
    monkeypatch.setattr(runner_module, "plan_mission", planned)
    mission = tmp_path / "short.yaml"
    mission.write_text(MISSION)
    out = tmp_path / "run"
    assert run_command(mission, out=out, seed=None, plots=False, animate=False) == 0
    assert calls == {"checked again": 0, "planned": 1}
    summary = json.loads((out / SUMMARY_FILE).read_text())
    assert summary["outcome"] == "success"  # judged
    assert summary["margin"] >= 0.0


# --- a figure that fails -----------------------------------------------------------


def _broken_drawing(*args: Any, **kwargs: Any) -> list[Path]:
    raise RuntimeError("a fault in drawing")


def test_a_figure_that_fails_keeps_the_data_and_the_summary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(plots_module, "draw_all", _broken_drawing)
    run = circle_run(300)
    with pytest.raises(RuntimeError, match="a fault in drawing"):
        write_run(run, tmp_path, resolved_mission={}, plots=True, animate=False)
    names = sorted(p.name for p in tmp_path.iterdir())
    assert names == ["manifest.json", "summary.json", "trajectory.csv", "transitions.json"]
    assert load_run(tmp_path).samples == 300


def test_run_says_a_figure_fault_in_one_line_and_keeps_the_summary(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(plots_module, "draw_all", _broken_drawing)
    mission = tmp_path / "short.yaml"
    mission.write_text(MISSION)
    out = tmp_path / "run"
    assert run_command(mission, out=out, seed=None, plots=True, animate=False) == 1
    stderr = capsys.readouterr().err
    assert stderr == (
        f"{out}: cannot draw the figures (RuntimeError: a fault in drawing); the data and "
        f"summary.json are in {out}; `wmr-mission plot {out}` draws again; please report it\n"
    )
    assert (out / SUMMARY_FILE).exists()
    assert not (out / CLAIM_FILE).exists()
    assert load_run(out).outcome.value == "success"


def test_plot_says_a_figure_fault_in_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """`wmr-mission plot` on a fault in drawing: one line and exit 1, no traceback."""
    mission = tmp_path / "short.yaml"
    mission.write_text(MISSION)
    out = tmp_path / "run"
    assert run_command(mission, out=out, seed=None, plots=False, animate=False) == 0
    capsys.readouterr()
    monkeypatch.setattr(plot_command, "draw_all", _broken_drawing)
    assert plot_command.replot_command(out) == 1
    assert capsys.readouterr().err == (
        f"{out}: cannot draw the figures (RuntimeError: a fault in drawing); "
        "the data are unchanged; please report it\n"
    )


def test_a_callers_edit_of_the_summary_never_reaches_summary_json(tmp_path: Path) -> None:
    """The summary kept from judging is handed out as a copy, nested values too."""
    mission = tmp_path / "short.yaml"
    mission.write_text(MISSION)
    result = run_mission(load_mission(mission))
    edited = result.summary()
    edited["final"]["position_error"] = 123.0
    assert result.summary()["final"]["position_error"] != 123.0
    result.write(tmp_path / "run", plots=False)
    written = json.loads((tmp_path / "run" / SUMMARY_FILE).read_text(encoding="utf-8"))
    assert written["final"]["position_error"] != 123.0


# --- memory ------------------------------------------------------------------------


def test_the_summary_of_a_long_run_allocates_little_beyond_its_samples() -> None:
    """A 100 000-sample track phase round 80 laps: the metrics allocate at most
    150 bytes per sample at once (its columns hold 144), not whole blocks of
    candidate segments."""
    import scipy.spatial  # noqa: F401  (loaded once per process: not the samples' memory)

    run = _laps(100_000)
    peak = _peak_bytes(lambda: summarize(run))
    assert peak < 150 * run.samples


def test_the_csv_is_written_in_blocks_of_constant_size(tmp_path: Path) -> None:
    """Twice the samples, the same peak: the text is never held whole."""

    def csv_peak(samples: int) -> int:
        """Peak bytes of writing the CSV beyond making the run."""
        made = _peak_bytes(lambda: _laps(samples))
        path = tmp_path / f"{samples}.csv"
        return _peak_bytes(lambda: write_trajectory(_laps(samples), path)) - made

    peaks = [csv_peak(8_000), csv_peak(16_000)]
    assert peaks[1] < 1.2 * peaks[0]


# --- the distance to the path ---------------------------------------------------------


def _nearest_by_brute_force(
    qx: np.ndarray, qy: np.ndarray, px: np.ndarray, py: np.ndarray, k: int
) -> np.ndarray:
    """Every point measured: the k smallest squared distances, ties to the earlier point."""
    squared = (px - qx[:, None]) ** 2 + (py - qy[:, None]) ** 2
    return np.argsort(squared, axis=1, kind="stable")[:, :k]


def test_nearest_points_equal_brute_force_with_ties_to_the_earlier_point() -> None:
    """The same points, in the same order, as measuring every point, by the
    grid and by the k-d tree: on clouds, random walks, grids (many points
    equally near a position), repeated points, and positions near and very far."""
    rng = np.random.default_rng(3)
    for trial in range(12):
        count = int(rng.integers(1, 1000))
        shape = trial % 4
        if shape == 0:
            px, py = rng.uniform(-5, 5, (2, count))
        elif shape == 1:
            px, py = np.cumsum(rng.normal(size=(2, count)), axis=1)
        elif shape == 2:  # a grid, shuffled: ties everywhere at the grid's points
            side = int(math.sqrt(count)) + 1
            px, py = (rng.permutation(np.indices((side, side)).reshape(2, -1), axis=1) * 0.5)[
                :, :count
            ]
        else:  # each point several times over
            px, py = np.repeat(rng.uniform(-5, 5, (2, count // 4 + 1)), 4, axis=1)[:, :count]
        px, py = (
            np.ascontiguousarray(px, dtype=np.float64),
            np.ascontiguousarray(py, dtype=np.float64),
        )
        qx, qy = rng.normal(0, 10 ** rng.uniform(-1, 3), (2, 600))
        qx[:200], qy[:200] = px[rng.integers(0, count, 200)], py[rng.integers(0, count, 200)]
        qx[200:300] = np.round(qx[200:300] * 4) / 4  # between grid points: ties
        qy[200:300] = np.round(qy[200:300] * 4) / 4
        cell = 10 ** rng.uniform(-2, 0)
        for positions in (0, TREE_POSITIONS):  # by the grid, by the tree
            points = NearestPoints(px, py, cell, positions)
            for k in (1, 4):
                found = points.nearest(qx, qy, k, np.zeros(qx.size))
                np.testing.assert_array_equal(found, _nearest_by_brute_force(qx, qy, px, py, k))


def _brute_force(
    qx: np.ndarray, qy: np.ndarray, px: np.ndarray, py: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Distance to the nearest segment of the polyline, every segment tried, and that segment."""
    ax, ay = px[:-1], py[:-1]
    sx, sy = px[1:] - ax, py[1:] - ay
    length2 = np.where(sx**2 + sy**2 > 0, sx**2 + sy**2, 1.0)
    found, segment = np.empty(qx.size), np.empty(qx.size, dtype=np.int64)
    for start in range(0, qx.size, 256):
        x, y = qx[start : start + 256, None], qy[start : start + 256, None]
        along = np.clip(((x - ax) * sx + (y - ay) * sy) / length2, 0, 1)
        distance = np.hypot(x - ax - along * sx, y - ay - along * sy)
        found[start : start + 256] = distance.min(axis=1)
        segment[start : start + 256] = distance.argmin(axis=1)
    return found, segment


@pytest.mark.parametrize("samples", [3_000, 40_000])  # one block, and ten
def test_distance_to_path_on_random_paths_against_brute_force(samples: int) -> None:
    """Random smooth paths flown twice (the second lap between the first's
    points), the robot up to ten sampling steps off, some samples far behind their
    reference point: never below the true distance, at most a sampling step
    above it, and exact where the nearest segment is near the sample's own
    reference point. 40 000 samples run through ten blocks."""
    rng = np.random.default_rng(samples)
    t = np.linspace(0.0, 4 * math.pi, samples)
    px = sum(rng.normal() * np.sin(m * t / 2 + rng.uniform(0, 6)) for m in range(1, 5))
    py = sum(rng.normal() * np.cos(m * t / 2 + rng.uniform(0, 6)) for m in range(1, 5))
    px, py = np.asarray(px, dtype=np.float64), np.asarray(py, dtype=np.float64)
    off = 10 * np.median(np.hypot(np.diff(px), np.diff(py)))  # ten sampling steps
    x = px + rng.uniform(-off, off, samples)
    y = py + rng.uniform(-off, off, samples)
    behind = np.arange(samples - 200, samples) - samples // 10
    x[-200:], y[-200:] = px[behind], py[behind] + off
    checked = np.r_[
        rng.choice(samples - 200, 600, replace=False), np.arange(samples - 200, samples)
    ]
    distance = distance_to_path(x, y, px, py)[checked]
    expected, segment = _brute_force(x[checked], y[checked], px, py)
    step = np.hypot(np.diff(px), np.diff(py)).max()
    assert np.all(distance >= expected - 1e-12)
    assert np.all(distance <= expected + step)
    near_own = np.abs(segment - checked) < LOCAL_WINDOW
    assert near_own[:-200].mean() > 0.5
    np.testing.assert_allclose(distance[near_own], expected[near_own], rtol=0, atol=1e-12)
    assert np.all(distance[-200:] <= off + step)  # far behind, but near the path


# --- figures, whatever the number of phases -------------------------------------------


def _cut(count: int) -> RunResult:
    """A 20 000-sample run cut into ``count`` phases of equal length, every
    other one a regulate phase with a target of its own and a `near` goal."""
    run = _many_phases(count, 20_000)
    phases = [
        replace(info, near=(math.cos(i), math.sin(i), 0.3))
        if i % 2
        else replace(info, kind="regulate", target=(math.cos(i), math.sin(i), 0.0))
        for i, info in enumerate(run.phases)
    ]
    return replace(run, phases=phases)


def _artists(run: RunResult) -> list[int]:
    """Artists on each of the four figures, as ``draw_all`` makes them."""
    counts = []
    for name in plots_module.FIGURE_NAMES:
        figure = Figure()
        if name == "xy":
            plots_module._xy_on(figure.add_subplot(), run)
        elif name == "states":
            plots_module._states_on(figure, list(figure.subplots(3, 1)), run)
        elif name == "estimation_error":
            plots_module._estimation_on(figure, list(figure.subplots(3, 2).ravel()), run)
        else:
            plots_module._inputs_on(figure, list(figure.subplots(2, 1)), run)
        # Phase labels above the plots over time: as many as there is room for.
        labels = 0 if name == "xy" else sum(len(ax.texts) for ax in figure.axes)
        assert labels <= 60
        counts.append(len(figure.findobj()) - labels)
    return counts


def test_the_figures_artists_do_not_grow_with_the_number_of_phases() -> None:
    """400 and 4 000 phases over the same samples: the same artists, where
    there were 2 lines per phase and axes, and a legend entry per phase."""
    assert _artists(_cut(400)) == _artists(_cut(4_000))
    legend = plots_module.plot_xy(_cut(4_000)).get_legend()
    assert legend is not None
    texts = [text.get_text() for text in legend.get_texts()]
    assert sum(text.startswith("leg-") or text[:1].isdigit() for text in texts) == (
        MAX_LEGEND_PHASES - 1
    )
    assert "... 3961 more, to 4000 leg-4000" in texts


def test_json_files_are_streamed_byte_for_byte_as_json_text(tmp_path: Path) -> None:
    value = {
        "phases": [
            {"name": f"leg-{i}", "rms": np.float64(i / 3), "gap": math.nan} for i in range(3)
        ],
        "file": "m\udcff.yaml",  # a file name that is not UTF-8
        "point": (1, np.int64(2)),
        "é": None,
    }
    path = write_json(tmp_path / "x.json", value)
    assert path.read_bytes() == json_text(value).encode("utf-8", "backslashreplace")
