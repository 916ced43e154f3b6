"""The run directory: write a run's files, and read them back for ``wmr-mission plot``.

| file | content |
|---|---|
| ``trajectory.csv`` | one row per sample (``TRAJECTORY_COLUMNS`` then ``EXTRA_COLUMNS``) |
| ``manifest.json`` | mission file and hash, resolved mission, seed, versions, ``run`` |
| ``transitions.json`` | each phase change |
| ``*.png``, ``animation.gif`` | figures (optional) |
| ``summary.json`` | metrics; written last: its presence means the directory is complete |

Every file is written to a temporary file in the same directory, synced, and
renamed over its final name, so an interrupted run never leaves a half-written
file under a final name.

``trajectory.csv``: floats are written as ``%.12g``; a missing value (NaN,
e.g. ``x_ref`` outside track phases) is written ``nan`` and infinities
``inf``/``-inf``, which every CSV reader (numpy, pandas, Python ``float``)
reads back. ``phase`` holds the phase name; lines end with ``\\n``.
"""

from __future__ import annotations

import csv
import io
import json
import math
import os
import platform
import secrets
from collections.abc import Iterator, Mapping, Sequence
from contextlib import contextmanager
from datetime import datetime
from enum import Enum
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np

from wmr_mission.output.metrics import check_expectations, summarize
from wmr_mission.result import (
    EXTRA_COLUMNS,
    MEASUREMENT_COLUMNS,
    TRAJECTORY_COLUMNS,
    Outcome,
    PhaseInfo,
    RunResult,
    Transition,
)

TRAJECTORY_FILE = "trajectory.csv"
MANIFEST_FILE = "manifest.json"
TRANSITIONS_FILE = "transitions.json"
SUMMARY_FILE = "summary.json"
ANIMATION_FILE = "animation.gif"

CSV_COLUMNS = TRAJECTORY_COLUMNS + EXTRA_COLUMNS + MEASUREMENT_COLUMNS
_FLOAT_FORMAT = "%.12g"
# Rows formatted per `%` operation: one C-level formatting call per block keeps
# a 360 000-sample run to about a second and a half.
_ROWS_PER_BLOCK = 20_000
# Packages whose versions decide the numbers of a run.
_VERSIONED_PACKAGES = ("numpy", "scipy", "pydantic", "numba", "matplotlib")


# Messages of both errors leave out the run directory: callers print `RUN_DIR: message`.
class RunDirError(ValueError):
    """A run directory that cannot be read back (missing or corrupt file); one line."""


class RunDirExistsError(FileExistsError):
    """The run directory exists and holds files: a run never overwrites another."""


def default_run_dir(mission_name: str, now: datetime) -> Path:
    """``runs/<mission-name>-<YYYYmmdd-HHMMSS>``."""
    return Path("runs") / f"{mission_name}-{now:%Y%m%d-%H%M%S}"


def prepare_run_dir(path: str | os.PathLike[str]) -> Path:
    """Create the run directory; refuse one that exists and is not empty (before a long run)."""
    run_dir = Path(path)
    if run_dir.exists() and not run_dir.is_dir():
        raise RunDirExistsError("exists and is not a directory; choose another --out")
    run_dir.mkdir(parents=True, exist_ok=True)
    if any(run_dir.iterdir()):
        raise RunDirExistsError(
            "run directory exists and is not empty; "
            "choose another --out or remove it (runs are never overwritten)"
        )
    return run_dir


