"""``wmr-mission export DIR --format mcap|mcap-json|parquet``: the data in the formats
robotics and data tools read (``pip install 'wmr-mission[export]'``).

``mcap`` (a run directory): ROS 2 messages in CDR, ``review/ros2_messages.py``.

``mcap-json`` (a run directory; Foxglove opens it): JSON messages whose schemas
Foxglove knows by name, log time ``round(t * 1e9)`` ns from the samples' ``t``,
frame ``world``:

| topic | schema | content |
|---|---|---|
| ``/pose`` | ``foxglove.PoseInFrame`` | true pose ``x, y, theta`` (heading: quaternion about z) |
| ``/estimate`` | ``foxglove.PoseInFrame`` | ``x_est, y_est, theta_est`` |
| ``/reference`` | ``foxglove.PoseInFrame`` | ``x_ref, y_ref`` in track phases, no heading |
| ``/measurement`` | ``foxglove.PoseInFrame`` | ``x_meas, y_meas`` (``theta_meas``) where measured |
| ``/regions`` | ``foxglove.SceneUpdate`` | each region's outline and name, at the first sample |
| ``/sample`` | ``wmr.Sample`` | every column of ``trajectory.csv`` by name |
| ``/transitions`` | ``wmr.Transition`` | each phase change, at its time |
| ``/summary`` | ``wmr.Summary`` | ``summary.json``, at the last sample |

A pose that is not finite is left out of its topic; ``/sample`` holds every
row: NaN as ``null``, infinities as the strings ``"inf"`` and ``"-inf"``,
every other number as the shortest text that reads back to the same float.

Parquet: ``trajectory.csv`` of a run (``phase`` a dictionary of the phase
names, ``phase2_iterations`` int64, the rest float64) or ``runs.csv`` of a
campaign (the types of ``CampaignDir.column_types``), the same columns in the
same order.
"""

from __future__ import annotations

import importlib
import json
import math
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from types import ModuleType
from typing import IO, TYPE_CHECKING, Any, Final

import numpy as np

from wmr_mission.basics import FloatArray
from wmr_mission.output.files import atomic_path
from wmr_mission.output.reader import RunDirError, read_json
from wmr_mission.output.rundir import (
    SUMMARY_FILE,
    TRAJECTORY_FILE,
)
from wmr_mission.record import CSV_COLUMNS, REFERENCE_COLUMN, csv_columns
from wmr_mission.review.ros2_messages import STAMP_LIMIT, write_ros2_mcap

if TYPE_CHECKING:
    from wmr_mission.campaign.reader import CampaignDir
    from wmr_mission.output.result import RunResult

__all__ = ["MissingExtra", "export_command", "write_mcap", "write_run_parquet"]

EXTRA: Final = "pip install 'wmr-mission[export]'"
FRAME: Final = "world"
DEFAULT_NAMES: Final = {
    ("run", "mcap"): "run.mcap",
    ("run", "mcap-json"): "run.json.mcap",
    ("run", "parquet"): "trajectory.parquet",
    ("campaign", "parquet"): "runs.parquet",
}


class MissingExtra(Exception):
    """The export's optional package is not installed; one line saying what to install."""


# The module each format needs, and the package that installs it.
_NEEDS: Final = {
    "mcap": ("mcap.writer", "mcap"),
    "mcap-json": ("mcap.writer", "mcap"),
    "parquet": ("pyarrow.parquet", "pyarrow"),
}


def _require(fmt: str) -> ModuleType:
    module, package = _NEEDS[fmt]
    try:
        return importlib.import_module(module)
    except ImportError:
        raise MissingExtra(f"--format {fmt} needs the {package} package: {EXTRA}") from None


# --- MCAP ---------------------------------------------------------------------

