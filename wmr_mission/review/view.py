"""``wmr-mission view RUN_DIR|CAMPAIGN_DIR|FALSIFY_DIR``: one self-contained HTML report.

The page needs no network: its script (``view.js``), its style (``view.css``)
and its data are inline, and a campaign's figures are PNG data URIs. Every
text taken from the files (mission, phase and region names, messages,
reasons, values) travels as JSON inside ``<script type="application/json">``
with ``<``, ``>`` and ``&`` escaped, and the script puts it into the page as
text (``textContent``), never as markup.

A run's time plots show at most ``MAX_DISPLAY_SAMPLES`` points per signal.
A longer run is cut into ``MAX_DISPLAY_SAMPLES / 2`` buckets of equal sample
counts; each bucket gives two points at its first and last sample times, and
each signal takes its bucket's smallest and largest value there, in the order
they occur, so a spike of one sample still shows. The x-y plot takes the true
samples at those times. The page says when it is thinned; trajectory.csv (or
``export``) has every sample.
"""

from __future__ import annotations

import base64
import html
import json
import math
import os
import sys
from importlib import resources
from pathlib import Path
from typing import Any, Final

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.output.files import write_bytes_atomic
from wmr_mission.output.reader import RunDirError
from wmr_mission.output.result import RunResult
from wmr_mission.output.rundir import SUMMARY_FILE, TRAJECTORY_FILE
from wmr_mission.spec import catalog

__all__ = ["MAX_DISPLAY_SAMPLES", "REPORT_FILE", "build_page", "view_command"]

REPORT_FILE: Final = "report.html"
# Points per signal of a run's plots: a few per pixel of a wide screen.
MAX_DISPLAY_SAMPLES: Final = 8000
# Rows of a campaign's table: every run that did not succeed, then successes
# in run order up to this many (runs.csv has them all).
MAX_TABLE_ROWS: Final = 10_000
# Significant digits of plotted values: far below a pixel; readouts show 6.
_DIGITS: Final = 7
_TIME_DIGITS: Final = 10
_POSE_KEYS: Final = ("x", "y", "x_est", "y_est", "x_ref", "y_ref", "theta", "theta_est")


# --- the page ---------------------------------------------------------------


def _asset(name: str) -> str:
    return (resources.files("wmr_mission.review") / name).read_text(encoding="utf-8")


def _script_json(text: str) -> str:
    """JSON text safe inside ``<script>``: no ``</script>``, no ``<!--``, no entity."""
    return (
        text.replace("&", "\\u0026")
        .replace("<", "\\u003c")
        .replace(">", "\\u003e")
        .replace("\u2028", "\\u2028")
        .replace("\u2029", "\\u2029")
    )


# What every page build_page writes holds before its data: how an earlier
# report is told from another HTML file (`view --out` writes over the first only).
_REPORT_MAIN = '<main id="report"></main>'


def is_report(path: Path) -> bool:
    """Whether ``path`` is a page `view` wrote: its mark in its first 64 KB (the
    page's style and head before it)."""
    try:
        with path.open("rb") as page:
            return _REPORT_MAIN.encode() in page.read(65536)
    except OSError:
        return False


def build_page(title: str, meta: dict[str, Any], series_json: str = "{}") -> str:
    """The HTML page: ``meta`` (any JSON) and ``series_json`` (numbers only) inline."""
    meta_json = _script_json(json.dumps(meta, ensure_ascii=False, allow_nan=False))
    return (
        "<!DOCTYPE html>\n"
        '<html lang="en">\n<head>\n<meta charset="utf-8">\n'
        '<meta name="viewport" content="width=device-width, initial-scale=1">\n'
        # No request leaves the page: not even for a favicon.
        '<meta http-equiv="Content-Security-Policy" content="default-src \'none\'; '
        "img-src data:; style-src 'unsafe-inline'; script-src 'unsafe-inline'\">\n"
        '<link rel="icon" href="data:,">\n'
        f"<title>{html.escape(title)}</title>\n"
        f"<style>\n{_asset('view.css')}</style>\n</head>\n<body>\n"
        f"{_REPORT_MAIN}\n"
        f'<script type="application/json" id="meta">{meta_json}</script>\n'
        f'<script type="application/json" id="series">{_script_json(series_json)}</script>\n'
        f"<script>\n{_asset('view.js')}</script>\n</body>\n</html>\n"
    )


