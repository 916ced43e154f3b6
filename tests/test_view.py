"""`wmr-mission view`: the HTML report of a run and of a campaign.

The pages are opened in headless Chromium (tests/browser.py) where it is
installed: no console error, every plot drawn, hover and brush linked, the
table filtered and sorted, names from the files shown as text.
"""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from browser import CANVAS_INK, Browser, Page, find_chromium, pixels_near
from test_output_synthetic import circle_run
from typer.testing import CliRunner

from wmr_mission.campaign.reader import load_campaign_dir
from wmr_mission.cli import app
from wmr_mission.output.result import RunResult
from wmr_mission.record import Transition
from wmr_mission.review.view import (
    MAX_DISPLAY_SAMPLES,
    build_page,
    run_meta,
    thin_signal,
    view_command,
)
from wmr_mission.spec import catalog

CHROMIUM = find_chromium()
needs_chromium = pytest.mark.skipif(
    CHROMIUM is None,
    reason="Chromium is not installed (apt-get install -y chromium): "
    "the reports are not opened in a browser",
)


@pytest.fixture(scope="module")
def browser() -> Iterator[Browser]:
    """One headless Chromium for the module's pages (each test opens its own tab)."""
    if CHROMIUM is None:
        pytest.skip("Chromium is not installed")
    with Browser() as chromium:
        yield chromium


# matplotlib's tab10, the colours of circle_run's three phases.
TAB10 = ((31, 119, 180), (255, 127, 14), (44, 160, 44))
HOSTILE = "<script>alert(1)</script>"


def _rgb(hex_color: str) -> tuple[int, int, int]:
    return int(hex_color[1:3], 16), int(hex_color[3:5], 16), int(hex_color[5:7], 16)


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The synthetic circle run (every region type), with measurements every 5th sample."""
    result = circle_run()
    measured = np.arange(result.samples) % 5 == 1
    result = dataclasses.replace(
        result,
        x_meas=np.where(measured, result.x + 0.01, np.nan),
        y_meas=np.where(measured, result.y - 0.01, np.nan),
        theta_meas=np.where(measured, result.theta, np.nan),
    )
    return result.write(tmp_path_factory.mktemp("view") / "circle", plots=False)


def _view(directory: Path, out: Path | None = None) -> Path:
    assert view_command(directory, out) == 0
    return out if out is not None else directory / "report.html"


def _rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as stream:
        return list(csv.DictReader(stream))


def _failed_worst_run(campaign_dir: Path) -> Path:
    summary = json.loads((campaign_dir / "campaign.json").read_text(encoding="utf-8"))
    failed = [w["run"] for w in summary["worst"] if w["outcome"] != "success"]
    assert failed, "the campaign of the tests has a failing run"
    return campaign_dir / "worst" / str(failed[0])


# --- without a browser --------------------------------------------------------


def test_thinning_keeps_each_buckets_extremes_in_order() -> None:
    samples = 360_001
    values = np.sin(np.arange(samples) * 1e-3)
    values[123_457] = 50.0  # a one-sample spike
    values[200_000:200_100] = np.nan
    bounds = np.linspace(0, samples, MAX_DISPLAY_SAMPLES // 2 + 1).astype(np.int64)
    shown = thin_signal(values, bounds)
    assert shown.shape == (MAX_DISPLAY_SAMPLES,)
    assert np.nanmax(shown) == 50.0
    for b in (0, 1000, 2345, MAX_DISPLAY_SAMPLES // 2 - 1):
        bucket = values[bounds[b] : bounds[b + 1]]
        first, second = shown[2 * b], shown[2 * b + 1]
        assert {first, second} == {np.nanmin(bucket), np.nanmax(bucket)}
        # in the order they occur
        assert np.nanargmin(bucket) <= np.nanargmax(bucket) or first == np.nanmax(bucket)
    assert np.array_equal(thin_signal(values[:100], None), values[:100])


def test_a_long_run_is_thinned_and_its_page_stays_small() -> None:
    result = circle_run(360_001)
    meta, series = run_meta(result, {})
    page = build_page("long", meta, series)
    data = json.loads(series)
    assert meta["shown"] == MAX_DISPLAY_SAMPLES == len(data["t"]) == len(data["constraint"])
    assert max(v for v in data["constraint"] if v is not None) == 0.02  # the violation shows
    assert len(page.encode()) < 3_000_000


def test_a_transition_s_reaction_and_why_reach_the_page() -> None:
    """The report's transitions hold what fired and why, as transitions.json does."""
    import dataclasses

    result = circle_run()
    fired = Transition(1.0, "circle", "circle", "timeout", 1.0, None, "retry: 2 (1 of 2)", "late")
    result = dataclasses.replace(result, transitions=[fired, *result.transitions])
    meta, _ = run_meta(result, {})
    assert (meta["transitions"][0]["reaction"], meta["transitions"][0]["why"]) == (
        "retry: 2 (1 of 2)",
        "late",
    )
    assert meta["transitions"][1]["reaction"] is None