# Foxglove's JSON schemas, trimmed to the fields written (Foxglove knows a
# schema by its name); each object lists every field its upstream schema requires.
_TIME = {
    "type": "object",
    "properties": {"sec": {"type": "integer", "minimum": 0}, "nsec": {"type": "integer"}},
}
_VECTOR3 = {"type": "object", "properties": {k: {"type": "number"} for k in "xyz"}}
_QUATERNION = {"type": "object", "properties": {k: {"type": "number"} for k in "xyzw"}}
_POSE = {"type": "object", "properties": {"position": _VECTOR3, "orientation": _QUATERNION}}
_COLOR = {"type": "object", "properties": {k: {"type": "number"} for k in "rgba"}}
_ARRAY = {"type": "array", "items": {"type": "object"}}
POSE_IN_FRAME: Final = {
    "title": "foxglove.PoseInFrame",
    "type": "object",
    "properties": {"timestamp": _TIME, "frame_id": {"type": "string"}, "pose": _POSE},
}
_LINE = {
    "type": "object",
    "properties": {
        "type": {"type": "integer", "description": "0 LINE_STRIP, 1 LINE_LOOP, 2 LINE_LIST"},
        "pose": _POSE,
        "thickness": {"type": "number"},
        "scale_invariant": {"type": "boolean"},
        "points": {"type": "array", "items": _VECTOR3},
        "color": _COLOR,
        "colors": {"type": "array", "items": _COLOR},
        "indices": {"type": "array", "items": {"type": "integer"}},
    },
}
_TEXT = {
    "type": "object",
    "properties": {
        "pose": _POSE,
        "billboard": {"type": "boolean"},
        "font_size": {"type": "number"},
        "scale_invariant": {"type": "boolean"},
        "color": _COLOR,
        "text": {"type": "string"},
    },
}
SCENE_UPDATE: Final = {
    "title": "foxglove.SceneUpdate",
    "type": "object",
    "properties": {
        "deletions": _ARRAY,
        "entities": {
            "type": "array",
            "items": {
                "type": "object",
                "properties": {
                    "timestamp": _TIME,
                    "frame_id": {"type": "string"},
                    "id": {"type": "string"},
                    "lifetime": _TIME,
                    "frame_locked": {"type": "boolean"},
                    "metadata": _ARRAY,
                    **dict.fromkeys(("arrows", "cubes", "spheres", "cylinders"), _ARRAY),
                    "lines": {"type": "array", "items": _LINE},
                    "triangles": _ARRAY,
                    "texts": {"type": "array", "items": _TEXT},
                    "models": _ARRAY,
                },
            },
        },
    },
}
_NUMBER_OR_NULL = {"type": ["number", "null", "string"], "description": "null: nan; 'inf', '-inf'"}
SAMPLE: Final = {
    "title": "wmr.Sample",
    "description": "One row of trajectory.csv (units: docs/run-directory.md).",
    "type": "object",
    "properties": {
        name: (
            {"type": "string"}
            if name == "phase"
            else {"type": "integer"}
            if name in ("phase2_iterations", REFERENCE_COLUMN)
            else _NUMBER_OR_NULL
        )
        # the reference in force, where a run has updates (csv_columns)
        for name in (*CSV_COLUMNS, REFERENCE_COLUMN)
    },
}
TRANSITION: Final = {
    "title": "wmr.Transition",
    "description": "One entry of transitions.json.",
    "type": "object",
    "properties": {
        "time": {"type": "number"},
        "from": {"type": "string"},
        "to": {"type": ["string", "null"]},
        "condition": {"type": "string"},
        "value": {"type": ["number", "null"]},
        "lap": {"type": ["integer", "null"]},
        "reaction": {"type": ["string", "null"]},
        "why": {"type": ["string", "null"]},
    },
}
SUMMARY: Final = {
    "title": "wmr.Summary",
    "description": "summary.json of the run (docs/run-directory.md).",
    "type": "object",
}
_SIDE_COLORS = {
    "outside": {"r": 0.70, "g": 0.15, "b": 0.12, "a": 1.0},
    "inside": {"r": 0.23, "g": 0.44, "b": 0.71, "a": 1.0},
    None: {"r": 0.45, "g": 0.45, "b": 0.45, "a": 1.0},
}
_IDENTITY = {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}


def nanoseconds(t: float) -> int:
    return round(t * 1e9)


def stamp(t: float) -> dict[str, int]:
    sec, nsec = divmod(nanoseconds(t), 1_000_000_000)
    return {"sec": sec, "nsec": nsec}


def _json_number(value: float) -> float | str | None:
    if math.isfinite(value):
        return value
    return None if math.isnan(value) else ("inf" if value > 0 else "-inf")


# The poses: one text template, filled per sample (json.dumps of a nested dict
# per message costs several times more on a long run). repr() of a finite float
# is valid JSON and reads back to the same float.
_POSE_TEXT = (
    '{"timestamp":{"sec":%d,"nsec":%d},"frame_id":"' + FRAME + '","pose":{"position":'
    '{"x":%r,"y":%r,"z":0.0},"orientation":{"x":0.0,"y":0.0,"z":%r,"w":%r}}}'
)


