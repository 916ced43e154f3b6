"""Read a run directory back for ``wmr-mission plot``, trusting nothing in it.

Every file is checked before anything is drawn: JSON shapes and types, names
(a mission, phase or region name is what a mission file allows, so no text
reaches a figure as markup), regions against the mission models, the CSV's
header, fields, numbers and phase names, and its row count against
``summary.json`` (a file cut at a line boundary is reported, not drawn as if
complete). A problem is one line naming the file and what is wrong.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import re
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from wmr_mission.output.result import RunResult
from wmr_mission.output.rundir import (
    CLAIM_FILE,
    MANIFEST_FILE,
    SUMMARY_FILE,
    TRAJECTORY_FILE,
    TRANSITIONS_FILE,
)
from wmr_mission.record import CSV_COLUMNS, REFERENCE_COLUMN, Outcome, PhaseRecord, Transition
from wmr_mission.spec.models import MISSION_NAME, is_color
from wmr_mission.terminal import shown

# Run directories written before the measurement was recorded: still readable.
MEASUREMENT_COLUMNS = ("x_meas", "y_meas", "theta_meas")
_OLDER_CSV_COLUMNS = tuple(c for c in CSV_COLUMNS if c not in MEASUREMENT_COLUMNS)


# Its message leaves out the run directory: callers print `RUN_DIR: message`.
class RunDirError(ValueError):
    """A run directory that cannot be read back (missing or corrupt file); one line."""


# --- reading back ---------------------------------------------------------


def _read_text(path: Path) -> str:
    if not path.is_file():
        raise RunDirError(f"{path.name} is missing (not a run directory, or an interrupted run)")
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RunDirError(f"{path.name}: cannot be read: {exc}") from None


def read_json(path: Path, *, finite: bool = False) -> Any:
    """A JSON file of a run directory, parsed (:func:`json_value`)."""
    return json_value(_read_text(path), path.name, finite=finite)


def json_value(text: str, name: str, *, finite: bool = False) -> Any:
    """The JSON text of a record's file ``name``; what is not JSON, or is nested
    too deeply to parse, is a :class:`RunDirError`. With ``finite``, a number
    that is not finite (``NaN``, ``Infinity``, ``1e999``: not JSON, though
    Python reads them) is None, as the product writes it."""
    options: dict[str, Any] = {}
    if finite:
        options["parse_constant"] = lambda _: None
        options["parse_float"] = lambda text: value if math.isfinite(value := float(text)) else None
    try:
        return json.loads(text, **options)
    except json.JSONDecodeError as exc:
        raise RunDirError(f"{name}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}") from None
    except RecursionError:
        raise RunDirError(
            f"{name}: nested too deeply to read (arrays and objects inside one another)"
        ) from None


def csv_rows(text: str, name: str) -> list[list[str]]:
    """The rows of a record's CSV file ``name``; a row the CSV reader refuses (a
    field over its limit of 131,072 characters) is a :class:`RunDirError`
    naming the line the row starts on."""
    reader = csv.reader(io.StringIO(text, newline=""))
    rows: list[list[str]] = []
    while True:
        line = reader.line_num + 1
        try:
            rows.append(next(reader))
        except StopIteration:
            return rows
        except csv.Error as exc:
            raise RunDirError(f"{name}:{line}: not a row of CSV: {exc}") from None


def _field(record: Any, key: str, kind: type | tuple[type, ...], where: str) -> Any:
    if not isinstance(record, dict) or key not in record:
        raise RunDirError(f"{where}: '{key}' is missing")
    value = record[key]
    kinds = kind if isinstance(kind, tuple) else (kind,)
    # JSON true/false are ints to Python; they are never a number here.
    if not isinstance(value, kinds) or (isinstance(value, bool) and bool not in kinds):
        raise RunDirError(f"{where}: '{key}' has the wrong type")
    return value


def _number(value: Any, where: str) -> float:
    # null stands for NaN (JSON has no NaN).
    if value is None:
        return math.nan
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise RunDirError(f"{where}: expected a number or null")
    return float(value)


_KINDS = ("track", "regulate", "hold")
_SIDES = ("inside", "outside")
# Largest phase-II iteration count a mission allows (estimator.max_iterations).
_MAX_ITERATIONS = 1000


def _name(record: Any, key: str, pattern: str, where: str) -> str:
    value = _field(record, key, str, where)
    if not re.match(pattern, value):
        raise RunDirError(f"{where}: '{key}' {_shown(value)} is not a name a mission allows")
    return str(value)


def _choice(record: Any, key: str, choices: Sequence[str], where: str) -> str:
    value = _field(record, key, str, where)
    if value not in choices:
        raise RunDirError(f"{where}: '{key}' must be one of {', '.join(choices)}")
    return str(value)


def _shown(value: str) -> str:
    return shown(repr(value), 40)


def _regions_from(run: Any) -> dict[str, Any]:
    """The regions, each checked against the mission's region models."""
    from pydantic import TypeAdapter, ValidationError

    from wmr_mission.fields import IDENTIFIER
    from wmr_mission.geometry.regions import RegionSpec

    where = f"{MANIFEST_FILE}: run.regions"
    regions = _field(run, "regions", dict, f"{MANIFEST_FILE}: run")
    adapter: TypeAdapter[Any] = TypeAdapter(RegionSpec)
    for name, region in regions.items():
        if not re.match(IDENTIFIER, name):
            raise RunDirError(f"{where}: {_shown(name)} is not a region name")
        try:
            adapter.validate_python(region)
        except ValidationError as error:
            first = error.errors(include_url=False)[0]
            at = ".".join(str(part) for part in first["loc"][1:])
            raise RunDirError(f"{where}.{name}{'.' + at if at else ''}: {first['msg']}") from None
    return dict(regions)