def _numbers(values: FloatArray, digits: int = _DIGITS) -> str:
    """A JSON array of numbers; NaN and infinities as null (a gap in a line)."""
    return (
        "["
        + ",".join(f"{v:.{digits}g}" if math.isfinite(v) else "null" for v in values.tolist())
        + "]"
    )


# --- a run ------------------------------------------------------------------


def _buckets(samples: int) -> np.ndarray | None:
    """Bucket boundaries (``count + 1`` sample indices), or None when every sample shows."""
    if samples <= MAX_DISPLAY_SAMPLES:
        return None
    return np.linspace(0, samples, MAX_DISPLAY_SAMPLES // 2 + 1).astype(np.int64)


def _display_indices(samples: int, bounds: np.ndarray | None) -> np.ndarray:
    if bounds is None:
        return np.arange(samples, dtype=np.int64)
    return np.column_stack([bounds[:-1], bounds[1:] - 1]).ravel()


def thin_signal(values: FloatArray, bounds: np.ndarray | None) -> FloatArray:
    """Two values per bucket: its smallest and largest (NaN ignored), in the
    order they occur; every value when ``bounds`` is None."""
    if bounds is None:
        return np.asarray(values, dtype=np.float64)
    v = np.asarray(values, dtype=np.float64)
    starts = bounds[:-1]
    counts = np.diff(bounds)
    bucket = np.repeat(np.arange(starts.size), counts)
    index = np.arange(v.size)
    with np.errstate(invalid="ignore"):
        low = np.fmin.reduceat(v, starts)
        high = np.fmax.reduceat(v, starts)
    first_low = np.minimum.reduceat(np.where(v == low[bucket], index, v.size), starts)
    first_high = np.minimum.reduceat(np.where(v == high[bucket], index, v.size), starts)
    low_first = first_low <= first_high
    return np.column_stack([np.where(low_first, low, high), np.where(low_first, high, low)]).ravel()


def _signals(result: RunResult) -> dict[str, FloatArray]:
    """The run's signals over time, computed in float64 before any thinning."""
    from wmr_mission.verdicts.metrics import estimation_errors

    errors = estimation_errors(result)
    with np.errstate(invalid="ignore"):
        reference_distance = np.hypot(result.x - result.x_ref, result.y - result.y_ref)
    return {
        "x": result.x,
        "y": result.y,
        "theta": result.theta,
        "x_est": result.x_est,
        "y_est": result.y_est,
        "theta_est": result.theta_est,
        "x_ref": result.x_ref,
        "y_ref": result.y_ref,
        "x_meas": result.x_meas,
        "y_meas": result.y_meas,
        "theta_meas": result.theta_meas,
        "v": result.v,
        "omega": result.omega,
        "error_x": errors["x"],
        "error_y": errors["y"],
        "error_theta": errors["theta"],
        "reference_distance": reference_distance,
        "constraint": result.constraint,
        "phase2_iterations": np.asarray(result.phase2_iterations, dtype=np.float64),
    }


def _any_finite(values: FloatArray) -> bool:
    return bool(np.isfinite(values).any())


def _limit_line(values: FloatArray, limit: float, unit: str) -> list[dict[str, Any]]:
    """The ±limit lines of an input, drawn when the signal comes within half of
    the limit (else they would flatten it, and the title names them)."""
    if not math.isfinite(limit):
        return []
    peak = float(np.nanmax(np.abs(values))) if _any_finite(values) else 0.0
    shown = peak >= 0.5 * limit
    return [
        {"y": sign * limit, "label": f"limit ±{limit:g} {unit}", "shown": shown}
        for sign in (1.0, -1.0)
    ]


def _plots(result: RunResult, signals: dict[str, FloatArray], summary: dict[str, Any]) -> list[Any]:
    """The time plots, each a list of series (key of the signal, label, style)."""

    def present(*keys: str) -> list[str]:
        return [k for k in keys if k in signals and _any_finite(signals[k])]

    def series(key: str, label: str, style: str) -> dict[str, str]:
        return {"key": key, "label": label, "style": style}

    plots: list[dict[str, Any]] = []
    for state, unit in (("x", "m"), ("y", "m"), ("theta", "rad")):
        keys = present(state, f"{state}_est", f"{state}_ref", f"{state}_meas")
        styles = {
            state: series(state, "true", "true"),
            f"{state}_est": series(f"{state}_est", "estimate", "estimate"),
            f"{state}_ref": series(f"{state}_ref", "reference", "reference"),
            f"{state}_meas": series(f"{state}_meas", "measurement", "measurement"),
        }
        plots.append(
            {"id": state, "title": f"{state} [{unit}]", "series": [styles[k] for k in keys]}
        )
    for name, unit, limit in (("v", "m/s", result.limits[0]), ("omega", "rad/s", result.limits[1])):
        lines = _limit_line(signals[name], limit, unit)
        plots.append(
            {
                "id": name,
                "title": f"{name} [{unit}]",
                "series": [series(name, name, "input")],
                "lines": lines,
            }
        )
    plots.append(
        {
            "id": "estimation_error",
            "title": "estimation error, true - estimate [m, m, rad]",
            "series": [
                series("error_x", "x", "error-x"),
                series("error_y", "y", "error-y"),
                series("error_theta", "theta", "error-theta"),
            ],
            "zero": True,
        }
    )
    if _any_finite(signals["reference_distance"]):
        plots.append(
            {
                "id": "reference_distance",
                "title": "distance to the reference point [m]",
                "series": [series("reference_distance", "distance", "error")],
                "zero": True,
            }
        )
    if _any_finite(signals["constraint"]):
        lines = [{"y": 0.0, "label": "boundary (above: violated)", "shown": True}]
        lines += [
            {"y": float(e["max"]), "label": f"expect max {e['max']:g}", "shown": True}
            for e in _expectations(summary)
            if e["metric"] == "max_constraint_violation" and isinstance(e.get("max"), int | float)
        ]
        plots.append(
            {
                "id": "constraint",
                "title": "constraint value (> 0: violated)",
                "series": [series("constraint", "constraint", "error")],
                "lines": lines,
            }
        )
    if signals["phase2_iterations"].any():
        plots.append(
            {
                "id": "phase2_iterations",
                "title": "estimator phase-II iterations (eqs. 8-11)",
                "series": [series("phase2_iterations", "iterations", "input")],
            }
        )
    return plots


def _finite_number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        return None
    return float(value)


def _text(value: Any) -> str | None:
    return value if isinstance(value, str) else None


def _expectations(summary: dict[str, Any]) -> list[dict[str, Any]]:
    """summary.json's verdicts, each field taken only when of the expected type."""
    records = summary.get("expectations")
    if not isinstance(records, list):
        return []
    return [
        {
            "metric": _text(e.get("metric")) or "?",
            "phase": _text(e.get("phase")),
            "max": _finite_number(e.get("max")),
            "min": _finite_number(e.get("min")),
            "value": _finite_number(e.get("value")),
            "met": e.get("met") if isinstance(e.get("met"), bool) else None,
            "margin": _finite_number(e.get("margin")),
            "unit": _unit(e.get("metric")),
        }
        for e in records
        if isinstance(e, dict)
    ]


def _unit(metric: Any) -> str:
    """A check's unit, from the catalog of metrics ("" for one it does not know)."""
    return catalog.unit_of(metric) if isinstance(metric, str) else ""


def _margins(record: Any) -> dict[str, Any] | None:
    """campaign.json's distribution of the runs' margins (None before it had one)."""
    if not isinstance(record, dict):
        return None
    return {
        **{q: _finite_number(record.get(q)) for q in ("min", "p1", "p5", "p50", "max")},
        "below_zero": _count(record.get("below_zero")) or 0,
        # the runs the quantiles are over, and the misses without a number they
        # leave out (None from a campaign.json written before it said them)
        "finite": _count(record.get("finite")),
        "minus_inf": _count(record.get("minus_inf")),
    }


def _dig(record: Any, *keys: str) -> float | None:
    for key in keys:
        if not isinstance(record, dict):
            return None
        record = record.get(key)
    return _finite_number(record)


# The catalog's metrics the phases' table shows, under the verdict's names: how
# far off the path and behind, the shares of samples at a limit; then each a
# runs.csv has a column of (wmr_mission.spec.catalog).
_PHASE_TABLE: Final = (
    "cross_track_error_max",
    "along_track_lag_max",
    "tracking_error_rms",
    "tracking_error_max",
    "speed_at_limit",
    "turn_rate_at_limit",
)


def _phase_metrics() -> list[catalog.Metric]:
    shown = [catalog.CATALOG[name] for name in _PHASE_TABLE]
    return shown + [m for m in catalog.phase_metrics() if m.column and m not in shown]


def _phase_rows(summary: dict[str, Any]) -> list[dict[str, Any]]:
    """summary.json's per-phase metrics that explain a phase at a glance."""
    records = summary.get("phases")
    if not isinstance(records, list):
        return []
    metrics = _phase_metrics()
    rows = []
    for p in records:
        if not isinstance(p, dict):
            continue
        rows.append(
            {
                "name": _text(p.get("name")) or "?",
                "kind": _text(p.get("kind")) or "?",
                "start": _dig(p, "start"),
                "end": _dig(p, "end"),
                "duration": _dig(p, "duration"),
                "target_position": _dig(p, "target_error", "position"),
                "target_heading": _dig(p, "target_error", "heading"),
                "max_violation": _dig(p, "constraint", "max_violation"),
                "metrics": [_dig(p, *metric.where) for metric in metrics],
            }
        )
    return rows


def _regions(result: RunResult, extent: tuple[float, float, float, float]) -> list[Any]:
    from pydantic import TypeAdapter

    from wmr_mission.geometry.regions import RegionSpec, region_outline

    sides: dict[str, set[str]] = {}
    for phase in result.phases:
        for region, side in phase.constraints:
            sides.setdefault(region, set()).add(side)
    adapter: TypeAdapter[Any] = TypeAdapter(RegionSpec)
    regions = []
    for name, record in result.regions.items():
        spec = adapter.validate_python(record)
        xs, ys = region_outline(spec, extent=extent)
        regions.append(
            {
                "name": name,
                "type": spec.type,
                "x": [float(v) for v in xs],
                "y": [float(v) for v in ys],
                "closed": spec.type != "half-plane",
                "sides": sorted(sides.get(name, ())),
            }
        )
    return regions


def _colors(result: RunResult) -> list[str]:
    from matplotlib.colors import to_hex

    from wmr_mission.output.figures import phase_colors

    return [str(to_hex(color)) for color in phase_colors(result)]


def run_meta(result: RunResult, summary: dict[str, Any]) -> tuple[dict[str, Any], str]:
    """The page's data for a run: its description (``meta``) and its signals (JSON text)."""
    from wmr_mission.output.figures import view_box

    samples = result.samples
    bounds = _buckets(samples)
    shown = _display_indices(samples, bounds)
    signals = _signals(result)
    box = view_box(result)
    colors = _colors(result)
    phase = np.asarray(result.phase, dtype=np.int64)
    transitions = []
    for change in result.transitions:
        k = min(int(np.searchsorted(result.t, change.time)), samples - 1) if samples else 0
        transitions.append(
            {
                "time": _finite_number(change.time),
                "from": change.from_phase,
                "to": change.to_phase,
                "condition": change.condition,
                "value": _finite_number(change.value),
                "lap": change.lap,
                "reaction": change.reaction,  # what fired, and why (None: in order)
                "why": change.why,
                "x": _finite_number(float(result.x[k])) if samples else None,
                "y": _finite_number(float(result.y[k])) if samples else None,
            }
        )
    meta: dict[str, Any] = {
        "kind": "run",
        "mission": result.mission_name,
        "seed": result.seed,
        "outcome": result.outcome.value,
        "message": result.message,
        "dt": result.dt,
        "samples": samples,
        "shown": int(shown.size),
        "bucket_seconds": (None if bounds is None else float(np.diff(bounds).max() * result.dt)),
        "phases": [
            {
                "name": info.name,
                "kind": info.kind,
                "color": colors[i],
                "target": None if info.target is None else [_finite_number(v) for v in info.target],
            }
            for i, info in enumerate(result.phases)
        ],
        "view": list(box),
        "regions": _regions(result, box),
        "transitions": transitions,
        "expectations": _expectations(summary),
        "margin": _finite_number(summary.get("margin")),
        "margin_check": _text(summary.get("margin_check")),
        "phase_table": _phase_rows(summary),
        # the columns of its metrics: the catalog's names and units
        "phase_metrics": [{"name": m.name, "unit": m.unit} for m in _phase_metrics()],
        "final": {
            "position_error": _dig(summary, "final", "position_error"),
            "heading_error": _dig(summary, "final", "heading_error"),
        },
        "plots": _plots(result, signals, summary),
    }
    parts = [
        f'"t":{_numbers(result.t[shown], _TIME_DIGITS)}',
        f'"phase":[{",".join(str(p) for p in phase[shown].tolist())}]',
    ]
    # The x-y plot and the readouts take true samples: the poses at the shown
    # times (the signals themselves when every sample shows).
    if bounds is not None:
        for key in _POSE_KEYS:
            parts.append(f'"pose_{key}":{_numbers(signals[key][shown])}')
    for key, values in signals.items():
        parts.append(f'"{key}":{_numbers(thin_signal(values, bounds))}')
    return meta, "{" + ",".join(parts) + "}"


def run_page(run_dir: Path) -> tuple[str, str]:
    """The HTML of a run directory's report, and its title."""
    from wmr_mission.output.reader import load_run, read_json

    result = load_run(run_dir)
    # load_run has read and checked summary.json: here only the verdicts are taken.
    summary = read_json(run_dir / SUMMARY_FILE)
    meta, series = run_meta(result, summary if isinstance(summary, dict) else {})
    return build_page(f"{result.mission_name}: run report", meta, series), result.mission_name


# --- a campaign -----------------------------------------------------------


def _table_rows(outcomes: list[str]) -> list[int]:
    """Indices of the rows shown: every failure, then successes in run order, in run order."""
    if len(outcomes) <= MAX_TABLE_ROWS:
        return list(range(len(outcomes)))
    failed = [i for i, outcome in enumerate(outcomes) if outcome != "success"][:MAX_TABLE_ROWS]
    room = MAX_TABLE_ROWS - len(failed)
    succeeded = [i for i, outcome in enumerate(outcomes) if outcome == "success"][:room]
    return sorted(failed + succeeded)


def _count(value: Any) -> int | None:
    return value if isinstance(value, int) and not isinstance(value, bool) and value >= 0 else None


def _cells_without_runs(cells: Any) -> list[str]:
    """campaign.json's grid cells without runs, each as ``path=value, ...``."""
    if not isinstance(cells, list):
        return []
    return [
        ", ".join(f"{path}={json.dumps(value)}" for path, value in cell.items())
        for cell in cells
        if isinstance(cell, dict)
    ]


def _campaign_expectation(record: dict[str, Any], runs: int, planned: int | None) -> dict[str, Any]:
    """One of campaign.json's expectations, each field taken only when of the
    expected type. A record without a ``verdict`` whose runs fall short of the
    planned ones is shown not judged: its ``met`` covers the runs done only."""
    met = record.get("met") if isinstance(record.get("met"), bool) else None
    verdict = _text(record.get("verdict"))
    if verdict is None:
        if met is True and planned is not None and runs < planned:
            met, verdict = None, f"not judged: interrupted after {runs} of {planned} runs"
        else:
            verdict = "\u2013" if met is None else "met" if met else "NOT MET"
    elif met is False:
        verdict = verdict.replace("not met", "NOT MET", 1)
    return {
        "metric": _text(record.get("metric")) or "?",
        "min": _finite_number(record.get("min")),
        "value": _finite_number(record.get("value")),
        "met": met,
        "verdict": verdict,
    }


def campaign_meta(campaign_dir: Path, out: Path) -> dict[str, Any]:
    from urllib.parse import quote

    from wmr_mission.campaign.reader import load_campaign_dir
    from wmr_mission.campaign.sweep import WORST_DIR

    campaign = load_campaign_dir(campaign_dir)
    summary = campaign.summary
    kept = _table_rows([row[2] for row in campaign.rows])
    worst_runs = (
        {str(w.get("run")) for w in summary.get("worst", []) if isinstance(w, dict)}
        if isinstance(summary.get("worst"), list)
        else set()
    )
    links = {}
    for run in worst_runs:
        directory = campaign_dir / WORST_DIR / run
        if run.isdigit() and (directory / SUMMARY_FILE).is_file():  # a run's record
            relative = os.path.relpath(directory, out.parent)
            links[run] = "/".join(quote(part) for part in Path(relative).parts) + "/"
    figures = [
        {"name": path.name, "png": base64.b64encode(path.read_bytes()).decode("ascii")}
        for path in campaign.figures()
    ]
    metrics = summary.get("metrics")
    planned = _count(summary.get("planned_runs"))
    missing = max(0, planned - summary["runs"]) if planned is not None else 0
    return {
        "kind": "campaign",
        "campaign": _text(summary.get("campaign")) or campaign_dir.name,
        "runs": summary["runs"],
        "planned_runs": summary.get("planned_runs"),
        "succeeded": summary["succeeded"],
        "success_rate": _finite_number(summary.get("success_rate")),
        "success_interval": [_finite_number(v) for v in summary["success_interval"]],
        "interrupted": summary.get("interrupted") is True,
        "outcomes": summary.get("outcomes", {}),
        "missing_runs": missing,
        "cells_without_runs": _cells_without_runs(summary.get("cells_without_runs")),
        "cells_without_runs_count": _count(summary.get("cells_without_runs_count")),
        "expectations": [
            _campaign_expectation(e, summary["runs"], planned)
            for e in summary.get("expectations", [])
            if isinstance(e, dict)
        ]
        if isinstance(summary.get("expectations"), list)
        else [],
        "metrics": {
            name: {q: _dig(values, q) for q in ("p50", "p95", "p99", "max")}
            for name, values in metrics.items()
            if isinstance(values, dict)
        }
        if isinstance(metrics, dict)
        else {},
        "margin": _margins(summary.get("margin")),
        "wall_seconds": _finite_number(summary.get("wall_seconds")),
        "missions_per_second": _finite_number(summary.get("missions_per_second")),
        "columns": campaign.columns,
        "types": list(campaign.column_types().values()),
        "rows": [_margin_shown(campaign.columns, campaign.rows[i]) for i in kept],
        "replays": [campaign.replay(i) for i in kept],
        "total_rows": len(campaign.rows),
        "worst": sorted(worst_runs),
        "worst_links": links,
        "figures": figures,
    }


def _margin_shown(columns: list[str], row: list[str]) -> list[str]:
    """A row as the page's numbers read it: runs.csv's empty ``margin`` is -inf
    where ``margin_check`` names what set it (an outcome, a check without a
    value) and +inf where it is empty (no check), written as JavaScript's
    Infinity, so that the table shows it and sorts a timeout below every run
    with a number, as the falsification's table does."""
    if "margin" not in columns or "margin_check" not in columns:
        return row  # a runs.csv written before the runs had margins
    at = columns.index("margin")
    if row[at] != "":
        return row
    shown = list(row)
    shown[at] = "-Infinity" if row[columns.index("margin_check")] else "Infinity"
    return shown


def campaign_page(campaign_dir: Path, out: Path) -> tuple[str, str]:
    meta = campaign_meta(campaign_dir, out)
    return build_page(f"{meta['campaign']}: campaign report", meta), str(meta["campaign"])


# --- the command ------------------------------------------------------------


def view_command(directory: Path, out: Path | None = None) -> int:
    """``wmr-mission view DIR [--out FILE.html]``: write the report, print its path.

    Exit code: 0 written; 1 the directory's files are damaged (as ``plot``);
    2 not a run, campaign or falsification directory, FILE a file of a
    record, in another record's directory or a file already that is not an
    earlier report (wmr_mission.review.record), or the page cannot be written."""
    from wmr_mission.campaign.reader import is_campaign_dir
    from wmr_mission.review.falsification import falsification_meta, is_falsification_dir
    from wmr_mission.review.record import record_file_refusal, written_at

    target = out if out is not None else directory / REPORT_FILE
    falsification = is_falsification_dir(directory)
    campaign = is_campaign_dir(directory)
    if not (falsification or campaign) and not (directory / TRAJECTORY_FILE).is_file():
        print(
            f"{directory}: neither a run directory (no {TRAJECTORY_FILE}) "
            "nor a campaign directory (no runs.csv, campaign.json) "
            "nor a falsification directory (no evaluations.csv, falsify.json)",
            file=sys.stderr,
        )
        return 2
    refusal = record_file_refusal(target, directory, REPORT_FILE, is_report)
    if refusal is not None:
        print(refusal, file=sys.stderr)
        return 2
    try:
        if falsification:
            meta = falsification_meta(directory)
            page = build_page(f"{meta['campaign']}: falsification report", meta)
        else:
            page, _ = campaign_page(directory, target) if campaign else run_page(directory)
    except (RunDirError, OSError) as error:
        print(f"{directory}: {error}", file=sys.stderr)
        return 1
    except Exception as error:  # a fault in the report: one line, never a traceback
        print(
            f"{directory}: cannot build the report ({type(error).__name__}: {error}); "
            "the data are unchanged; please report it",
            file=sys.stderr,
        )
        return 1
    try:
        write_bytes_atomic(written_at(target), page.encode("utf-8"))
    except OSError as error:
        print(f"{target}: cannot write the report: {error.strerror or error}", file=sys.stderr)
        return 2
    print(target)
    return 0
