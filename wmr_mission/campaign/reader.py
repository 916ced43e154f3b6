"""Read a campaign directory back for ``view`` and ``export``, trusting nothing in it.

``runs.csv`` is checked line by line (its header against the campaign's
varied paths, the field count, the run and seed numbers, each metric a number
or empty, each run's seed and values against the campaign's plan), and
``campaign.json`` and ``manifest.json`` for the keys read. A problem is one
line naming the file (and line) and what is wrong, as for a run directory.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Final

from wmr_mission.campaign.load import recorded_sha256, replay_line, value_text
from wmr_mission.campaign.sweep import CAMPAIGN_FILE, MANIFEST_FILE, RUNS_FILE
from wmr_mission.output.reader import RunDirError, csv_rows, json_value

__all__ = ["CampaignDir", "is_campaign_dir", "load_campaign_dir"]

# The first and last columns of runs.csv; the varied paths follow the first,
# the metrics precede the last (their set grows with the product's metrics).
FIRST_COLUMNS: Final = ("run", "seed", "outcome")
LAST_COLUMN: Final = "reason"
# Between the metrics and the reason: the check that sets the run's margin, a name.
TEXT_METRICS: Final = ("margin_check",)
_INTEGER = re.compile(r"[-+]?\d+")


@dataclass(frozen=True)
class CampaignDir:
    """A campaign directory, read and checked: ``runs.csv`` as text cells."""

    path: Path
    paths: list[str]  # the varied mission paths, in runs.csv's order
    metrics: list[str]  # the metric columns
    rows: list[list[str]]  # runs.csv's cells, one list per run
    summary: dict[str, Any]  # campaign.json
    manifest: dict[str, Any]
    values: list[dict[str, Any]]  # each row's drawn values, from the campaign's plan

    @property
    def columns(self) -> list[str]:
        return [*FIRST_COLUMNS, *self.paths, *self.metrics, LAST_COLUMN]

    def figures(self) -> list[Path]:
        """The campaign's PNG figures, the three of every campaign first."""
        known = ("trajectories.png", "success.png", "metrics.png")
        found = sorted(p for p in self.path.glob("*.png") if p.is_file())
        return sorted(found, key=lambda p: known.index(p.name) if p.name in known else len(known))

    def replay(self, index: int) -> str:
        """The ``wmr-mission run`` command that reproduces row ``index``, as
        ``campaign.json``'s ``worst`` gives it."""
        return replay_line(
            str(self.manifest["mission_file"]),
            [str(setting) for setting in self.manifest.get("settings") or []],
            self.values[index],
            self.rows[index][1],
            str(self.manifest["environment"]["fingerprint"]),
            recorded_sha256(self.manifest),
        )

    def column_types(self) -> dict[str, str]:
        """Each column's type: ``int64``, ``float64``, ``bool`` or ``string``.

        ``run`` and ``seed`` are integers, the metrics numbers (an empty cell:
        no value), ``outcome`` and ``reason`` text; a varied path's column is
        integers, numbers or booleans when every run's value is one, else text
        (a list or mapping is its JSON text, as in runs.csv)."""
        types = {"run": "int64", "seed": "int64", "outcome": "string", LAST_COLUMN: "string"}
        for path in self.paths:
            drawn = [values[path] for values in self.values]
            if drawn and all(isinstance(v, bool) for v in drawn):
                types[path] = "bool"
            elif drawn and all(isinstance(v, int) and not isinstance(v, bool) for v in drawn):
                types[path] = "int64"
            elif drawn and all(
                isinstance(v, int | float) and not isinstance(v, bool) for v in drawn
            ):
                types[path] = "float64"
            else:
                types[path] = "string"
        types.update(dict.fromkeys(self.metrics, "float64"))
        types.update(dict.fromkeys(set(TEXT_METRICS) & set(self.metrics), "string"))
        return {name: types[name] for name in self.columns}


def is_campaign_dir(path: Path) -> bool:
    """Whether ``path`` looks like a campaign directory (it has runs.csv or campaign.json)."""
    return (path / RUNS_FILE).is_file() or (path / CAMPAIGN_FILE).is_file()


def _read_json(path: Path) -> dict[str, Any]:
    if not path.is_file():
        raise RunDirError(
            f"{path.name} is missing (not a campaign directory, or an interrupted one)"
        )
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RunDirError(f"{path.name}: cannot be read: {exc}") from None
    value = json_value(text, path.name)
    if not isinstance(value, dict):
        raise RunDirError(f"{path.name}: expected a JSON object")
    return value


def _check_summary(summary: dict[str, Any]) -> None:
    for key in ("runs", "succeeded"):
        value = summary.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise RunDirError(f"{CAMPAIGN_FILE}: '{key}' must be a whole number")
    rate = summary.get("success_rate")
    if rate is not None and (isinstance(rate, bool) or not isinstance(rate, int | float)):
        raise RunDirError(f"{CAMPAIGN_FILE}: 'success_rate' must be a number or null")
    interval = summary.get("success_interval")
    if not (
        isinstance(interval, list)
        and len(interval) == 2
        and all(
            v is None or (isinstance(v, int | float) and not isinstance(v, bool)) for v in interval
        )
    ):
        raise RunDirError(f"{CAMPAIGN_FILE}: 'success_interval' must be [lo, hi]")
    outcomes = summary.get("outcomes", {})
    if not isinstance(outcomes, dict) or not all(
        isinstance(n, int) and not isinstance(n, bool) for n in outcomes.values()
    ):
        raise RunDirError(f"{CAMPAIGN_FILE}: 'outcomes' must map each outcome to a count")


