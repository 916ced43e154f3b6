"""``animation.gif``: the robot's pose and trail over its regions (``run --animate``)."""

from __future__ import annotations

import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.output.figures import (
    draw_regions,
    finite,
    names_as_typed,
    region_sides,
    thin,
    view_box,
)
from wmr_mission.output.files import atomic_path

if TYPE_CHECKING:
    from wmr_mission.record import RunRecord

MAX_FRAMES = 200
FPS = 20
_DPI = 100
# 800 pixels wide; the height follows the scene [in].
WIDTH = 8.0
HEIGHTS = (3.5, 8.0)
_AXES_SHARE = 0.7  # of the width: the axes, less the legend's room at the right
_TITLE_AND_LABELS = 1.1  # [in] above and below the axes
# Points of the drawn path: plenty at the animation's size, and cheap to redraw each frame.
TRAIL_POINTS = 4000
# Length of the robot's arrow, as a fraction of the scene's extent.
GLYPH_SIZE = 0.04


def frame_samples(samples: int, max_frames: int = MAX_FRAMES) -> np.ndarray:
    """Sample shown by each frame: evenly spaced, first and last included."""
    if samples <= 0:
        return np.zeros(0, dtype=np.int64)
    count = min(samples, max_frames)
    return np.unique(np.round(np.linspace(0, samples - 1, count)).astype(np.int64))


def glyph_size(view: tuple[float, float, float, float]) -> float:
    """Length of the robot's arrow [m]: a fixed share of the scene, whatever its scale."""
    return GLYPH_SIZE * max(view[1] - view[0], view[3] - view[2])


def animation_size(view: tuple[float, float, float, float]) -> tuple[float, float]:
    """The GIF's size [in], WIDTH wide and as high as the scene's shape needs
    beside its legend and under its title (within HEIGHTS): no blank bands."""
    aspect = (view[3] - view[2]) / max(view[1] - view[0], 1e-12)
    height = WIDTH * _AXES_SHARE * aspect + _TITLE_AND_LABELS
    return WIDTH, min(max(height, HEIGHTS[0]), HEIGHTS[1])


def robot_outline(x: float, y: float, theta: float, size: float) -> FloatArray:
    """A triangle pointing along the heading: the robot's pose arrow."""
    body = np.array([[1.0, 0.0], [-0.6, 0.5], [-0.35, 0.0], [-0.6, -0.5]]) * size
    c, s = math.cos(theta), math.sin(theta)
    rotated: FloatArray = body @ np.array([[c, s], [-s, c]]) + np.array([x, y])
    return rotated