def _phases_from(run: Any) -> list[PhaseRecord]:
    where = f"{MANIFEST_FILE}: run.phases"
    phases = []
    for i, record in enumerate(_field(run, "phases", list, f"{MANIFEST_FILE}: run")):
        at = f"{where}[{i}]"
        target = _field(record, "target", (list, type(None)), at)
        if target is not None and len(target) != 3:
            raise RunDirError(f"{at}: 'target' must be [x, y, theta]")
        constraints = tuple(
            (
                str(_field(c, "region", str, f"{at}.constraints")),
                _choice(c, "side", _SIDES, f"{at}.constraints"),
            )
            for c in _field(record, "constraints", list, at)
        )
        phases.append(
            PhaseRecord(
                name=_field(record, "name", str, at),
                kind=_choice(record, "kind", _KINDS, at),
                target=(
                    None
                    if target is None
                    else (
                        _number(target[0], at),
                        _number(target[1], at),
                        _number(target[2], at),
                    )
                ),
                constraints=constraints,
                near=_near_from(record, at),
                points=_points_from(record, at),
                color=_color_from(record, at),
                targets=_targets_from(record, at),
            )
        )
    return phases


def _targets_from(record: Any, at: str) -> tuple[tuple[int, float, float, float], ...]:
    """A phase's ``targets`` ([sample, x, y, theta] each), absent where none changed."""
    changes = record.get("targets") or []
    if not isinstance(changes, list) or not all(
        isinstance(c, list) and len(c) == 4 and isinstance(c[0], int) for c in changes
    ):
        raise RunDirError(f"{at}: 'targets' must be [[sample, x, y, theta], ...]")
    return tuple(
        (int(c[0]), _number(c[1], at), _number(c[2], at), _number(c[3], at)) for c in changes
    )


def _optional(record: Any, key: str, kind: type, where: str) -> Any:
    """A field older run directories lack: None when absent or null."""
    if not isinstance(record, dict) or record.get(key) is None:
        return None
    return _field(record, key, kind, where)


def _near_from(record: Any, where: str) -> tuple[float, float, float] | None:
    near = _optional(record, "near", list, where)
    if near is None:
        return None
    if len(near) != 3:
        raise RunDirError(f"{where}: 'near' must be [x, y, tolerance]")
    x, y, tolerance = (_number(value, where) for value in near)
    if not (math.isfinite(x) and math.isfinite(y)):
        raise RunDirError(f"{where}: 'near' must be finite")
    return x, y, _positive(tolerance, f"{where}.near")