def test_text_from_the_files_cannot_leave_its_script_element() -> None:
    meta = {"name": HOSTILE, "other": "</script><!-- & \u2028"}
    page = build_page(HOSTILE, meta)
    assert page.count("<script") == 3  # the two data elements and the report's script
    assert "alert(1)</script>" not in page
    assert "<title>&lt;script&gt;alert(1)&lt;/script&gt;" in page
    embedded = re.search(r'<script type="application/json" id="meta">(.*?)</script>', page)
    assert embedded is not None
    assert json.loads(embedded.group(1)) == meta


def test_the_page_fetches_nothing(run_dir: Path, campaign_dir: Path, tmp_path: Path) -> None:
    for directory in (run_dir, campaign_dir):
        page = _view(directory, tmp_path / f"{directory.name}.html").read_text(encoding="utf-8")
        assert not re.search(r"\b(https?|ftp|wss?):", page)
        assert not re.search(r"""(src|href)=["'](?!data:)""", page)
        assert "default-src 'none'" in page


def test_view_writes_the_default_report_and_prints_its_path(run_dir: Path) -> None:
    result = CliRunner().invoke(app, ["view", str(run_dir)])
    assert result.exit_code == 0, result.output
    assert result.output.strip() == str(run_dir / "report.html")
    assert (run_dir / "report.html").stat().st_size > 10_000


def test_bad_directories_get_one_line(tmp_path: Path, run_dir: Path, capsys: Any) -> None:
    assert view_command(tmp_path) == 2
    assert capsys.readouterr().err == (
        f"{tmp_path}: neither a run directory (no trajectory.csv) "
        "nor a campaign directory (no runs.csv, campaign.json) "
        "nor a falsification directory (no evaluations.csv, falsify.json)\n"
    )
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    for name in ("manifest.json", "summary.json", "transitions.json"):
        (damaged / name).write_bytes((run_dir / name).read_bytes())
    lines = (run_dir / "trajectory.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    lines[7] = lines[7].replace(",", ",x", 1)
    (damaged / "trajectory.csv").write_text("".join(lines), encoding="utf-8")
    assert view_command(damaged) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"{damaged}: trajectory.csv:8: x is not a number")
    assert err.count("\n") == 1
    assert view_command(run_dir, tmp_path / "missing" / "report.html") == 2
    assert capsys.readouterr().err.startswith(f"{tmp_path / 'missing' / 'report.html'}: cannot")