def write_animation(result: RunRecord, path: Path, *, max_frames: int = MAX_FRAMES) -> Path:
    """Write a GIF of at most ``max_frames`` frames at ``FPS``, whatever the run length.

    The still parts (regions, the whole path in grey, axes) are drawn once; each
    frame redraws only the trail and the two pose arrows over them, and writes
    its title with PIL (matplotlib would lay out and render its glyphs anew for
    every frame: most of the time). Every frame takes the palette of the last
    one, which holds every colour drawn.
    """
    from matplotlib import patches
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from PIL import Image, ImageDraw

    samples = frame_samples(result.samples, max_frames)
    if samples.size == 0:
        raise ValueError("a run without samples cannot be animated")
    # Its own Agg canvas: no pyplot, so a notebook's backend is never touched.
    view = view_box(result)
    fig = Figure(figsize=animation_size(view), dpi=_DPI)
    canvas: Any = FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    draw_regions(ax, result.regions, view, region_sides(result))
    path_points = thin(0, result.samples, TRAIL_POINTS)
    ax.plot(
        finite(result.x[path_points]), finite(result.y[path_points]), color="0.85", linewidth=1.0
    )
    (trail,) = ax.plot([], [], color="tab:blue", linewidth=1.6, animated=True)
    size = glyph_size(view)
    robot = patches.Polygon(
        np.zeros((4, 2)),
        closed=True,
        facecolor="tab:blue",
        edgecolor="black",
        label="true pose",
        animated=True,
    )
    estimate = patches.Polygon(
        np.zeros((4, 2)),
        closed=True,
        facecolor="none",
        edgecolor="tab:red",
        linewidth=1.5,
        label="estimate",
        animated=True,
    )
    ax.add_patch(robot)
    ax.add_patch(estimate)
    ax.set_xlim(view[0], view[1])
    ax.set_ylim(view[2], view[3])
    ax.set_aspect("equal", adjustable="box")
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    # Beside the axes, not over the path.
    fig.subplots_adjust(right=0.8)
    ax.legend(
        handles=[robot, estimate],
        loc="upper left",
        bbox_to_anchor=(1.02, 1.0),
        fontsize=8,
        frameon=False,
    )
    names_as_typed(fig)
    canvas.draw()
    background = canvas.copy_from_bbox(fig.bbox)
    title_font, title_at = _title_style(fig, ax)
    # Simulated seconds per second of the GIF: how much faster than real time it plays.
    shown_seconds = len(samples) / FPS
    duration = float(result.t[-1] - result.t[0]) if result.samples > 1 else 0.0
    pace = f"{duration / shown_seconds:.3g}x real time" if shown_seconds > 0 else ""

    def frame(k: int) -> Any:
        canvas.restore_region(background)
        shown = path_points[path_points <= k]
        trail.set_data(finite(result.x[shown]), finite(result.y[shown]))
        robot.set_xy(robot_outline(*_pose(result.x, result.y, result.theta, k), size))
        estimate.set_xy(
            robot_outline(*_pose(result.x_est, result.y_est, result.theta_est, k), size)
        )
        for artist in (trail, estimate, robot):
            ax.draw_artist(artist)
        width, height = canvas.get_width_height()
        image = Image.frombuffer("RGBA", (width, height), canvas.buffer_rgba(), "raw", "RGBA", 0, 1)
        image = image.convert("RGB")
        phase = result.phases[int(result.phase[k])].name
        title = f"{result.mission_name}   t = {result.t[k]:.2f} s   phase: {phase}   {pace}"
        ImageDraw.Draw(image).text(title_at, title, font=title_font, fill="black", anchor="md")
        return image

    # The fast octree palette of the last frame: median cut would take most of the time.
    palette = frame(int(samples[-1])).quantize(method=Image.Quantize.FASTOCTREE)
    frames = [frame(int(k)).quantize(palette=palette, dither=Image.Dither.NONE) for k in samples]
    with atomic_path(path) as tmp:
        frames[0].save(
            tmp,
            format="GIF",
            save_all=True,
            append_images=frames[1:],
            duration=round(1000 / FPS),
            loop=0,
            # Frames are cropped to what changed; filling the unchanged pixels
            # of that box with transparency would cost a third of the time.
            optimize=False,
        )
    return path


def _title_style(fig: Any, ax: Any) -> tuple[Any, tuple[float, float]]:
    """The font of an axes title (in pixels) and where its text's bottom centre
    goes in the image, as matplotlib places it."""
    from matplotlib import font_manager, rcParams
    from matplotlib.font_manager import FontProperties
    from PIL import ImageFont

    properties = FontProperties(size=rcParams["axes.titlesize"])
    font = ImageFont.truetype(
        font_manager.findfont(properties), round(properties.get_size_in_points() * _DPI / 72)
    )
    pad = float(rcParams["axes.titlepad"]) * _DPI / 72
    box = ax.get_window_extent()
    height = fig.bbox.height
    return font, ((box.x0 + box.x1) / 2, height - box.y1 - pad)


def _pose(x: FloatArray, y: FloatArray, theta: FloatArray, k: int) -> tuple[float, float, float]:
    # A non-finite pose (divergence) is drawn at the origin rather than breaking the file.
    pose = (float(x[k]), float(y[k]), float(theta[k]))
    return pose if all(math.isfinite(v) for v in pose) else (0.0, 0.0, 0.0)