def _plan(manifest: dict[str, Any]) -> Any:
    from pydantic import ValidationError

    from wmr_mission.campaign.models import Campaign
    from wmr_mission.campaign.plan import Plan

    for key in ("mission_file",):
        if not isinstance(manifest.get(key), str):
            raise RunDirError(f"{MANIFEST_FILE}: '{key}' must be a text")
    environment = manifest.get("environment")
    if not isinstance(environment, dict) or not isinstance(environment.get("fingerprint"), str):
        raise RunDirError(f"{MANIFEST_FILE}: 'environment.fingerprint' must be a text")
    try:
        return Plan(Campaign.model_validate(manifest.get("resolved_campaign")))
    except ValidationError as error:
        first = error.errors(include_url=False)[0]
        at = ".".join(str(part) for part in first["loc"])
        where = "resolved_campaign" + (f".{at}" if at else "")
        raise RunDirError(f"{MANIFEST_FILE}: {where}: {first['msg']}") from None


def _read_rows(path: Path, plan: Any) -> tuple[list[str], list[list[str]]]:
    """runs.csv's metric columns and rows, each checked against the plan."""
    if not path.is_file():
        raise RunDirError(f"{path.name} is missing (not a campaign directory)")
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RunDirError(f"{path.name}: cannot be read: {exc}") from None
    table = csv_rows(text, path.name)
    paths = plan.paths
    header = table[0] if table else []
    first = [*FIRST_COLUMNS, *paths]
    if (
        header[: len(first)] != first
        or header[-1:] != [LAST_COLUMN]
        or len(header) < len(first) + 1
    ):
        raise RunDirError(
            f"{path.name}:1: header must be {','.join(first)},<metrics>,{LAST_COLUMN} "
            f"(the varied paths of {MANIFEST_FILE})"
        )
    metrics = header[len(first) : -1]
    rows = table[1:]
    for line, row in enumerate(rows, start=2):
        if len(row) != len(header):
            raise RunDirError(
                f"{path.name}:{line}: expected {len(header)} fields, found {len(row)}"
            )
        for name, cell in zip(FIRST_COLUMNS[:2], row, strict=False):
            if not _INTEGER.fullmatch(cell):
                raise RunDirError(f"{path.name}:{line}: {name} is not a whole number: {cell!r}")
        if not row[2]:
            raise RunDirError(f"{path.name}:{line}: outcome is empty")
        for name, cell in zip(metrics, row[len(first) : -1], strict=True):
            if cell and name not in TEXT_METRICS and not _is_number(cell):
                raise RunDirError(f"{path.name}:{line}: {name} is not a number: {cell!r}")
    return metrics, rows


def _is_number(text: str) -> bool:
    try:
        float(text)
    except ValueError:
        return False
    return True


def _drawn_values(path: Path, plan: Any, rows: list[list[str]]) -> list[dict[str, Any]]:
    """Each row's values as the plan draws them: the row must hold them, and the run's seed."""
    drawn = []
    for line, row in enumerate(rows, start=2):
        run = int(row[0])
        if not 0 <= run < len(plan):
            raise RunDirError(
                f"{path.name}:{line}: run {run} is not a run of a {len(plan)}-run campaign"
            )
        draw = plan.draw(run)
        cells = [v if isinstance(v, str) else value_text(v) for v in draw.values.values()]
        if int(row[1]) != draw.seed or row[3 : 3 + len(cells)] != cells:
            raise RunDirError(
                f"{path.name}:{line}: run {run}'s seed and values are not those the campaign "
                f"draws ({MANIFEST_FILE}'s resolved_campaign)"
            )
        drawn.append(draw.values)
    return drawn


def load_campaign_dir(directory: Path) -> CampaignDir:
    """Read and check a campaign directory; raises :class:`RunDirError` (one line)."""
    if not directory.is_dir():
        raise RunDirError("not a directory")
    summary = _read_json(directory / CAMPAIGN_FILE)
    _check_summary(summary)
    manifest = _read_json(directory / MANIFEST_FILE)
    plan = _plan(manifest)
    metrics, rows = _read_rows(directory / RUNS_FILE, plan)
    values = _drawn_values(directory / RUNS_FILE, plan, rows)
    if len(rows) != summary["runs"]:  # cut at a line's end, or rows added: not this record
        raise RunDirError(
            f"{RUNS_FILE} holds {len(rows)} runs, but {CAMPAIGN_FILE} says {summary['runs']} "
            "(cut short or edited)"
        )
    return CampaignDir(directory, plan.paths, metrics, rows, summary, manifest, values)


def cell_value(cell: str, kind: str) -> Any:
    """A runs.csv cell as a value of its column's type (None: an empty metric)."""
    if kind == "int64":
        return int(cell)
    if kind == "float64":
        return float(cell) if cell else None
    if kind == "bool":
        return cell == "true"
    return cell
