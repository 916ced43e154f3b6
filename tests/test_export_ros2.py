"""`wmr-mission export --format mcap`: a run as ROS 2 messages (CDR), read back by
ROS 2's own message readers (rclpy's deserialisation, the installed interface
packages), message for message equal to the run's files."""

from __future__ import annotations

import csv
import dataclasses
import json
import math
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from mcap.reader import make_reader
from test_output_synthetic import circle_run

from wmr_mission.review.export import export_command
from wmr_mission.review.ros2_messages import DEFINITIONS, PATH_POSES, message_definition

serialization = pytest.importorskip("rclpy.serialization", reason="the ros2 extra")
nav_msgs = pytest.importorskip("nav_msgs.msg", reason="the ros2 extra")
geometry_msgs = pytest.importorskip("geometry_msgs.msg", reason="the ros2 extra")
std_msgs = pytest.importorskip("std_msgs.msg", reason="the ros2 extra")

# rclpy's type support imports lark, which imports the deprecated sre_parse and
# sre_constants.
pytestmark = pytest.mark.filterwarnings(
    "ignore:module 'sre_(parse|constants)' is deprecated:DeprecationWarning"
)

TYPES = {
    "nav_msgs/msg/Odometry": nav_msgs.Odometry,
    "nav_msgs/msg/Path": nav_msgs.Path,
    "geometry_msgs/msg/Twist": geometry_msgs.Twist,
    "geometry_msgs/msg/PoseStamped": geometry_msgs.PoseStamped,
    "std_msgs/msg/String": std_msgs.String,
}


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """circle_run measured every 5th sample, with a NaN pose on one sample."""
    result = circle_run()
    measured = np.arange(result.samples) % 5 == 1
    x_est = result.x_est.copy()
    x_est[900] = math.nan
    result = dataclasses.replace(
        result,
        x_est=x_est,
        x_meas=np.where(measured, result.x + 0.01, np.nan),
        y_meas=np.where(measured, result.y - 0.01, np.nan),
        theta_meas=np.where(measured, result.theta + 0.001, np.nan),
    )
    return result.write(tmp_path_factory.mktemp("ros2") / "circle", plots=False)


def _columns(path: Path) -> dict[str, np.ndarray]:
    with path.open(encoding="utf-8", newline="") as stream:
        rows = list(csv.reader(stream))
    return {
        name: np.array([row[j] for row in rows[1:]], dtype=object if name == "phase" else float)
        for j, name in enumerate(rows[0])
    }


def _read(path: Path) -> tuple[dict[str, list[tuple[int, Any]]], dict[str, str]]:
    """Each topic's (log time, message decoded by rclpy), and each topic's type."""
    topics: dict[str, list[tuple[int, Any]]] = {}
    kinds: dict[str, str] = {}
    with path.open("rb") as stream:
        reader = make_reader(stream)
        assert reader.get_header().profile == "ros2"
        for schema, channel, message in reader.iter_messages(log_time_order=False):
            assert schema is not None
            assert (schema.encoding, channel.message_encoding) == ("ros2msg", "cdr")
            kinds[channel.topic] = schema.name
            decoded = serialization.deserialize_message(message.data, TYPES[schema.name])
            topics.setdefault(channel.topic, []).append((message.log_time, decoded))
    return topics, kinds


def _yaw(q: Any) -> float:
    assert q.x == q.y == 0.0
    return 2.0 * math.atan2(q.z, q.w)


def _same_angle(a: float, b: float) -> bool:
    return abs(math.remainder(a - b, 2 * math.pi)) < 1e-12


def _stamp_ns(stamp: Any) -> int:
    return int(stamp.sec) * 1_000_000_000 + int(stamp.nanosec)


def test_definitions_are_the_installed_ros2_interfaces() -> None:
    share = Path(sys.prefix) / "share"
    for kind, text in DEFINITIONS.items():
        package, name = kind.split("/")
        shipped = (share / package / "msg" / f"{name}.msg").read_text(encoding="utf-8")
        lines = [line.split("#")[0].rstrip() for line in shipped.splitlines()]
        assert "\n".join(line for line in lines if line.strip()) == text, kind