@contextmanager
def atomic_path(final: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``final``; on success sync it and rename it to ``final``.

    The temporary name keeps ``final``'s suffix so writers that pick a format
    from the file name (images) still do. On failure the temporary file is removed.
    """
    tmp = _new_temporary(final)
    try:
        yield tmp
        with tmp.open("rb+") as written:
            written.flush()
            os.fsync(written.fileno())
        os.replace(tmp, final)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise
    _sync_directory(final.parent)


def _new_temporary(final: Path) -> Path:
    # Not tempfile.mkstemp: its files are private (0600); run files get the usual umask.
    for _ in range(100):
        tmp = final.with_name(f".{final.stem}.{secrets.token_hex(4)}.tmp{final.suffix}")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        return tmp
    raise FileExistsError(f"{final.parent}: cannot create a temporary file")


def _sync_directory(directory: Path) -> None:
    # Makes the rename itself durable; not every platform can open a directory.
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_bytes_atomic(path: Path, data: bytes) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return path


# --- trajectory.csv -------------------------------------------------------


def _csv_field(text: str) -> str:
    # RFC 4180 quoting, only for names that need it.
    if any(c in text for c in ',"\r\n') or text != text.strip():
        return '"' + text.replace('"', '""') + '"'
    return text


def trajectory_csv_blocks(result: RunResult) -> Iterator[str]:
    """``trajectory.csv`` in pieces: the header line, then blocks of lines, so a
    long run is never held in memory as one text."""
    names = np.array([_csv_field(p.name) for p in result.phases] or [""], dtype=object)
    floats = [getattr(result, name) for name in TRAJECTORY_COLUMNS[:-1]]
    extra = [getattr(result, name) for name in EXTRA_COLUMNS[:-1]]
    formats = (
        [_FLOAT_FORMAT] * (len(TRAJECTORY_COLUMNS) - 1)
        + ["%s"]
        + [_FLOAT_FORMAT] * (len(EXTRA_COLUMNS) - 1)
        + ["%d"]
        + [_FLOAT_FORMAT] * len(MEASUREMENT_COLUMNS)
    )
    row_format = ",".join(formats) + "\n"
    yield ",".join(CSV_COLUMNS) + "\n"
    for start in range(0, result.samples, _ROWS_PER_BLOCK):
        block = slice(start, start + _ROWS_PER_BLOCK)
        columns: list[list[Any]] = [
            np.asarray(column[block], dtype=np.float64).tolist() for column in floats
        ]
        columns.append(names[np.asarray(result.phase[block], dtype=np.int64)].tolist())
        columns += [np.asarray(column[block], dtype=np.float64).tolist() for column in extra]
        columns.append(np.asarray(result.phase2_iterations[block], dtype=np.int64).tolist())
        columns += [
            np.asarray(result.measurement_column(i)[block], dtype=np.float64).tolist()
            for i in range(len(MEASUREMENT_COLUMNS))
        ]
        values = tuple(value for row in zip(*columns, strict=True) for value in row)
        yield row_format * (len(values) // len(columns)) % values


def trajectory_csv_text(result: RunResult) -> str:
    """The whole ``trajectory.csv``: header line then one line per sample."""
    return "".join(trajectory_csv_blocks(result))


def write_trajectory(result: RunResult, path: Path) -> Path:
    """Write ``trajectory.csv`` block by block (atomically, like every run file)."""
    with atomic_path(path) as tmp, tmp.open("w", encoding="utf-8", newline="") as out:
        for block in trajectory_csv_blocks(result):
            out.write(block)
    return path


# --- JSON -----------------------------------------------------------------


def jsonable(value: Any) -> Any:
    """Plain JSON data: tuples as lists, numpy scalars as numbers, NaN and infinities as null."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return [jsonable(v) for v in value.tolist()]
    if isinstance(value, Enum):
        return jsonable(value.value)
    if isinstance(value, bool | str) or value is None:
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def json_text(value: Any) -> str:
    return json.dumps(jsonable(value), indent=2, allow_nan=False, ensure_ascii=False) + "\n"


def write_json(path: Path, value: Any) -> Path:
    return write_bytes_atomic(path, json_text(value).encode("utf-8"))


def transitions_record(transitions: Sequence[Transition]) -> list[dict[str, Any]]:
    """One record per phase change; ``lap`` only where the phase entered is in a repeat."""
    return [
        {
            "time": tr.time,
            "from": tr.from_phase,
            "to": tr.to_phase,
            "condition": tr.condition,
            "value": tr.value,
            **({} if tr.lap is None else {"lap": tr.lap}),
        }
        for tr in transitions
    ]


def package_versions() -> dict[str, str | None]:
    """Versions of Python and of the packages that decide a run's numbers (null: not installed)."""
    from wmr_mission import __version__

    versions: dict[str, str | None] = {
        "python": platform.python_version(),
        "wmr-mission": __version__,
    }
    for package in _VERSIONED_PACKAGES:
        try:
            versions[package] = metadata.version(package)
        except metadata.PackageNotFoundError:
            versions[package] = None
    return versions


def run_record(result: RunResult) -> dict[str, Any]:
    """What ``load_run`` needs besides the CSV, transitions and summary."""
    return {
        "mission_name": result.mission_name,
        "dt": result.dt,
        "phases": [
            {
                "name": phase.name,
                "kind": phase.kind,
                "target": list(phase.target) if phase.target is not None else None,
                "constraints": [
                    {"region": region, "side": side} for region, side in phase.constraints
                ],
            }
            for phase in result.phases
        ],
        "limits": {"v": result.limits[0], "omega": result.limits[1]},
        "error_bounds": {
            state: list(bound)
            for state, bound in zip(("x", "y", "theta"), result.error_bounds, strict=True)
        },
        "regions": result.regions,
    }


def manifest_record(
    result: RunResult,
    *,
    mission_sha256: str,
    resolved_mission: Mapping[str, Any],
    mission_file: str,
) -> dict[str, Any]:
    return {
        "mission_file": mission_file,
        "mission_sha256": mission_sha256,
        "resolved_mission": resolved_mission,
        "seed": result.seed,
        "versions": package_versions(),
        "run": run_record(result),
    }


def write_run(
    result: RunResult,
    out_dir: str | os.PathLike[str],
    *,
    mission_sha256: str,
    resolved_mission: Mapping[str, Any],
    mission_file: str,
    plots: bool,
    animate: bool,
) -> list[Path]:
    """Write the run directory (made by ``prepare_run_dir``); return the files written.

    ``summary.json`` comes last, so its presence marks a complete directory.
    When ``resolved_mission`` has an ``expect`` section, the summary also lists
    each expectation and whether it was met.
    """
    run_dir = Path(out_dir)
    run_dir.mkdir(parents=True, exist_ok=True)
    written = [
        write_trajectory(result, run_dir / TRAJECTORY_FILE),
        write_json(
            run_dir / MANIFEST_FILE,
            manifest_record(
                result,
                mission_sha256=mission_sha256,
                resolved_mission=resolved_mission,
                mission_file=mission_file,
            ),
        ),
        write_json(run_dir / TRANSITIONS_FILE, transitions_record(result.transitions)),
    ]
    if plots:
        from wmr_mission.output.plots import draw_all

        written += draw_all(result, run_dir)
    if animate:
        from wmr_mission.output.animation import write_animation

        written.append(write_animation(result, run_dir / ANIMATION_FILE))
    summary = summarize(result)
    expect = resolved_mission.get("expect")
    if isinstance(expect, Mapping):
        summary["expectations"] = check_expectations(summary, dict(expect))
    written.append(write_json(run_dir / SUMMARY_FILE, summary))
    return written


# --- reading back ---------------------------------------------------------


def _read_text(path: Path) -> str:
    if not path.is_file():
        raise RunDirError(f"{path.name} is missing (not a run directory, or an interrupted run)")
    try:
        return path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise RunDirError(f"{path.name}: cannot be read: {exc}") from None


def _read_json(path: Path) -> Any:
    text = _read_text(path)
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise RunDirError(
            f"{path.name}:{exc.lineno}:{exc.colno}: not valid JSON: {exc.msg}"
        ) from None


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


def _phases_from(run: Any) -> list[PhaseInfo]:
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
                str(_field(c, "side", str, f"{at}.constraints")),
            )
            for c in _field(record, "constraints", list, at)
        )
        phases.append(
            PhaseInfo(
                name=_field(record, "name", str, at),
                kind=_field(record, "kind", str, at),
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
            )
        )
    return phases


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
            )
        )
    return transitions


