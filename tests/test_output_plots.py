from __future__ import annotations

import math
import subprocess
import sys
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
from matplotlib.backends.backend_agg import FigureCanvasAgg
from PIL import Image
from test_output_synthetic import circle_run

from wmr_mission.commands.plot import replot_command
from wmr_mission.output.figures import (
    DPI,
    MAX_POINTS_PER_LINE,
    _clip_half_plane,
    _figure,
    draw_all,
    thin,
)
from wmr_mission.output.rundir import write_run

FIGURES = ["verdicts.png", "xy.png", "states.png", "estimation_error.png", "inputs.png"]


def test_draw_all_writes_five_legible_pngs(tmp_path: Path) -> None:
    paths = draw_all(circle_run(), tmp_path)
    assert [p.name for p in paths] == FIGURES
    for path in paths:
        assert path.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
        assert path.stat().st_size > 20_000
        with Image.open(path) as image:
            width, height = image.size
        assert 700 <= width <= 2000, path.name
        assert 400 <= height <= 1600, path.name
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(FIGURES)  # no temporaries


def test_thin_keeps_ends_and_bounds_the_points() -> None:
    k = thin(0, 360_000)
    assert k.size <= MAX_POINTS_PER_LINE + 1
    assert (k[0], k[-1]) == (0, 359_999)
    assert np.all(np.diff(k) > 0)
    np.testing.assert_array_equal(thin(5, 9), [5, 6, 7, 8])
    assert thin(3, 3).size == 0


def test_half_plane_is_clipped_to_its_inside() -> None:
    inside = _clip_half_plane((0.0, 4.0, 0.0, 2.0), (1.0, 0.0), 1.0)
    assert inside[:, 0].max() == pytest.approx(1.0)
    assert inside[:, 0].min() == pytest.approx(0.0)
    assert len(inside) == 4
    assert len(_clip_half_plane((0.0, 4.0, 0.0, 2.0), (1.0, 0.0), -1.0)) == 0


def test_long_run_with_a_diverged_tail_still_plots(tmp_path: Path) -> None:
    run = circle_run(60_000)
    run.x = run.x.copy()
    run.x[-100:] = np.inf
    run.y = np.where(np.arange(run.samples) > 59_800, np.nan, run.y)
    paths = draw_all(run, tmp_path)
    assert all(p.stat().st_size > 20_000 for p in paths)


def test_replot_redraws_a_written_run(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    write_run(
        circle_run(),
        tmp_path,
        mission_sha256="0" * 64,
        resolved_mission={},
        mission_file="circle.yaml",
        plots=False,
        animate=False,
    )
    assert replot_command(tmp_path) == 0
    printed = capsys.readouterr().out.split()
    assert printed == [str(tmp_path / name) for name in FIGURES]
    assert all((tmp_path / name).stat().st_size > 20_000 for name in FIGURES)


def test_replot_of_a_broken_run_dir_is_one_line_on_stderr(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    write_run(
        circle_run(100),
        tmp_path,
        mission_sha256="0" * 64,
        resolved_mission={},
        mission_file="circle.yaml",
        plots=False,
        animate=False,
    )
    (tmp_path / "trajectory.csv").unlink()
    assert replot_command(tmp_path) == 1
    captured = capsys.readouterr()
    assert captured.out == ""
    assert captured.err == (
        f"{tmp_path}: trajectory.csv is missing (not a run directory, or an interrupted run)\n"
    )


def test_importing_the_output_modules_does_not_load_matplotlib() -> None:
    code = (
        "import sys, wmr_mission.output.rundir, wmr_mission.output.figures, "
        "wmr_mission.output.animation, wmr_mission.output.report; "
        "sys.exit('matplotlib' in sys.modules)"
    )
    assert subprocess.run([sys.executable, "-c", code], check=False).returncode == 0


def test_write_run_writes_the_summary_before_the_figures(tmp_path: Path) -> None:
    written = write_run(
        circle_run(300),
        tmp_path,
        mission_sha256="0" * 64,
        resolved_mission={},
        mission_file="circle.yaml",
        plots=True,
        animate=False,
    )
    names = [p.name for p in written]
    assert names[3] == "summary.json"
    assert names[4:9] == FIGURES
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(names)


def test_a_png_records_its_resolution(tmp_path: Path) -> None:
    (path, *_) = draw_all(circle_run(300), tmp_path)
    with Image.open(path) as image:
        assert image.mode in ("RGB", "RGBA")
        assert [round(d) for d in image.info["dpi"]] == [DPI, DPI]


def test_estimation_titles_need_no_room_from_the_exponents_beside_them() -> None:
    """The estimation figure's titles are placed at their axes' top without
    matplotlib's search for room: the search would only move them for a y
    exponent they overlap, and errors of a nanometre give the top row one."""
    run = circle_run()
    run = replace(
        run,
        x_est=run.x + 1e-9 * np.cos(run.t),
        error_bounds=((math.nan, math.nan), run.error_bounds[1], run.error_bounds[2]),
    )
    fig = _figure(run, "estimation_error")
    canvas = FigureCanvasAgg(fig)
    canvas.draw()
    renderer = canvas.get_renderer()
    for ax in fig.axes[:2]:
        exponent = ax.yaxis.offsetText
        assert exponent.get_text(), "no exponent: the test would show nothing"
        title = ax.title.get_window_extent(renderer)
        assert not title.overlaps(exponent.get_window_extent(renderer))
        assert title.y0 >= ax.get_window_extent(renderer).y1


@pytest.mark.parametrize("name", ["keep-out", "patrol-detour", "case1"])
def test_phase_labels_on_time_plots_never_overlap(name: str) -> None:
    """Each phase's number (and name where it fits) above the time plots: a
    label is pushed past its neighbour's or left out, never drawn over it."""
    import re

    from matplotlib.backends.backend_agg import FigureCanvasAgg

    from wmr_mission import load_mission, run_mission
    from wmr_mission.output.figures import plot_inputs, plot_states

    result = run_mission(
        load_mission(Path(__file__).resolve().parents[1] / "missions" / f"{name}.yaml")
    )
    for figure in (plot_states(result), plot_inputs(result)):
        renderer = FigureCanvasAgg(figure).get_renderer()
        labels = [
            text.get_window_extent(renderer)
            for ax in figure.axes
            for text in ax.texts
            if re.fullmatch(r"\d+( \S+)?", text.get_text())
        ]
        assert len(labels) >= 2, name
        for i, first in enumerate(labels):
            for second in labels[i + 1 :]:
                assert not first.overlaps(second), (name, first, second)