def test_a_definition_names_each_type_it_uses_once() -> None:
    text = message_definition("nav_msgs/Odometry")
    names = [line[5:] for line in text.splitlines() if line.startswith("MSG: ")]
    assert names == [
        "std_msgs/Header",
        "builtin_interfaces/Time",
        "geometry_msgs/PoseWithCovariance",
        "geometry_msgs/Pose",
        "geometry_msgs/Point",
        "geometry_msgs/Quaternion",
        "geometry_msgs/TwistWithCovariance",
        "geometry_msgs/Twist",
        "geometry_msgs/Vector3",
    ]


def test_ros2_messages_read_back_equal_to_the_run(run_dir: Path) -> None:
    assert export_command(run_dir, "mcap") == 0
    topics, kinds = _read(run_dir / "run.mcap")
    assert kinds == {
        "/odom": "nav_msgs/msg/Odometry",
        "/estimate": "nav_msgs/msg/Odometry",
        "/cmd_vel": "geometry_msgs/msg/Twist",
        "/measurement": "geometry_msgs/msg/PoseStamped",
        "/reference": "nav_msgs/msg/Path",
        "/transitions": "std_msgs/msg/String",
        "/summary": "std_msgs/msg/String",
    }
    c = _columns(run_dir / "trajectory.csv")
    ns = [round(t * 1e9) for t in c["t"]]

    for topic, (x, y, theta) in {
        "/odom": ("x", "y", "theta"),
        "/estimate": ("x_est", "y_est", "theta_est"),
    }.items():
        kept = np.flatnonzero(np.isfinite(c[x]) & np.isfinite(c[y])).tolist()
        assert len(topics[topic]) == len(kept) > 0, topic
        for (log_time, odometry), k in zip(topics[topic], kept, strict=True):
            assert log_time == _stamp_ns(odometry.header.stamp) == ns[k]
            assert (odometry.header.frame_id, odometry.child_frame_id) == ("world", "base_link")
            position = odometry.pose.pose.position
            assert (position.x, position.y, position.z) == (c[x][k], c[y][k], 0.0)
            assert _same_angle(_yaw(odometry.pose.pose.orientation), c[theta][k])
            twist = odometry.twist.twist
            assert (twist.linear.x, twist.angular.z) == (c["v"][k], c["omega"][k])
    assert len(topics["/estimate"]) == len(topics["/odom"]) - 1  # the NaN sample left out

    assert [(t, m.linear.x, m.angular.z) for t, m in topics["/cmd_vel"]] == list(
        zip(ns, c["v"], c["omega"], strict=True)
    )

    measured = np.flatnonzero(np.isfinite(c["x_meas"])).tolist()
    assert len(topics["/measurement"]) == len(measured) > 0
    for (log_time, pose), k in zip(topics["/measurement"], measured, strict=True):
        assert log_time == _stamp_ns(pose.header.stamp) == ns[k]
        assert (pose.pose.position.x, pose.pose.position.y) == (c["x_meas"][k], c["y_meas"][k])
        assert _same_angle(_yaw(pose.pose.orientation), c["theta_meas"][k])

    # a Path at the start of each phase with a reference, holding its reference
    paths = topics["/reference"]
    starts = [k for k in range(len(ns)) if k == 0 or c["phase"][k] != c["phase"][k - 1]]
    with_reference = [k for k in starts if math.isfinite(c["x_ref"][k])]
    assert [t for t, _ in paths] == [ns[k] for k in with_reference] != []
    for (_, path), start in zip(paths, with_reference, strict=True):
        span = [
            k
            for k in range(start, len(ns))
            if c["phase"][k] == c["phase"][start] and math.isfinite(c["x_ref"][k])
        ]
        span = [k for k in span if all(c["phase"][j] == c["phase"][start] for j in (start, k))]
        assert len(path.poses) == min(len(span), PATH_POSES)
        assert (path.poses[0].pose.position.x, path.poses[-1].pose.position.x) == (
            c["x_ref"][span[0]],
            c["x_ref"][span[-1]],
        )
        for pose in path.poses:
            k = ns.index(_stamp_ns(pose.header.stamp))
            assert (pose.pose.position.x, pose.pose.position.y) == (c["x_ref"][k], c["y_ref"][k])

    transitions = json.loads((run_dir / "transitions.json").read_text(encoding="utf-8"))
    assert [json.loads(m.data) for _, m in topics["/transitions"]] == [
        {"lap": None, "reaction": None, "why": None, **t} for t in transitions
    ]
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    assert [(t, json.loads(m.data)) for t, m in topics["/summary"]] == [(ns[-1], summary)]