def _points_from(record: Any, where: str) -> tuple[tuple[float, float], ...]:
    points = _optional(record, "points", list, where) or []
    if not all(isinstance(point, list) and len(point) == 2 for point in points):
        raise RunDirError(f"{where}: 'points' must be a list of [x, y]")
    pairs = tuple((_number(point[0], where), _number(point[1], where)) for point in points)
    if not all(math.isfinite(x) and math.isfinite(y) for x, y in pairs):
        raise RunDirError(f"{where}: 'points' must be finite")
    return pairs


def _color_from(record: Any, where: str) -> str | None:
    color = _optional(record, "color", str, where)
    if color is None:
        return None
    if not is_color(color):
        raise RunDirError(f"{where}: 'color' {_shown(color)} is not a colour")
    return str(color)


def _transitions_from(records: Any) -> list[Transition]:
    if not isinstance(records, list):
        raise RunDirError(f"{TRANSITIONS_FILE}: expected a list of transitions")
    transitions = []
    for i, record in enumerate(records):
        at = f"{TRANSITIONS_FILE}: [{i}]"
        transitions.append(
            Transition(
                time=_number(_field(record, "time", (int, float), at), at),
                from_phase=_field(record, "from", str, at),
                to_phase=_field(record, "to", (str, type(None)), at),
                condition=_field(record, "condition", str, at),
                value=_number(_field(record, "value", (int, float, type(None)), at), at),
                lap=_lap(record, at),
                reaction=_optional_text(record, "reaction", at),
                why=_optional_text(record, "why", at),
            )
        )
    return transitions


def _optional_text(record: Any, key: str, where: str) -> str | None:
    """An optional text of a transition (absent where no reaction fired)."""
    text = record.get(key) if isinstance(record, dict) else None
    if text is not None and not isinstance(text, str):
        raise RunDirError(f"{where}: {key!r} must be a text or null")
    return text


def _lap(record: Any, where: str) -> int | None:
    """The optional lap of a transition (absent in runs without repeats)."""
    lap = record.get("lap") if isinstance(record, dict) else None
    if lap is not None and (isinstance(lap, bool) or not isinstance(lap, int)):
        raise RunDirError(f"{where}: 'lap' must be a whole number or null")
    return lap


def _read_trajectory(path: Path, phase_names: Sequence[str]) -> dict[str, np.ndarray]:
    text = _read_text(path)
    header = csv_rows(text[: text.find("\n") + 1], path.name)
    columns = tuple(header[0] if header else ())
    if columns not in (CSV_COLUMNS, _OLDER_CSV_COLUMNS, (*CSV_COLUMNS, REFERENCE_COLUMN)):
        raise RunDirError(f"{path.name}:1: header must be exactly {','.join(CSV_COLUMNS)}")
    try:
        data = _parse_rows_fast(text, phase_names, columns)
    except ValueError:
        # Find the first bad line and say what is wrong with it.
        data = _parse_rows_checked(text, phase_names, path.name, columns)
    for name in MEASUREMENT_COLUMNS:
        data.setdefault(name, np.full(data["t"].shape[0], np.nan))
    return data


def _parse_rows_fast(
    text: str, phase_names: Sequence[str], columns: Sequence[str]
) -> dict[str, np.ndarray]:
    """numpy's C parser; raises ValueError on anything unexpected."""
    if not text.partition("\n")[2].strip():
        raise ValueError("no samples")  # loadtxt warns on empty input: take the checked path
    phase_column = list(columns).index("phase")
    numeric = [i for i in range(len(columns)) if i != phase_column]
    options: dict[str, Any] = {
        "delimiter": ",",
        "skiprows": 1,
        "quotechar": '"',
        "comments": None,
        "ndmin": 2,
    }
    values = np.loadtxt(io.StringIO(text), usecols=numeric, dtype=np.float64, **options)
    names = np.loadtxt(io.StringIO(text), usecols=[phase_column], dtype=str, **options)[:, 0]
    known, inverse = np.unique(names, return_inverse=True)
    index_of = {name: i for i, name in enumerate(phase_names)}
    if any(name not in index_of for name in known.tolist()):
        raise ValueError("unknown phase")
    data = {columns[i]: values[:, j].copy() for j, i in enumerate(numeric)}
    data["phase"] = np.array([index_of[n] for n in known.tolist()], dtype=np.int64)[inverse]
    iterations = data["phase2_iterations"]
    if not np.all(
        np.isfinite(iterations)
        & (iterations == np.round(iterations))
        & (iterations >= 0)
        & (iterations <= _MAX_ITERATIONS)
    ):
        raise ValueError("phase2_iterations not a count")
    data["phase2_iterations"] = iterations.astype(np.int64)
    if REFERENCE_COLUMN in data:
        references = data[REFERENCE_COLUMN]
        if not np.all((references == np.round(references)) & (references >= 0)):
            raise ValueError("reference not a number of an update")
        data[REFERENCE_COLUMN] = references.astype(np.int64)
    return data


