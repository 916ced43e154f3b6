"""A run as ROS 2 messages in MCAP: CDR under ``ros2msg`` schemas, the form
``ros2 bag info``, ``ros2 bag play`` and Foxglove's ROS 2 panels read
(``wmr-mission export RUN_DIR --format mcap``).

- ``/odom``, ``nav_msgs/msg/Odometry``: the true pose; the twist applied (``v``,
  ``omega``);
- ``/estimate``, ``nav_msgs/msg/Odometry``: ``x_est, y_est, theta_est``; the same twist;
- ``/cmd_vel``, ``geometry_msgs/msg/Twist``: ``v``, ``omega`` of each sample;
- ``/measurement``, ``geometry_msgs/msg/PoseStamped``: ``x_meas, y_meas``
  (``theta_meas``) where measured;
- ``/reference``, ``nav_msgs/msg/Path``: the reference in force, at the first sample
  of each phase that has one: its points, each stamped with its sample's time;
- ``/transitions``, ``std_msgs/msg/String``: each entry of ``transitions.json`` as
  JSON, at its time;
- ``/summary``, ``std_msgs/msg/String``: ``summary.json``, at the last sample.

Frames: ``world`` (the mission's plane) and ``base_link`` (the robot). A
sample whose pose is not finite is left out of its topic, as in the JSON form.
"""

from __future__ import annotations

import json
import re
import struct
from collections.abc import Iterator
from typing import IO, TYPE_CHECKING, Any, Final

import numpy as np

if TYPE_CHECKING:
    from wmr_mission.output.result import RunResult

__all__ = ["DEFINITIONS", "STAMP_LIMIT", "message_definition", "write_ros2_mcap"]

WORLD: Final = "world"
ROBOT: Final = "base_link"
# builtin_interfaces/Time holds its seconds in an int32.
STAMP_LIMIT: Final = 2**31
# A Path message holds at most this many poses: a long phase's reference is
# thinned evenly, its last point always kept (a 1-hour phase at 100 Hz would
# otherwise be one 20 MB message).
PATH_POSES: Final = 2000

# The ROS 2 interface definitions written, as the ROS 2 packages ship them
# (comments and blank lines left out); tests/test_export_ros2.py compares them
# with the installed packages' .msg files.
DEFINITIONS: Final = {
    "builtin_interfaces/Time": "int32 sec\nuint32 nanosec",
    "std_msgs/Header": "builtin_interfaces/Time stamp\nstring frame_id",
    "std_msgs/String": "string data",
    "geometry_msgs/Point": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/Vector3": "float64 x\nfloat64 y\nfloat64 z",
    "geometry_msgs/Quaternion": "float64 x 0\nfloat64 y 0\nfloat64 z 0\nfloat64 w 1",
    "geometry_msgs/Pose": "Point position\nQuaternion orientation",
    "geometry_msgs/PoseStamped": "std_msgs/Header header\nPose pose",
    "geometry_msgs/PoseWithCovariance": "Pose pose\nfloat64[36] covariance",
    "geometry_msgs/Twist": "Vector3  linear\nVector3  angular",
    "geometry_msgs/TwistWithCovariance": "Twist twist\nfloat64[36] covariance",
    "nav_msgs/Odometry": (
        "std_msgs/Header header\nstring child_frame_id\n"
        "geometry_msgs/PoseWithCovariance pose\ngeometry_msgs/TwistWithCovariance twist"
    ),
    "nav_msgs/Path": "std_msgs/Header header\ngeometry_msgs/PoseStamped[] poses",
}
_PRIMITIVES: Final = frozenset(
    {
        *("bool", "byte", "char", "string", "wstring"),
        *("float32", "float64", "int8", "uint8", "int16", "uint16"),
        *("int32", "uint32", "int64", "uint64"),
    }
)
_SEPARATOR: Final = "=" * 80