def _pose_messages(
    t: np.ndarray, x: np.ndarray, y: np.ndarray, theta: np.ndarray | None
) -> Iterator[tuple[int, bytes]]:
    """(log time, PoseInFrame JSON) of each sample whose position (and heading) is finite."""
    if theta is None:
        qz, qw = np.zeros_like(t), np.ones_like(t)
    else:
        qz, qw = np.sin(0.5 * theta), np.cos(0.5 * theta)
    finite = np.isfinite(x) & np.isfinite(y) & np.isfinite(qz) & np.isfinite(qw)
    for k in np.flatnonzero(finite).tolist():
        ns = nanoseconds(float(t[k]))
        sec, nsec = divmod(ns, 1_000_000_000)
        text = _POSE_TEXT % (sec, nsec, float(x[k]), float(y[k]), float(qz[k]), float(qw[k]))
        yield ns, text.encode()


def _sample_messages(result: RunResult) -> Iterator[tuple[int, bytes]]:
    """One message a row of trajectory.csv, every column of it by name."""
    names = [p.name for p in result.phases]
    written = csv_columns(result)
    whole = ("phase2_iterations", REFERENCE_COLUMN)  # integers as they are
    columns = {
        name: np.asarray(getattr(result, name)).tolist() for name in written if name != "phase"
    }
    phase = np.asarray(result.phase).tolist()
    encode = json.JSONEncoder(allow_nan=False, separators=(",", ":")).encode
    for k, t in enumerate(columns["t"]):
        row: dict[str, Any] = {}
        for name in written:
            if name == "phase":
                row[name] = names[phase[k]]
            elif name in whole:
                row[name] = columns[name][k]
            else:
                row[name] = _json_number(columns[name][k])
        yield nanoseconds(t), encode(row).encode()


def _region_entities(result: RunResult, t0: float) -> dict[str, Any]:
    from pydantic import TypeAdapter

    from wmr_mission.geometry.regions import RegionSpec, region_outline
    from wmr_mission.output.figures import view_box

    sides: dict[str, str] = {}
    for phase in result.phases:
        for region, side in phase.constraints:
            sides.setdefault(region, side)
    box = view_box(result)
    adapter: TypeAdapter[Any] = TypeAdapter(RegionSpec)
    entities = []
    pose = {"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": _IDENTITY}
    for name, record in result.regions.items():
        spec = adapter.validate_python(record)
        xs, ys = region_outline(spec, extent=box)
        closed = spec.type != "half-plane"
        if closed and xs.size > 1 and np.hypot(xs[-1] - xs[0], ys[-1] - ys[0]) < 1e-9:
            xs, ys = xs[:-1], ys[:-1]  # a LINE_LOOP closes itself
        color = _SIDE_COLORS[sides.get(name)]
        points = [{"x": float(a), "y": float(b), "z": 0.0} for a, b in zip(xs, ys, strict=True)]
        label_at = (
            {"x": float(np.mean(xs)), "y": float(np.mean(ys)), "z": 0.0}
            if points
            else {"x": 0.0, "y": 0.0, "z": 0.0}
        )
        entities.append(
            {
                "timestamp": stamp(t0),
                "frame_id": FRAME,
                "id": f"region/{name}",
                "lifetime": {"sec": 0, "nsec": 0},
                "frame_locked": False,
                "metadata": [
                    {"key": "type", "value": spec.type},
                    {"key": "constraint", "value": sides.get(name) or "none"},
                ],
                "arrows": [],
                "cubes": [],
                "spheres": [],
                "cylinders": [],
                "lines": [
                    {
                        "type": 1 if closed else 0,
                        "pose": pose,
                        "thickness": 2.0,
                        "scale_invariant": True,
                        "points": points,
                        "color": color,
                        "colors": [],
                        "indices": [],
                    }
                ],
                "triangles": [],
                "texts": [
                    {
                        "pose": {"position": label_at, "orientation": _IDENTITY},
                        "billboard": True,
                        "font_size": 14.0,
                        "scale_invariant": True,
                        "color": color,
                        "text": name,
                    }
                ],
                "models": [],
            }
        )
    return {"deletions": [], "entities": entities}