def _parse_rows_checked(
    text: str, phase_names: Sequence[str], filename: str, columns: Sequence[str]
) -> dict[str, np.ndarray]:
    """Row by row, naming the first line that does not fit."""
    rows = csv_rows(text, filename)[1:]
    for line, row in enumerate(rows, start=2):
        if len(row) != len(columns):
            raise RunDirError(
                f"{filename}:{line}: expected {len(columns)} fields, found {len(row)}"
            )
    data: dict[str, np.ndarray] = {}
    cells = list(zip(*rows, strict=True)) if rows else [() for _ in columns]
    index_of = {name: i for i, name in enumerate(phase_names)}
    for name, column in zip(columns, cells, strict=True):
        if name == "phase":
            try:
                data[name] = np.array([index_of[value] for value in column], dtype=np.int64)
            except KeyError as exc:
                line = column.index(exc.args[0]) + 2
                raise RunDirError(
                    f"{filename}:{line}: unknown phase {exc.args[0]!r} "
                    f"({MANIFEST_FILE} lists {', '.join(phase_names)})"
                ) from None
            continue
        dtype = np.int64 if name in ("phase2_iterations", REFERENCE_COLUMN) else np.float64
        try:
            data[name] = np.array(column, dtype=dtype)
            if dtype is np.int64 and not np.all(
                (data[name] >= 0) & (data[name] <= _MAX_ITERATIONS)
            ):
                raise ValueError("out of range")
        except (ValueError, OverflowError):
            line, problem = next(
                (line, problem)
                for line, value in enumerate(column, start=2)
                if (problem := _problem(value, dtype))
            )
            raise RunDirError(f"{filename}:{line}: {name} {problem}") from None
    return data


def _problem(text: str, dtype: type) -> str | None:
    """What is wrong with one CSV cell, or None."""
    if dtype is not np.int64:
        try:
            float(text)
        except ValueError:
            return f"is not a number: {text!r}"
        return None
    if not re.fullmatch(r"\s*[-+]?\d+\s*", text):
        return f"is not an integer: {text!r}"
    if not 0 <= int(text) <= _MAX_ITERATIONS:
        return f"is out of range 0..{_MAX_ITERATIONS}: {text!r}"
    return None


def _bound(bounds: dict[str, Any], state: str) -> tuple[float, float]:
    where = f"{MANIFEST_FILE}: run.error_bounds"
    pair = _field(bounds, state, list, where)
    if len(pair) != 2:
        raise RunDirError(f"{where}: '{state}' must be [lower, upper]")
    return _number(pair[0], where), _number(pair[1], where)