def _lap(record: Any, where: str) -> int | None:
    """The optional lap of a transition (absent in runs without repeats)."""
    lap = record.get("lap") if isinstance(record, dict) else None
    if lap is not None and (isinstance(lap, bool) or not isinstance(lap, int)):
        raise RunDirError(f"{where}: 'lap' must be a whole number or null")
    return lap


def _read_trajectory(path: Path, phase_names: Sequence[str]) -> dict[str, np.ndarray]:
    text = _read_text(path)
    header = next(csv.reader(io.StringIO(text[: text.find("\n") + 1], newline="")), None)
    if header is None or tuple(header) != CSV_COLUMNS:
        raise RunDirError(f"{path.name}:1: header must be exactly {','.join(CSV_COLUMNS)}")
    try:
        return _parse_rows_fast(text, phase_names)
    except ValueError:
        # Find the first bad line and say what is wrong with it.
        return _parse_rows_checked(text, phase_names, path.name)


def _parse_rows_fast(text: str, phase_names: Sequence[str]) -> dict[str, np.ndarray]:
    """numpy's C parser; raises ValueError on anything unexpected."""
    if not text.partition("\n")[2].strip():
        raise ValueError("no samples")  # loadtxt warns on empty input: take the checked path
    phase_column = CSV_COLUMNS.index("phase")
    numeric = [i for i in range(len(CSV_COLUMNS)) if i != phase_column]
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
    data = {CSV_COLUMNS[i]: values[:, j].copy() for j, i in enumerate(numeric)}
    data["phase"] = np.array([index_of[n] for n in known.tolist()], dtype=np.int64)[inverse]
    iterations = data["phase2_iterations"]
    if not np.all(np.isfinite(iterations) & (iterations == np.round(iterations))):
        raise ValueError("phase2_iterations not integral")
    data["phase2_iterations"] = iterations.astype(np.int64)
    return data


