"""Figures for a paper: TrueType fonts in PDF (no Type 3, which publishers
refuse), text as text in SVG, and sizes for one and two columns."""

from __future__ import annotations

import shutil
import subprocess
from dataclasses import replace
from pathlib import Path

import pytest
from failing import ungated_disturbed
from PIL import Image

from wmr_mission.output.figures import DPI, FIGURE_NAMES, STYLES, draw_all
from wmr_mission.output.result import RunResult
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
PDFFONTS = shutil.which("pdffonts")
needs_pdffonts = pytest.mark.skipif(
    PDFFONTS is None, reason="poppler-utils is not installed (apt-get install -y poppler-utils)"
)


@pytest.fixture(scope="module")
def keep_out() -> RunResult:
    return run_mission(load_mission(MISSIONS / "keep-out.yaml"))


@needs_pdffonts
def test_no_pdf_has_a_type_3_font(keep_out: RunResult, tmp_path: Path) -> None:
    paths = draw_all(keep_out, tmp_path, ("pdf",), style="one-column")
    assert [p.name for p in paths] == [f"{name}.pdf" for name in FIGURE_NAMES]
    for path in paths:
        fonts = subprocess.run(
            [str(PDFFONTS), str(path)], capture_output=True, text=True, check=True
        ).stdout
        assert "TrueType" in fonts, path.name  # the premise: text is embedded
        assert "Type 3" not in fonts, path.name


def test_svg_keeps_text_as_text(tmp_path: Path) -> None:
    disturbed = run_mission(ungated_disturbed())
    assert disturbed.outcome.value == "expect-failed"  # the premise
    (path, *_) = draw_all(disturbed, tmp_path, ("svg",))
    svg = path.read_text()
    assert "<text" in svg
    assert "turn_rate_jump_max" in svg  # the failure, searchable


def _text_only(path: Path) -> bool:
    """keep-out's estimation_error.png: one sentence (its estimate is exact)."""
    return path.stem == "estimation_error"


@pytest.mark.parametrize("style", ["one-column", "two-column"])
def test_a_column_style_fits_its_column(keep_out: RunResult, tmp_path: Path, style: str) -> None:
    width = STYLES[style].width
    assert width is not None
    for path in draw_all(keep_out, tmp_path, ("png",), style=style):
        if path.stem == "verdicts":
            continue  # drawn for a screen whatever the style
        with Image.open(path) as image:
            drawn = image.size[0] / DPI
        # within the column; one with axes fills it (a sentence alone is as wide as it is)
        assert drawn <= width + 0.02, path.name
        if not _text_only(path):
            assert drawn == pytest.approx(width, abs=0.02), path.name


def test_a_long_label_keeps_the_one_column_figure_a_column_wide(
    keep_out: RunResult, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from wmr_mission.output import figures

    # wider than half an em a character: the legend below is measured, not guessed
    (first, *others) = keep_out.phases
    wide = replace(keep_out, phases=[replace(first, name="M" * 32), *others])
    monkeypatch.setattr(figures, "FIGURE_NAMES", ("xy",))
    (path,) = draw_all(wide, tmp_path, ("png",), style="one-column")
    with Image.open(path) as image:
        assert image.size[0] / DPI == pytest.approx(STYLES["one-column"].width, abs=0.02)


def _made(directory: Path) -> Path:
    directory.mkdir()
    return directory


def test_dpi_sets_the_pixels_of_a_png_and_keeps_its_size(
    keep_out: RunResult, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from wmr_mission.cli import DPI_RANGE as CLI_DPI_RANGE
    from wmr_mission.output import figures
    from wmr_mission.output.figures import DPI_RANGE

    assert CLI_DPI_RANGE == DPI_RANGE
    # draw_all as it is, drawing the one figure compared (six PNGs, not thirty)
    monkeypatch.setattr(figures, "FIGURE_NAMES", ("xy",))
    for style in STYLES:
        (default,) = draw_all(keep_out, _made(tmp_path / style), ("png",), style)
        (sharp,) = draw_all(keep_out, _made(tmp_path / f"{style}-300"), ("png",), style, 300)
        assert sharp.stem == default.stem == "xy"
        with Image.open(default) as low, Image.open(sharp) as high:
            # the same inches, to the 1 % the layout moves by when text is measured finer
            assert high.size[0] / 300 == pytest.approx(low.size[0] / DPI, rel=0.015), style
            assert high.size[1] / 300 == pytest.approx(low.size[1] / DPI, rel=0.015), style
    with pytest.raises(ValueError, match="dpi 10: expected 50 to 600"):
        draw_all(keep_out, _made(tmp_path / "refused"), ("png",), dpi=10)