def write_mcap(result: RunResult, summary: Any, stream: IO[bytes]) -> None:
    """The run as MCAP with Foxglove schemas (JSON encoding) into ``stream``."""
    from mcap.writer import CompressionType, Writer

    writer = Writer(stream, compression=CompressionType.ZSTD)
    writer.start(profile="", library="wmr-mission")
    schemas: dict[str, int] = {}
    channels: dict[str, int] = {}
    for topic, schema in (
        ("/pose", POSE_IN_FRAME),
        ("/estimate", POSE_IN_FRAME),
        ("/reference", POSE_IN_FRAME),
        ("/measurement", POSE_IN_FRAME),
        ("/regions", SCENE_UPDATE),
        ("/sample", SAMPLE),
        ("/transitions", TRANSITION),
        ("/summary", SUMMARY),
    ):
        name = str(schema["title"])
        if name not in schemas:
            schemas[name] = writer.register_schema(
                name=name, encoding="jsonschema", data=json.dumps(schema).encode()
            )
        channels[topic] = writer.register_channel(
            topic=topic, message_encoding="json", schema_id=schemas[name]
        )

    def put(topic: str, messages: Iterator[tuple[int, bytes]]) -> None:
        channel = channels[topic]
        for sequence, (ns, data) in enumerate(messages):
            writer.add_message(
                channel_id=channel, log_time=ns, publish_time=ns, data=data, sequence=sequence
            )

    r = result
    t0 = float(r.t[0]) if r.samples else 0.0
    t_end = float(r.t[-1]) if r.samples else 0.0
    regions = json.dumps(_region_entities(r, t0), allow_nan=False).encode()
    put("/regions", iter([(nanoseconds(t0), regions)]))
    put("/pose", _pose_messages(r.t, r.x, r.y, r.theta))
    put("/estimate", _pose_messages(r.t, r.x_est, r.y_est, r.theta_est))
    put("/reference", _pose_messages(r.t, r.x_ref, r.y_ref, None))
    measured_theta = np.where(np.isfinite(r.theta_meas), r.theta_meas, 0.0)
    put("/measurement", _pose_messages(r.t, r.x_meas, r.y_meas, measured_theta))
    put("/sample", _sample_messages(r))
    put(
        "/transitions",
        (
            (
                nanoseconds(change.time),
                json.dumps(change.fields(), allow_nan=False).encode(),
            )
            for change in r.transitions
        ),
    )
    put("/summary", iter([(nanoseconds(t_end), json.dumps(summary, allow_nan=False).encode())]))
    writer.finish()  # type: ignore[no-untyped-call]


# --- Parquet ------------------------------------------------------------------


def _csv_header(path: Path) -> list[str]:
    with path.open(encoding="utf-8", newline="") as stream:
        return stream.readline().rstrip("\n").split(",")


def run_table(result: RunResult, columns: list[str]) -> Any:
    """trajectory.csv as a pyarrow table: the same columns, phase a dictionary."""
    import pyarrow as pa

    from wmr_mission.version import __version__

    arrays = []
    for name in columns:
        if name == "phase":
            indices = pa.array(np.asarray(result.phase, dtype=np.int32))
            names = pa.array([p.name for p in result.phases], pa.string())
            arrays.append(pa.DictionaryArray.from_arrays(indices, names))
        elif name == "phase2_iterations":
            arrays.append(pa.array(np.asarray(result.phase2_iterations, dtype=np.int64)))
        else:
            arrays.append(pa.array(np.asarray(getattr(result, name), dtype=np.float64)))
    table = pa.Table.from_arrays(arrays, names=columns)
    return table.replace_schema_metadata(
        {
            "wmr_mission.source": TRAJECTORY_FILE,
            "wmr_mission.mission": result.mission_name,
            "wmr_mission.seed": str(result.seed),
            "wmr_mission.version": __version__,
        }
    )


def campaign_table(campaign: CampaignDir) -> Any:
    """runs.csv as a pyarrow table: the same columns, typed by ``column_types``."""
    import pyarrow as pa

    from wmr_mission.campaign.reader import cell_value
    from wmr_mission.version import __version__

    kinds = {
        "int64": pa.int64(),
        "float64": pa.float64(),
        "bool": pa.bool_(),
        "string": pa.string(),
    }
    types = campaign.column_types()
    arrays = []
    for j, name in enumerate(campaign.columns):
        kind = types[name]
        values = [cell_value(row[j], kind) for row in campaign.rows]
        arrays.append(pa.array(values, kinds[kind]))
    table = pa.Table.from_arrays(arrays, names=campaign.columns)
    return table.replace_schema_metadata(
        {
            "wmr_mission.source": "runs.csv",
            "wmr_mission.campaign": str(campaign.summary.get("campaign", "")),
            "wmr_mission.version": __version__,
        }
    )


def write_run_parquet(result: RunResult, columns: list[str], path: Path) -> None:
    import pyarrow.parquet as pq

    pq.write_table(run_table(result, columns), str(path), compression="zstd")