def test_a_damaged_runs_csv_gets_one_line(campaign_dir: Path, tmp_path: Path, capsys: Any) -> None:
    copy = tmp_path / "campaign"
    copy.mkdir()
    for name in ("campaign.json", "manifest.json"):
        (copy / name).write_bytes((campaign_dir / name).read_bytes())
    lines = (campaign_dir / "runs.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    (copy / "runs.csv").write_text("".join([*lines[:3], "3,4\n"]), encoding="utf-8")
    assert view_command(copy) == 1
    header = lines[0].count(",") + 1
    assert capsys.readouterr().err == (f"{copy}: runs.csv:4: expected {header} fields, found 2\n")
    # a run whose seed is not the plan's
    row = lines[2].split(",")
    row[1] = str(int(row[1]) + 1)
    (copy / "runs.csv").write_text(lines[0] + ",".join(row), encoding="utf-8")
    assert view_command(copy) == 1
    assert "runs.csv:2: run 1's seed and values are not those" in capsys.readouterr().err
    # cut at a line's end: every row whole, but fewer than campaign.json's runs
    runs = json.loads((campaign_dir / "campaign.json").read_text())["runs"]
    (copy / "runs.csv").write_text("".join(lines[:5]), encoding="utf-8")
    assert view_command(copy) == 1
    assert capsys.readouterr().err == (
        f"{copy}: runs.csv holds 4 runs, but campaign.json says {runs} (cut short or edited)\n"
    )


# --- in the browser -------------------------------------------------------------


def _rect(page: Page, selector: str) -> dict[str, float]:
    rect: dict[str, float] = page.evaluate(
        f"(() => {{ const e = document.querySelector({json.dumps(selector)});"
        " e.scrollIntoView({block: 'center'}); const r = e.getBoundingClientRect();"
        " return {x: r.x, y: r.y, width: r.width, height: r.height}; })()"
    )
    return rect


def _readout(page: Page) -> dict[str, list[str]]:
    rows: list[list[str]] = page.evaluate(
        "[...document.querySelectorAll('#readout tr')]"
        ".map(r => [...r.cells].map(c => c.textContent))"
    )
    return {row[0]: row[1:] for row in rows if row and row[0]}


def _ink_in_column(page: Page, selector: str, x: int) -> int:
    count: int = page.evaluate(
        f"""(() => {{ const c = document.querySelector({json.dumps(selector)});
        const d = c.getContext('2d').getImageData({x}, 0, 1, c.height).data; let n = 0;
        for (let i = 3; i < d.length; i += 4) if (d[i]) n++; return n; }})()"""
    )
    return count


@needs_chromium
def test_run_report_draws_every_plot_without_a_console_error(
    browser: Browser, run_dir: Path
) -> None:
    report = _view(run_dir)
    meta = json.loads(
        re.search(r'id="meta">(.*?)</script>', report.read_text(encoding="utf-8")).group(1)  # type: ignore[union-attr]
    )
    with browser.open(report) as page:
        assert page.problems() == []
        assert page.evaluate("document.body.dataset.rendered") == "1"
        ink = page.evaluate(CANVAS_INK)
        assert set(ink) == {"xy", *(plot["id"] for plot in meta["plots"])}
        assert {"x", "y", "theta", "v", "omega", "constraint", "reference_distance"} <= set(ink)
        assert all(count > 2000 for count in ink.values()), ink
        # the path in the colours of the phases it ends in (the orbit draws over
        # the approach's arc), and every phase in the band over the time plots
        for rgb in TAB10[1:]:
            assert page.evaluate(pixels_near('canvas[data-plot="xy"]', rgb, 12)) > 100, rgb
        for rgb in TAB10:
            assert page.evaluate(pixels_near('canvas[data-plot="x"]', rgb, 12)) > 200, rgb
        assert page.evaluate(pixels_near('canvas[data-plot="x"]', (31, 78, 156), 12)) > 100
        assert page.evaluate("document.querySelector('h1').textContent") == "circle"
        transitions = json.loads((run_dir / "transitions.json").read_text(encoding="utf-8"))
        tables = page.evaluate(
            "[...document.querySelectorAll('table')]"
            ".map(t => t.tBodies[0] ? t.tBodies[0].rows.length : -1)"
        )
        # readout, verdicts (none: a run written from Python has no expect), phases, transitions
        assert tables == [10, 3, len(transitions)]


@needs_chromium
def test_hover_on_a_time_plot_follows_the_time_on_every_plot(
    browser: Browser, run_dir: Path
) -> None:
    with browser.open(_view(run_dir)) as page:
        box = _rect(page, 'canvas[data-plot="v"]')
        xy_overlay = (
            "document.querySelector('canvas[data-plot=\"xy\"] + canvas.overlay').toDataURL()"
        )
        xy_before = page.evaluate(xy_overlay)
        # t = 12.5 s of 20 s: the plot area runs from x 60 to width - 12
        left, right = box["x"] + 60, box["x"] + box["width"] - 12
        time = 12.5
        x = left + (right - left) * time / 20.0
        page.mouse("mouseMoved", x, box["y"] + box["height"] / 2)
        readout = _readout(page)
        shown_time = float(readout["t [s]"][0])
        assert abs(shown_time - time) <= 20.0 / (right - left)  # within a pixel
        k = round(shown_time / 0.01)
        rows = _rows(run_dir / "trajectory.csv")
        assert readout["phase"] == [rows[k]["phase"]] == ["orbit"]
        assert float(readout["x [m]"][0]) == pytest.approx(float(rows[k]["x"]), rel=1e-5)
        assert float(readout["x [m]"][1]) == pytest.approx(float(rows[k]["x_est"]), rel=1e-5)
        # the cursor is drawn on every time plot at that x, and on the x-y plot
        column = round(x - box["x"])
        for plot in ("x", "theta", "omega", "estimation_error", "constraint"):
            overlay = f'canvas[data-plot="{plot}"] + canvas.overlay'
            assert _ink_in_column(page, overlay, column) > 50, plot
        assert page.evaluate(xy_overlay) != xy_before


@needs_chromium
def test_hover_on_the_path_puts_its_time_on_every_plot(browser: Browser, run_dir: Path) -> None:
    report = _view(run_dir)
    view_box = json.loads(
        re.search(r'id="meta">(.*?)</script>', report.read_text(encoding="utf-8")).group(1)  # type: ignore[union-attr]
    )["view"]
    with browser.open(report) as page:
        box = _rect(page, 'canvas[data-plot="xy"]')
        # the x-y plot's mapping (view.js, xyPlot): equal scales, centred, 44 px margins
        width, height, pad = 620, 500, 44
        x0, x1, y0, y1 = view_box
        scale = min((width - 2 * pad) / (x1 - x0), (height - 2 * pad) / (y1 - y0))
        # t = 10 s: the circle at angle 5 rad, a place the robot passes once
        x, y = 2.0 * math.cos(5.0), 2.0 * math.sin(5.0)
        page.mouse(
            "mouseMoved",
            box["x"] + width / 2 + (x - (x0 + x1) / 2) * scale,
            box["y"] + height / 2 - (y - (y0 + y1) / 2) * scale,
        )
        readout = _readout(page)
        assert float(readout["t [s]"][0]) == pytest.approx(10.0, abs=2.0 / scale)
        assert readout["phase"] == ["orbit"]
        plot = _rect(page, 'canvas[data-plot="omega"]')
        t_column = round(60 + (plot["width"] - 72) * float(readout["t [s]"][0]) / 20.0)
        overlay = 'canvas[data-plot="omega"] + canvas.overlay'
        assert _ink_in_column(page, overlay, t_column) > 50


@needs_chromium
def test_brushing_a_span_zooms_every_time_plot(browser: Browser, run_dir: Path) -> None:
    with browser.open(_view(run_dir)) as page:
        box = _rect(page, 'canvas[data-plot="x"]')
        before = page.evaluate("document.querySelector('canvas[data-plot=\"omega\"]').toDataURL()")
        y = box["y"] + box["height"] / 2
        start, end = box["x"] + 300, box["x"] + 500
        page.mouse("mousePressed", start, y, buttons=1)
        page.mouse("mouseMoved", (start + end) / 2, y, buttons=1)
        page.mouse("mouseMoved", end, y, buttons=1)
        page.mouse("mouseReleased", end, y)
        assert (
            page.evaluate(
                "[...document.querySelectorAll('button')]"
                ".find(b => b.textContent === 'Zoom out').hidden"
            )
            is False
        )
        after = page.evaluate("document.querySelector('canvas[data-plot=\"omega\"]').toDataURL()")
        assert after != before
        # the span is drawn over the x-y path (amber)
        xy_overlay = 'canvas[data-plot="xy"] + canvas.overlay'
        assert page.evaluate(pixels_near(xy_overlay, (255, 196, 0), 60)) > 100
        page.evaluate(
            "document.querySelector('canvas[data-plot=\"x\"] + canvas.overlay')"
            ".dispatchEvent(new MouseEvent('dblclick', {bubbles: true}))"
        )
        assert (
            page.evaluate("document.querySelector('canvas[data-plot=\"omega\"]').toDataURL()")
            == before
        )
        assert page.problems() == []


@needs_chromium
def test_a_failing_run_shows_its_verdicts_and_opens_at_its_end(
    browser: Browser, campaign_dir: Path
) -> None:
    run = _failed_worst_run(campaign_dir)
    summary = json.loads((run / "summary.json").read_text(encoding="utf-8"))
    with browser.open(_view(run)) as page:
        assert page.problems() == []
        verdicts = page.evaluate(
            "[...document.querySelectorAll('table')][1].tBodies[0].rows.length"
        )
        assert verdicts == len(summary["expectations"])
        failing = page.evaluate(
            "[...document.querySelectorAll('tr.bad')]"
            ".map(r => r.cells[0].textContent + ' ' + r.cells[5].textContent)"
        )
        unmet = [f"{e['metric']} NOT MET" for e in summary["expectations"] if not e["met"]]
        assert unmet
        assert failing == unmet
        # each check's margin beside it: below 0 where it failed
        margins = page.evaluate(
            "[...document.querySelectorAll('tr.bad')].map(r => r.cells[4].textContent)"
        )
        assert all(m.startswith("-") for m in margins), margins
        assert page.evaluate(
            "[...document.querySelectorAll('p.sub')].some(p => p.textContent.startsWith('margin '))"
        )
        assert float(_readout(page)["t [s]"][0]) == pytest.approx(summary["duration"])
        assert page.evaluate("document.querySelector('.badge').textContent") == summary["outcome"]
        # the phases' table: the verdict's numbers under summary.json's names
        phases = page.evaluate(
            "(() => { const t = [...document.querySelectorAll('table')][2];"
            " const names = [...t.tHead.rows[0].cells].map(c => c.textContent);"
            " return [...t.tBodies[0].rows].map(r => Object.fromEntries("
            "[...r.cells].map((c, i) => [names[i], c.textContent]))); })()"
        )
        for shown, phase in zip(phases, summary["phases"], strict=True):
            for name in (
                "cross_track_error_max",
                "along_track_lag_max",
                "tracking_error_rms",
                "speed_at_limit",
            ):
                metric = catalog.CATALOG[name]
                value = (phase.get(metric.where[0]) or {}).get(metric.where[1])
                cell = shown[f"{name} [{metric.unit}]" if metric.unit else name]
                no_value = "\N{EN DASH}"  # what the page shows for null
                assert (
                    (cell == no_value)
                    if value is None
                    else float(cell) == pytest.approx(value, 1e-3)
                )


def _hostile_run(tmp_path: Path) -> Path:
    result = circle_run()
    names = (HOSTILE, "orbit", "<img src=x onerror=alert(2)>")
    phases = [dataclasses.replace(p, name=n) for p, n in zip(result.phases, names, strict=True)]
    transitions = [
        Transition(c.time, names[i], names[i + 1] if i + 1 < 3 else None, c.condition, c.value)
        for i, c in enumerate(result.transitions)
    ]
    hostile: RunResult = dataclasses.replace(
        result, phases=phases, transitions=transitions, message=f"ended in {HOSTILE}"
    )
    return hostile.write(tmp_path / "hostile", plots=False)


@needs_chromium
def test_names_from_the_files_are_shown_as_text(browser: Browser, tmp_path: Path) -> None:
    run = _hostile_run(tmp_path)
    report = _view(run)
    assert HOSTILE not in report.read_text(encoding="utf-8")
    with browser.open(report) as page:
        assert page.problems() == []  # no alert dialog, no error
        assert page.evaluate("document.scripts.length") == 3
        assert page.evaluate("document.images.length") == 0
        text = page.evaluate("document.body.innerText")
        assert HOSTILE in text
        assert "<img src=x onerror=alert(2)>" in text
        assert f"ended in {HOSTILE}" in text
        assert page.evaluate("document.body.dataset.rendered") == "1"


# --- a campaign -----------------------------------------------------------------


def _table(page: Page) -> list[list[str]]:
    rows: list[list[str]] = page.evaluate(
        "[...document.querySelectorAll('#runs tbody tr.run')]"
        ".map(r => [...r.cells].map(c => c.textContent))"
    )
    return rows


def _replays(page: Page) -> list[str]:
    texts: list[str] = page.evaluate(
        "[...document.querySelectorAll('#runs tbody tr.replay code')].map(c => c.textContent)"
    )
    return texts


@needs_chromium
def test_campaign_report_lists_every_run_with_its_replay(
    browser: Browser, campaign_dir: Path
) -> None:
    summary = json.loads((campaign_dir / "campaign.json").read_text(encoding="utf-8"))
    rows = _rows(campaign_dir / "runs.csv")
    with browser.open(_view(campaign_dir)) as page:
        assert page.problems() == []
        assert page.evaluate("document.body.dataset.rendered") == "1"
        shown = _table(page)
        assert [r[0].split(" ")[0] for r in shown] == [r["run"] for r in rows]
        assert [r[2] for r in shown] == [r["outcome"] for r in rows]
        replays = dict(zip((r["run"] for r in rows), _replays(page), strict=True))
        for worst in summary["worst"]:
            assert replays[str(worst["run"])] == worst["replay"]
        sub = page.evaluate("document.querySelector('.sub').textContent")
        lo, hi = summary["success_interval"]
        assert f"{summary['succeeded']} of {summary['runs']} runs succeeded" in sub
        assert f"{100 * summary['success_rate']:.2f} %" in sub
        assert f"{100 * lo:.2f} % .. {100 * hi:.2f} %" in sub
        figures = sorted(p.name for p in campaign_dir.glob("*.png"))
        assert sorted(page.evaluate("[...document.images].map(i => i.alt)")) == figures
        widths = page.evaluate(
            "Promise.all([...document.images].map(i => i.decode().then(() => i.naturalWidth)))"
        )
        assert all(w > 300 for w in widths), widths


@needs_chromium
def test_campaign_table_filters_and_sorts(browser: Browser, campaign_dir: Path) -> None:
    rows = _rows(campaign_dir / "runs.csv")
    with browser.open(_view(campaign_dir)) as page:
        page.evaluate(
            "(() => { const s = document.querySelector('select'); s.value = 'expect-failed';"
            " s.dispatchEvent(new Event('change')); })()"
        )
        failed = [r["run"] for r in rows if r["outcome"] == "expect-failed"]
        assert failed
        assert [r[0].split(" ")[0] for r in _table(page)] == failed
        page.evaluate(
            "(() => { const s = document.querySelector('select'); s.value = '';"
            " s.dispatchEvent(new Event('change'));"
            " const q = document.querySelector('input[type=search]'); q.value = 'EKF';"
            " q.dispatchEvent(new Event('input')); })()"
        )
        ekf = [r["run"] for r in rows if r["estimator.type"] == "ekf"]
        assert [r[0].split(" ")[0] for r in _table(page)] == ekf
        page.evaluate(
            "(() => { const q = document.querySelector('input[type=search]'); q.value = '';"
            " q.dispatchEvent(new Event('input'));"
            " const th = [...document.querySelectorAll('#runs th')]"
            ".find(h => h.textContent.startsWith('final_position_error'));"
            " th.click(); th.click(); })()"
        )
        by_error = sorted(rows, key=lambda r: -float(r["final_position_error"]))
        assert [r[0].split(" ")[0] for r in _table(page)] == [r["run"] for r in by_error]
        assert page.problems() == []


@needs_chromium
def test_campaign_text_is_shown_as_text(
    browser: Browser, campaign_dir: Path, tmp_path: Path
) -> None:
    copy = tmp_path / "campaign"
    copy.mkdir()
    for name in ("campaign.json", "manifest.json"):
        (copy / name).write_bytes((campaign_dir / name).read_bytes())
    lines = (campaign_dir / "runs.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    lines[1] = lines[1].rstrip("\n") + '"<img src=x onerror=alert(3)>"\n'
    (copy / "runs.csv").write_text("".join(lines), encoding="utf-8")
    with browser.open(_view(copy)) as page:
        assert page.problems() == []
        assert page.evaluate("document.images.length") == 0
        assert "<img src=x onerror=alert(3)>" in page.evaluate("document.body.innerText")


def _timeouts_campaign(directory: Path) -> Path:
    """Two runs of short.yaml that time out (0.2 s) and two that park."""
    mission = Path(__file__).parent / "data" / "campaigns" / "short.yaml"
    path = directory / "timeouts.yaml"
    path.write_text(
        f"version: 1\nname: timeouts\nmission: {mission}\nruns: 2\nseed: 3\n"
        "vary:\n  phases[0].timeout: {grid: [0.2, 20]}\n",
        encoding="utf-8",
    )
    return path


@needs_chromium
def test_campaign_margins_say_the_runs_they_are_over(browser: Browser, tmp_path: Path) -> None:
    """Two of four runs time out (margin -inf): the least margin of the others
    is above 0, so the line says it is of the runs with a number and that the
    two missed without one, never a least margin above the runs that missed;
    the table shows their margin as -inf (an empty cell in runs.csv) and sorts
    it below the others, not after them as an empty cell."""
    from wmr_mission import run_campaign

    path = _timeouts_campaign(tmp_path)
    out = tmp_path / "campaign"
    summary = run_campaign(path, out=out, workers=1).summary
    margin = summary["margin"]
    assert summary["outcomes"] == {"success": 2, "timeout": 2}
    assert (margin["finite"], margin["below_zero"], margin["minus_inf"]) == (2, 2, 2)
    assert margin["min"] > 0
    with browser.open(_view(out)) as page:
        assert page.problems() == []
        lines = page.evaluate("[...document.querySelectorAll('p.sub')].map(p => p.textContent)")
        (line,) = [text for text in lines if text.startswith("margins")]
        assert line.startswith("margins of the 2 runs with a number: least ")
        assert line.endswith(
            "; 2 runs below 0, 2 of them without a number"
            " (-inf: an outcome such as a timeout, or a check without a value)"
        )
        page.evaluate(
            "[...document.querySelectorAll('#runs th')]"
            ".find(h => h.textContent === 'margin').click()"
        )
        columns = page.evaluate(
            "[...document.querySelectorAll('#runs th')].map(h => h.textContent)"
        )
        at = columns.index("margin ▲")
        shown = [(row[2], row[at]) for row in _table(page)]
        assert shown[:2] == [("timeout", "-inf"), ("timeout", "-inf")]
        assert [outcome for outcome, _ in shown[2:]] == ["success", "success"]
        assert all(float(margin) > 0 for _, margin in shown[2:])


@needs_chromium
def test_falsification_report_shows_a_timeout_s_margin_as_minus_inf(
    browser: Browser, tmp_path: Path
) -> None:
    """falsify.json writes a timeout's margin as the text "-inf": the lowest
    runs' table says -inf, as the printed line does, not a dash."""
    from wmr_mission import falsify_campaign

    out = tmp_path / "falsify"
    falsify_campaign(_timeouts_campaign(tmp_path), budget=4, method="random", seed=1, out=out)
    record = json.loads((out / "falsify.json").read_text(encoding="utf-8"))
    assert record["best"][0]["objective"] == "-inf"
    with browser.open(_view(out)) as page:
        assert page.problems() == []
        lowest = page.evaluate(
            "[...document.querySelector('table').querySelectorAll('tbody tr')]"
            ".map(tr => tr.children[2].textContent)"
        )
        assert lowest[0] == "-inf"


@needs_chromium
def test_a_one_hour_run_loads(browser: Browser, tmp_path: Path) -> None:
    """360 001 samples: the page is thinned to MAX_DISPLAY_SAMPLES points per signal."""
    result = circle_run(360_001)
    meta, series = run_meta(result, {})
    report = tmp_path / "hour.html"
    report.write_text(build_page("hour", meta, series), encoding="utf-8")
    with browser.open(report) as page:
        assert page.problems() == []
        assert page.evaluate("document.body.dataset.rendered") == "1"
        ink = page.evaluate(CANVAS_INK)
        assert all(count > 2000 for count in ink.values()), ink
        note = page.evaluate("document.querySelector('.note').textContent")
        assert f"show {MAX_DISPLAY_SAMPLES} of 360001 samples" in note


def test_the_pages_phases_are_the_runs_in_their_colours() -> None:
    meta, _ = run_meta(circle_run(), {})
    assert [p["name"] for p in meta["phases"]] == ["approach", "orbit", "park"]
    assert [_rgb(p["color"]) for p in meta["phases"]] == list(TAB10)
    assert [p["target"] for p in meta["phases"]] == [None, None, [0.0, 0.0, 0.0]]


def test_a_large_campaigns_table_keeps_every_failure(
    campaign_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from wmr_mission.review import view

    rows = _rows(campaign_dir / "runs.csv")
    failed = [r["run"] for r in rows if r["outcome"] != "success"]
    monkeypatch.setattr(view, "MAX_TABLE_ROWS", len(failed) + 2)
    meta = view.campaign_meta(campaign_dir, tmp_path / "report.html")
    kept = [row[0] for row in meta["rows"]]
    successes = [r["run"] for r in rows if r["outcome"] == "success"][:2]
    assert kept == sorted(failed + successes, key=int)
    assert meta["total_rows"] == len(rows) > len(kept)
    campaign = load_campaign_dir(campaign_dir)
    index = {row[0]: i for i, row in enumerate(campaign.rows)}
    assert meta["replays"] == [campaign.replay(index[run]) for run in kept]