def test_a_long_phase_s_reference_is_thinned_keeping_its_ends(
    run_dir: Path, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    from wmr_mission.review import ros2_messages

    monkeypatch.setattr(ros2_messages, "PATH_POSES", 50)
    out = tmp_path / "thinned.mcap"
    assert export_command(run_dir, "mcap", out) == 0
    topics, _ = _read(out)
    c = _columns(run_dir / "trajectory.csv")
    first = [k for k in range(len(c["t"])) if c["phase"][k] == c["phase"][0]]
    (_, path), *_ = topics["/reference"]
    assert len(first) > 50
    assert len(path.poses) == 50
    stamps = [_stamp_ns(p.header.stamp) for p in path.poses]
    assert stamps == sorted(set(stamps))
    assert (stamps[0], stamps[-1]) == (
        round(c["t"][first[0]] * 1e9),
        round(c["t"][first[-1]] * 1e9),
    )


def test_a_time_beyond_a_ros2_stamp_is_a_positioned_error(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    far = tmp_path / "far"
    far.mkdir()
    for name in ("manifest.json", "transitions.json", "summary.json"):
        (far / name).write_bytes((run_dir / name).read_bytes())
    lines = (run_dir / "trajectory.csv").read_text(encoding="utf-8").splitlines()
    last = lines[-1].split(",")
    last[0] = "3e9"
    (far / "trajectory.csv").write_text("\n".join([*lines[:-1], ",".join(last)]) + "\n")
    assert export_command(far, "mcap") == 1
    err = capsys.readouterr().err
    assert err == (
        f"{far}: trajectory.csv:{len(lines)}: t = 3e+09 s is not a ROS 2 stamp "
        f"(0 to {2**31} s); --format mcap-json takes up to 1.845e+10 s\n"
    )
    assert not list(far.glob("*.mcap"))


def _library_encoding(kind: str, message: Any) -> bytes:
    """mcap-ros2-support's encoding of ``message`` (a dict) under ``kind``."""
    from mcap_ros2._dynamic import serialize_dynamic

    package, name = kind.split("/msg/")
    return bytes(serialize_dynamic(kind, message_definition(f"{package}/{name}"))[kind](message))


def _as_dict(message: Any) -> Any:
    """A decoded ROS 2 message as nested dicts, for the library's encoder."""
    if hasattr(message, "get_fields_and_field_types"):
        return {
            name: _as_dict(getattr(message, name)) for name in message.get_fields_and_field_types()
        }
    if isinstance(message, (list, tuple)) or type(message).__name__ == "ndarray":
        return [_as_dict(item) for item in message]
    return message


def test_every_message_s_bytes_are_the_library_s_encoding(run_dir: Path, tmp_path: Path) -> None:
    """The CDR written here equals mcap-ros2-support's, byte for byte, on every message."""
    out = tmp_path / "run.mcap"
    assert export_command(run_dir, "mcap", out) == 0
    count = 0
    with out.open("rb") as stream:
        for schema, _, message in make_reader(stream).iter_messages():
            assert schema is not None
            decoded = serialization.deserialize_message(message.data, TYPES[schema.name])
            assert message.data == _library_encoding(schema.name, _as_dict(decoded)), schema.name
            count += 1
    assert count > 4000