def _dependencies(name: str) -> list[str]:
    """The types a definition uses, fully named, in order of first use."""
    package = name.split("/")[0]
    found: list[str] = []
    for line in DEFINITIONS[name].splitlines():
        kind = re.sub(r"\[.*\]$", "", line.split()[0])
        if kind in _PRIMITIVES or re.match(r"^(w?string)<=", kind):
            continue
        full = kind if "/" in kind else f"{package}/{kind}"
        if full not in found:
            found.append(full)
    return found


def message_definition(name: str) -> str:
    """``name``'s concatenated ``ros2msg`` definition: its own text, then each type it
    uses (depth first, once) after a separator and ``MSG: pkg/Type``, as rosbag2 writes it."""
    order: list[str] = []
    pending = list(reversed(_dependencies(name)))
    while pending:  # depth first, without recursion
        kind = pending.pop()
        if kind in order:
            continue
        order.append(kind)
        pending.extend(reversed([k for k in _dependencies(kind) if k not in order]))
    parts = [DEFINITIONS[name]]
    parts += [f"{_SEPARATOR}\nMSG: {kind}\n{DEFINITIONS[kind]}" for kind in order]
    return "\n".join(parts) + "\n"


def _schema_name(kind: str) -> str:
    package, message = kind.split("/")
    return f"{package}/msg/{message}"


# --- CDR, written here ----------------------------------------------------------
# mcap-ros2-support encodes a message from a dict in about 56 us: 20 s of CPU
# for the odometry of a 1-hour run, against 2.5 s here (`python
# benchmarks/looking.py --exports-only`). Odometry, Twist and PoseStamped have a fixed layout here
# (their strings are the constant frame names), so all of a run's messages of a
# kind are one numpy array of records; Path and String are written field by
# field. tests/test_export_ros2.py checks every message's bytes equal that
# library's encoding, and `python benchmarks/looking.py export` pairs the two.

# CDR little-endian encapsulation: the payload's alignment counts from after it.
_ENCAPSULATION: Final = b"\x00\x01\x00\x00"