def load_run(run_dir: str | os.PathLike[str]) -> RunResult:
    """Rebuild a run's ``RunResult`` from its directory (``compute_ns`` is not saved: zeros)."""
    directory = Path(run_dir)
    if not directory.is_dir():
        raise RunDirError("not a directory")
    if [entry.name for entry in directory.iterdir()] == [CLAIM_FILE]:
        raise RunDirError(
            f"holds only the claim ({CLAIM_FILE}) of a run that has written nothing yet: "
            "one still running, or one killed before it could (kill -9)"
        )
    manifest = read_json(directory / MANIFEST_FILE)
    run = _field(manifest, "run", dict, MANIFEST_FILE)
    where = f"{MANIFEST_FILE}: run"
    phases = _phases_from(run)
    limits = _field(run, "limits", dict, where)
    bounds = _field(run, "error_bounds", dict, where)
    error_bounds = [_bound(bounds, state) for state in ("x", "y", "theta")]
    transitions = _transitions_from(read_json(directory / TRANSITIONS_FILE))
    summary = read_json(directory / SUMMARY_FILE)
    outcome_text = _field(summary, "outcome", str, SUMMARY_FILE)
    try:
        outcome = Outcome(outcome_text)
    except ValueError:
        raise RunDirError(f"{SUMMARY_FILE}: unknown outcome {outcome_text!r}") from None
    regions = _regions_from(run)
    for phase in phases:
        for region, _ in phase.constraints:
            if region not in regions:
                raise RunDirError(
                    f"{where}.phases: phase {phase.name!r} names region {region!r}, "
                    "which run.regions does not hold"
                )
    data = _read_trajectory(directory / TRAJECTORY_FILE, [p.name for p in phases])
    samples = data["t"].shape[0]
    expected = _field(summary, "samples", int, SUMMARY_FILE)
    if samples != expected:
        raise RunDirError(
            f"{TRAJECTORY_FILE}: {samples} rows, but {SUMMARY_FILE} says {expected} samples "
            "(the file was cut short or changed)"
        )
    _check_columns(data)
    seed = _field(manifest, "seed", int, MANIFEST_FILE)
    return RunResult(
        mission_name=_name(run, "mission_name", MISSION_NAME, where),
        dt=_positive(_field(run, "dt", (int, float), where), f"{where}.dt"),
        seed=int(seed),
        phases=phases,
        t=data["t"],
        x=data["x"],
        y=data["y"],
        theta=data["theta"],
        x_est=data["x_est"],
        y_est=data["y_est"],
        theta_est=data["theta_est"],
        v=data["v"],
        omega=data["omega"],
        phase=data["phase"],
        x_ref=data["x_ref"],
        y_ref=data["y_ref"],
        constraint=data["constraint"],
        phase2_iterations=data["phase2_iterations"],
        compute_ns=np.zeros(samples, dtype=np.int64),
        transitions=transitions,
        outcome=outcome,
        message=_field(summary, "message", str, SUMMARY_FILE),
        limits=(
            _positive(_field(limits, "v", (int, float), f"{where}.limits"), f"{where}.limits.v"),
            _positive(
                _field(limits, "omega", (int, float), f"{where}.limits"), f"{where}.limits.omega"
            ),
        ),
        error_bounds=(error_bounds[0], error_bounds[1], error_bounds[2]),
        regions=regions,
        constraint_margin=_number(run.get("constraint_margin", 0.0), where),
        x_meas=data["x_meas"],
        y_meas=data["y_meas"],
        theta_meas=data["theta_meas"],
        mission=_optional(manifest, "resolved_mission", dict, MANIFEST_FILE),
        reference=data.get(REFERENCE_COLUMN),
        expectations=_checks_from(summary),
    )


def _checks_from(summary: Any) -> list[dict[str, Any]] | None:
    """summary.json's checks, each as Check.read reads it; None where it has none."""
    from wmr_mission.verdicts.check import Check

    records = summary.get("expectations")
    if not isinstance(records, list):
        return None
    try:
        return [Check.read(record).record() | dict(record) for record in records]
    except (KeyError, TypeError, ValueError, AttributeError):
        raise RunDirError(f"{SUMMARY_FILE}: expectations: a check is not one") from None


def _positive(value: float, where: str) -> float:
    if not (math.isfinite(value) and value > 0):
        raise RunDirError(f"{where}: expected a positive number, got {value!r}")
    return float(value)


def _check_columns(data: dict[str, np.ndarray]) -> None:
    """Sample times finite and increasing; iteration counts as a mission allows."""
    t = data["t"]
    bad = np.flatnonzero(~np.isfinite(t))
    if bad.size == 0 and t.size > 1:
        bad = np.flatnonzero(np.diff(t) <= 0) + 1
        if bad.size:
            raise RunDirError(f"{TRAJECTORY_FILE}:{bad[0] + 2}: t does not increase")
    if bad.size:
        raise RunDirError(f"{TRAJECTORY_FILE}:{bad[0] + 2}: t is not a finite number")