# --- the command --------------------------------------------------------------


def _writer(directory: Path, fmt: str, campaign: bool) -> Callable[[Path], None]:
    """Read and check DIR, and return what writes the export to a path."""
    if campaign:
        from wmr_mission.campaign.reader import load_campaign_dir

        _require(fmt)
        table = campaign_table(load_campaign_dir(directory))

        def write_campaign(path: Path) -> None:
            import pyarrow.parquet as pq

            pq.write_table(table, str(path), compression="zstd")

        return write_campaign

    from wmr_mission.output.reader import load_run

    _require(fmt)
    result = load_run(directory)
    if fmt in ("mcap", "mcap-json"):
        _check_log_times(result.t, fmt)
        # Numbers that are not finite as null, as the product writes them: JSON has none.
        summary = read_json(directory / SUMMARY_FILE, finite=True)
        write = write_ros2_mcap if fmt == "mcap" else write_mcap

        def write_run_mcap(path: Path) -> None:
            with path.open("wb") as stream:
                write(result, summary, stream)

        return write_run_mcap
    columns = _csv_header(directory / TRAJECTORY_FILE)
    return lambda path: write_run_parquet(result, columns, path)


# [s] MCAP log times are unsigned 64-bit nanoseconds (nanoseconds()); a ROS 2
# stamp holds its seconds in an int32 (builtin_interfaces/Time).
LAST_LOG_TIME = (2**64 - 1) / 1e9


def _check_log_times(t: FloatArray, fmt: str) -> None:
    """Every t a log time of the format, else the first that is not, at its line."""
    last = STAMP_LIMIT if fmt == "mcap" else LAST_LOG_TIME
    with np.errstate(invalid="ignore"):
        wrong = np.flatnonzero(~((t >= 0.0) & (t < last)))  # NaN too
    if wrong.size:
        row = int(wrong[0])
        what = (
            f"a ROS 2 stamp (0 to {STAMP_LIMIT} s); --format mcap-json takes up to "
            f"{LAST_LOG_TIME:.4g} s"
            if fmt == "mcap"
            else f"an MCAP log time (0 to {LAST_LOG_TIME:.4g} s)"
        )
        raise RunDirError(f"{TRAJECTORY_FILE}:{row + 2}: t = {float(t[row]):g} s is not {what}")


def export_command(directory: Path, fmt: str, out: Path | None = None) -> int:
    """``wmr-mission export DIR --format mcap|parquet [--out PATH]``; print the path.

    Exit code: 0 written; 1 the directory's files are damaged (as ``plot``);
    2 a usage error: not a run or campaign directory, MCAP asked of a campaign,
    the extra not installed, PATH a file of a record, in another record's
    directory or a file already that is not an earlier export of the format
    (wmr_mission.review.record), or the file cannot be written."""
    from wmr_mission.campaign.reader import is_campaign_dir
    from wmr_mission.review.record import record_file_refusal, written_at

    campaign = is_campaign_dir(directory)
    if not campaign and not (directory / TRAJECTORY_FILE).is_file():
        print(
            f"{directory}: neither a run directory (no {TRAJECTORY_FILE}) "
            "nor a campaign directory (no runs.csv, campaign.json)",
            file=sys.stderr,
        )
        return 2
    kind = "campaign" if campaign else "run"
    if (kind, fmt) not in DEFAULT_NAMES:
        print(
            f"{directory}: a campaign directory exports as parquet (its runs.csv); "
            "for MCAP, export one of its runs (worst/RUN)",
            file=sys.stderr,
        )
        return 2
    target = out if out is not None else directory / DEFAULT_NAMES[kind, fmt]
    refusal = record_file_refusal(target, directory, DEFAULT_NAMES[kind, fmt])
    if refusal is not None:
        print(refusal, file=sys.stderr)
        return 2
    try:
        write = _writer(directory, fmt, campaign)
    except MissingExtra as error:
        print(error, file=sys.stderr)
        return 2
    except (RunDirError, OSError) as error:
        print(f"{directory}: {error}", file=sys.stderr)
        return 1
    try:
        with atomic_path(written_at(target)) as tmp:
            write(tmp)
    except OSError as error:
        print(f"{target}: cannot write: {error.strerror or error}", file=sys.stderr)
        return 2
    except Exception as error:  # a fault in the export: one line, never a traceback
        print(
            f"{directory}: cannot export ({type(error).__name__}: {error}); "
            "the data are unchanged; please report it",
            file=sys.stderr,
        )
        return 1
    print(target)
    return 0