def _layout(fields: list[tuple[str, str]]) -> np.dtype[np.void]:
    """The record of a CDR message: fields ``(name, kind)`` with kind ``i4``, ``u4``,
    ``f8``, ``f8[36]`` or ``str:TEXT`` (a constant string), each aligned to its
    size as CDR does, after the 4 bytes of encapsulation."""
    names: list[str] = ["encapsulation"]
    formats: list[Any] = ["S4"]
    offsets: list[int] = [0]
    at = 0  # in the payload
    for name, kind in fields:
        if kind.startswith("str:"):
            at = -(-at // 4) * 4
            text = kind[4:].encode() + b"\x00"
            names += [f"{name}_length", name]
            formats += ["<u4", f"S{len(text)}"]
            offsets += [4 + at, 4 + at + 4]
            at += 4 + len(text)
            continue
        size = 8 if kind.startswith("f8") else 4
        at = -(-at // size) * size
        names.append(name)
        formats.append(("<f8", (36,)) if kind == "f8[36]" else "<" + kind)
        offsets.append(4 + at)
        at += 288 if kind == "f8[36]" else size
    return np.dtype({"names": names, "formats": formats, "offsets": offsets, "itemsize": 4 + at})


_HEADER: Final = [("sec", "i4"), ("nanosec", "u4"), ("frame_id", f"str:{WORLD}")]
_POSE: Final = [
    *[(f"p{axis}", "f8") for axis in "xyz"],
    *[(f"q{axis}", "f8") for axis in "xyzw"],
]
_TWIST: Final = [(f"l{axis}", "f8") for axis in "xyz"] + [(f"a{axis}", "f8") for axis in "xyz"]
ODOMETRY: Final = _layout(
    [
        *_HEADER,
        ("child_frame_id", f"str:{ROBOT}"),
        *_POSE,
        ("pose_covariance", "f8[36]"),
        *_TWIST,
        ("twist_covariance", "f8[36]"),
    ]
)
POSE_STAMPED: Final = _layout([*_HEADER, *_POSE])
TWIST: Final = _layout(_TWIST)


def _records(layout: np.dtype[np.void], t: np.ndarray, **columns: np.ndarray) -> np.ndarray:
    """One record per sample: the constants, the stamp from ``t``, the columns given."""
    records = np.zeros(t.size, dtype=layout)
    records["encapsulation"] = _ENCAPSULATION
    names = layout.names or ()
    for name in names:
        if name.endswith("_length"):
            text = name.removesuffix("_length")
            records[name] = layout.fields[text][0].itemsize  # type: ignore[index]
            records[text] = (WORLD if text == "frame_id" else ROBOT).encode()
    if "sec" in names:
        sec, nanosec = np.divmod(np.array([round(v * 1e9) for v in t.tolist()]), 1_000_000_000)
        records["sec"], records["nanosec"] = sec, nanosec
    if "qw" in names:
        records["qw"] = 1.0
    for name, column in columns.items():
        records[name] = column
    return records


def _messages(t: np.ndarray, records: np.ndarray) -> Iterator[tuple[float, bytes]]:
    data = records.tobytes()
    size = records.dtype.itemsize
    for k, time in enumerate(t.tolist()):
        yield time, data[k * size : (k + 1) * size]


def _odometry(
    t: np.ndarray, x: np.ndarray, y: np.ndarray, theta: np.ndarray, v: np.ndarray, w: np.ndarray
) -> Iterator[tuple[float, bytes]]:
    kept = np.isfinite(x) & np.isfinite(y) & np.isfinite(theta)
    return _messages(
        t[kept],
        _records(
            ODOMETRY,
            t[kept],
            px=x[kept],
            py=y[kept],
            qz=np.sin(0.5 * theta[kept]),
            qw=np.cos(0.5 * theta[kept]),
            lx=np.where(np.isfinite(v), v, 0.0)[kept],
            az=np.where(np.isfinite(w), w, 0.0)[kept],
        ),
    )


def _twists(t: np.ndarray, v: np.ndarray, w: np.ndarray) -> Iterator[tuple[float, bytes]]:
    kept = np.isfinite(v) & np.isfinite(w)
    return _messages(t[kept], _records(TWIST, t[kept], lx=v[kept], az=w[kept]))


def _measurements(result: RunResult) -> Iterator[tuple[float, bytes]]:
    r = result
    kept = np.isfinite(r.x_meas) & np.isfinite(r.y_meas)
    theta = np.where(np.isfinite(r.theta_meas), r.theta_meas, 0.0)[kept]
    return _messages(
        r.t[kept],
        _records(
            POSE_STAMPED,
            r.t[kept],
            px=r.x_meas[kept],
            py=r.y_meas[kept],
            qz=np.sin(0.5 * theta),
            qw=np.cos(0.5 * theta),
        ),
    )


class _Cdr:
    """A message's CDR bytes written field by field (little-endian; each field
    aligned to its size, counted from after the encapsulation)."""

    def __init__(self) -> None:
        self.data = bytearray(_ENCAPSULATION)

    def _align(self, size: int) -> None:
        self.data += bytes(-(len(self.data) - 4) % size)

    def u4(self, value: int) -> None:
        self._align(4)
        self.data += struct.pack("<I", value)

    def stamp(self, t: float) -> None:
        sec, nanosec = divmod(round(t * 1e9), 1_000_000_000)
        self._align(4)
        self.data += struct.pack("<iI", sec, nanosec)

    def text(self, value: str) -> None:
        encoded = value.encode() + b"\x00"
        self.u4(len(encoded))
        self.data += encoded

    def f8(self, *values: float) -> None:
        self._align(8)
        self.data += struct.pack(f"<{len(values)}d", *values)


def _string(text: str) -> bytes:
    """std_msgs/msg/String."""
    cdr = _Cdr()
    cdr.text(text)
    return bytes(cdr.data)


def _path(t: float, points: list[tuple[float, float, float]]) -> bytes:
    """nav_msgs/msg/Path of the points ``(t, x, y)``, in frame world, no headings."""
    cdr = _Cdr()
    cdr.stamp(t)
    cdr.text(WORLD)
    cdr.u4(len(points))
    for time, x, y in points:
        cdr.stamp(time)
        cdr.text(WORLD)
        cdr.f8(x, y, 0.0, 0.0, 0.0, 0.0, 1.0)
    return bytes(cdr.data)


def _references(result: RunResult) -> Iterator[tuple[float, bytes]]:
    """A Path at the first sample of each run of samples of one phase that has a
    reference: the reference in force from then on (thinned to PATH_POSES)."""
    r = result
    phase = np.asarray(r.phase)
    starts = np.flatnonzero(np.r_[True, phase[1:] != phase[:-1]]).tolist() if r.samples else []
    for start, end in zip(starts, [*starts[1:], r.samples], strict=True):
        span = np.arange(start, end)
        span = span[np.isfinite(r.x_ref[span]) & np.isfinite(r.y_ref[span])]
        if span.size == 0:
            continue
        if span.size > PATH_POSES:
            span = span[np.unique(np.linspace(0, span.size - 1, PATH_POSES).round().astype(int))]
        points = list(
            zip(r.t[span].tolist(), r.x_ref[span].tolist(), r.y_ref[span].tolist(), strict=True)
        )
        yield float(r.t[start]), _path(float(r.t[start]), points)


def write_ros2_mcap(result: RunResult, summary: Any, stream: IO[bytes]) -> None:
    """The run as ROS 2 messages (CDR) into ``stream``. The caller has checked that
    every ``t`` lies in [0, STAMP_LIMIT)."""
    from mcap.writer import CompressionType, Writer

    writer = Writer(stream, compression=CompressionType.ZSTD)
    writer.start(profile="ros2", library="wmr-mission")
    schemas = {
        kind: writer.register_schema(
            name=_schema_name(kind), encoding="ros2msg", data=message_definition(kind).encode()
        )
        for kind in (
            "nav_msgs/Odometry",
            "geometry_msgs/Twist",
            "geometry_msgs/PoseStamped",
            "nav_msgs/Path",
            "std_msgs/String",
        )
    }

    def put(topic: str, kind: str, messages: Iterator[tuple[float, bytes]]) -> None:
        channel = writer.register_channel(
            topic=topic, message_encoding="cdr", schema_id=schemas[kind]
        )
        for sequence, (t, data) in enumerate(messages):
            ns = round(t * 1e9)
            writer.add_message(
                channel_id=channel, log_time=ns, publish_time=ns, data=data, sequence=sequence
            )

    r = result
    t_end = float(r.t[-1]) if r.samples else 0.0
    put("/odom", "nav_msgs/Odometry", _odometry(r.t, r.x, r.y, r.theta, r.v, r.omega))
    put(
        "/estimate",
        "nav_msgs/Odometry",
        _odometry(r.t, r.x_est, r.y_est, r.theta_est, r.v, r.omega),
    )
    put("/cmd_vel", "geometry_msgs/Twist", _twists(r.t, r.v, r.omega))
    put("/measurement", "geometry_msgs/PoseStamped", _measurements(r))
    put("/reference", "nav_msgs/Path", _references(r))
    put(
        "/transitions",
        "std_msgs/String",
        (
            (change.time, _string(json.dumps(change.fields(), allow_nan=False)))
            for change in r.transitions
        ),
    )
    summary_text = json.dumps(summary, allow_nan=False)
    put("/summary", "std_msgs/String", iter([(t_end, _string(summary_text))]))
    writer.finish()  # type: ignore[no-untyped-call]
