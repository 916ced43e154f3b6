from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from PIL import GifImagePlugin, Image
from test_output_synthetic import circle_run

from wmr_mission.output.animation import MAX_FRAMES, frame_samples, robot_outline, write_animation
from wmr_mission.output.rundir import write_run


def test_animation_is_a_gif_of_several_frames(tmp_path: Path) -> None:
    path = write_animation(circle_run(), tmp_path / "animation.gif", max_frames=12)
    assert path == tmp_path / "animation.gif"
    with Image.open(path) as gif:
        assert isinstance(gif, GifImagePlugin.GifImageFile)
        assert gif.n_frames == 12
        assert gif.info["duration"] == 50  # 20 frames per second
    assert [p.name for p in tmp_path.iterdir()] == ["animation.gif"]


def test_frames_are_capped_whatever_the_run_length() -> None:
    frames = frame_samples(360_000)
    assert len(frames) == MAX_FRAMES
    assert (frames[0], frames[-1]) == (0, 359_999)
    np.testing.assert_array_equal(frame_samples(5), [0, 1, 2, 3, 4])
    assert frame_samples(0).size == 0


def test_robot_outline_points_along_the_heading() -> None:
    outline = robot_outline(1.0, 2.0, math.pi / 2, 0.5)
    assert outline[0] == pytest.approx([1.0, 2.5])  # the nose
    assert outline[:, 1].min() == pytest.approx(2.0 - 0.3)


def test_write_run_animates_on_request(tmp_path: Path) -> None:
    run = circle_run(120)
    written = write_run(
        run,
        tmp_path,
        mission_sha256="0" * 64,
        resolved_mission={},
        mission_file="m.yaml",
        plots=False,
        animate=True,
    )
    assert [p.name for p in written][-2:] == ["summary.json", "animation.gif"]
    with Image.open(tmp_path / "animation.gif") as gif:
        assert isinstance(gif, GifImagePlugin.GifImageFile)
        assert gif.n_frames == 120


def test_the_gif_is_800_pixels_wide_and_as_high_as_its_scene() -> None:
    from wmr_mission.output.animation import HEIGHTS, WIDTH, animation_size

    wide = animation_size((-6.0, 6.0, -3.5, 3.5))
    square = animation_size((-1.0, 1.0, -1.0, 1.0))
    assert wide[0] == square[0] == WIDTH == 8.0  # 800 pixels at 100 dpi
    assert HEIGHTS[0] <= wide[1] < square[1] <= HEIGHTS[1]
    assert animation_size((0.0, 100.0, 0.0, 1.0))[1] == HEIGHTS[0]  # a strip: no thinner
    assert animation_size((0.0, 1.0, 0.0, 100.0))[1] == HEIGHTS[1]  # a mast: no taller


def test_a_written_gif_has_that_size(tmp_path: Path) -> None:
    from wmr_mission.output.animation import animation_size
    from wmr_mission.output.figures import view_box

    run = circle_run()
    path = write_animation(run, tmp_path / "animation.gif", max_frames=3)
    with Image.open(path) as gif:
        assert gif.size == (800, round(animation_size(view_box(run))[1] * 100))