def _parse_rows_checked(
    text: str, phase_names: Sequence[str], filename: str
) -> dict[str, np.ndarray]:
    """Row by row, naming the first line that does not fit."""
    rows = list(csv.reader(io.StringIO(text, newline="")))[1:]
    for line, row in enumerate(rows, start=2):
        if len(row) != len(CSV_COLUMNS):
            raise RunDirError(
                f"{filename}:{line}: expected {len(CSV_COLUMNS)} fields, found {len(row)}"
            )
    data: dict[str, np.ndarray] = {}
    cells = list(zip(*rows, strict=True)) if rows else [() for _ in CSV_COLUMNS]
    index_of = {name: i for i, name in enumerate(phase_names)}
    for name, column in zip(CSV_COLUMNS, cells, strict=True):
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
        dtype = np.int64 if name == "phase2_iterations" else np.float64
        try:
            data[name] = np.array(column, dtype=dtype)
        except ValueError:
            line, bad = next(
                (line, value)
                for line, value in enumerate(column, start=2)
                if not _parses(value, dtype)
            )
            kind = "an integer" if dtype is np.int64 else "a number"
            raise RunDirError(f"{filename}:{line}: {name} is not {kind}: {bad!r}") from None
    return data


def _parses(text: str, dtype: type) -> bool:
    try:
        np.array([text], dtype=dtype)
    except ValueError:
        return False
    return True


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
    manifest = _read_json(directory / MANIFEST_FILE)
    run = _field(manifest, "run", dict, MANIFEST_FILE)
    where = f"{MANIFEST_FILE}: run"
    phases = _phases_from(run)
    limits = _field(run, "limits", dict, where)
    bounds = _field(run, "error_bounds", dict, where)
    error_bounds = [_bound(bounds, state) for state in ("x", "y", "theta")]
    transitions = _transitions_from(_read_json(directory / TRANSITIONS_FILE))
    summary = _read_json(directory / SUMMARY_FILE)
    outcome_text = _field(summary, "outcome", str, SUMMARY_FILE)
    try:
        outcome = Outcome(outcome_text)
    except ValueError:
        raise RunDirError(f"{SUMMARY_FILE}: unknown outcome {outcome_text!r}") from None
    data = _read_trajectory(directory / TRAJECTORY_FILE, [p.name for p in phases])
    samples = data["t"].shape[0]
    seed = _field(manifest, "seed", int, MANIFEST_FILE)
    return RunResult(
        mission_name=_field(run, "mission_name", str, where),
        dt=_number(_field(run, "dt", (int, float), where), where),
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
            _number(_field(limits, "v", (int, float), f"{where}.limits"), where),
            _number(_field(limits, "omega", (int, float), f"{where}.limits"), where),
        ),
        error_bounds=(error_bounds[0], error_bounds[1], error_bounds[2]),
        regions=_field(run, "regions", dict, where),
        measurement=np.column_stack([data[name] for name in MEASUREMENT_COLUMNS]),
    )
