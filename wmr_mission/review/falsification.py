"""``wmr-mission view`` of a falsification directory (``wmr-mission falsify``'s):
its verdict, the lowest runs with their commands, its figures and every evaluation."""

from __future__ import annotations

import base64
import json
import math
from pathlib import Path
from typing import Any, Final

from wmr_mission.campaign.falsify.figures import MARGINS_FIGURE, REGION_FIGURE
from wmr_mission.campaign.falsify.files import (
    EVALUATIONS_FILE,
    FAILING_DIR,
    FALSIFY_FILE,
    columns,
)
from wmr_mission.campaign.load import recorded_sha256, replay_line
from wmr_mission.output.reader import RunDirError, csv_rows, json_value

__all__ = ["falsification_meta", "is_falsification_dir"]

# Rows of the table: evaluations.csv has them all.
MAX_TABLE_ROWS: Final = 10_000
_NUMBERS: Final = ("margin", "objective")


def is_falsification_dir(path: Path) -> bool:
    return (path / FALSIFY_FILE).is_file() and (path / EVALUATIONS_FILE).is_file()


def _json(path: Path) -> dict[str, Any]:
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise RunDirError(f"{path.name}: not UTF-8 text ({error.reason})") from None
    data = json_value(text, path.name)
    if not isinstance(data, dict):
        raise RunDirError(f"{path.name}:1:1: not a JSON object")
    return data


def _rows(path: Path) -> list[list[str]]:
    """``evaluations.csv``'s header and rows, each row as wide as the header."""
    try:
        text = path.read_text(encoding="utf-8")
    except UnicodeDecodeError as error:
        raise RunDirError(f"{path.name}: not a CSV table of evaluations ({error})") from None
    table = csv_rows(text, path.name)
    if not table:
        raise RunDirError(f"{path.name}:1: empty: expected a header of columns")
    header = table[0]
    paths = header[3:-4]
    if header != columns(paths):
        raise RunDirError(
            f"{path.name}:1: not the header of falsify's evaluations: expected "
            f"{', '.join(columns(['PATH...']))}"
        )
    width = len(header)
    for line, row in enumerate(table[1:], start=2):
        if len(row) != width:
            raise RunDirError(f"{path.name}:{line}: expected {width} fields, found {len(row)}")
    return table


def _value(cell: str) -> Any:
    try:
        return json.loads(cell)
    except ValueError:
        return cell  # a text value is written as it is


def _shown(cell: str) -> str:
    """A margin cell as the page's numbers read it (JavaScript's Infinity)."""
    return {"inf": "Infinity", "-inf": "-Infinity"}.get(cell, cell)


def _type(column: str, cells: list[str]) -> str:
    if column in ("evaluation", "seed"):
        return "int64"
    if column in _NUMBERS:
        return "float64"
    if cells and all(_is_number(c) for c in cells):
        return "float64"
    return "string"


def _is_number(cell: str) -> bool:
    try:
        return math.isfinite(float(cell))
    except ValueError:
        return False


def falsification_meta(directory: Path) -> dict[str, Any]:
    record = _json(directory / FALSIFY_FILE)
    manifest = _json(directory / "manifest.json")
    table = _rows(directory / EVALUATIONS_FILE)
    columns, rows = table[0], table[1 : MAX_TABLE_ROWS + 1]
    paths = columns[3:-4]
    environment = manifest.get("environment")
    if not isinstance(environment, dict) or "fingerprint" not in environment:
        raise RunDirError("manifest.json: no environment.fingerprint: expected a falsify manifest")
    if "mission_file" not in manifest:
        raise RunDirError("manifest.json: no mission_file: expected a falsify manifest")
    fingerprint = str(environment["fingerprint"])
    replays = []
    for row in rows:
        mission = directory / FAILING_DIR / f"{row[0]}.yaml"
        if mission.is_file():
            replays.append(f"wmr-mission run {mission.resolve()}")
            continue
        values = {path: _value(cell) for path, cell in zip(paths, row[3:-4], strict=True)}
        mission_file = str(manifest["mission_file"])
        digest = recorded_sha256(manifest)
        replays.append(replay_line(mission_file, [], values, row[1], fingerprint, digest))
    figures = [
        {"name": name, "png": base64.b64encode((directory / name).read_bytes()).decode("ascii")}
        for name in (MARGINS_FIGURE, REGION_FIGURE)
        if (directory / name).is_file()
    ]
    outcomes: dict[str, int] = {}
    for row in table[1:]:
        outcomes[row[2]] = outcomes.get(row[2], 0) + 1
    return {
        "kind": "falsification",
        "campaign": str(record.get("campaign") or directory.name),
        "record": record,
        "outcomes": outcomes,
        "columns": columns,
        "types": [_type(c, [r[j] for r in rows]) for j, c in enumerate(columns)],
        "rows": [
            [_shown(c) if columns[j] in _NUMBERS else c for j, c in enumerate(r)] for r in rows
        ],
        "replays": replays,
        "total_rows": len(table) - 1,
        "worst": [],
        "worst_links": {},
        "figures": figures,
    }
