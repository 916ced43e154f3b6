"""`wmr-mission export`: MCAP and Parquet read back equal to the CSV they came from."""

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
from test_output_synthetic import REGIONS, circle_run
from typer.testing import CliRunner

from wmr_mission.cli import app
from wmr_mission.review.export import export_command

pq = pytest.importorskip("pyarrow.parquet")


@pytest.fixture(scope="module")
def run_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """circle_run with measurements every 5th sample, an infinity in the constraint,
    a reference updated half-way (the `reference` column of a run with updates),
    and its first transition a reaction's, with why it fired."""
    result = circle_run()
    measured = np.arange(result.samples) % 5 == 1
    constraint = result.constraint.copy()
    constraint[1700] = math.inf
    result = dataclasses.replace(
        result,
        x_meas=np.where(measured, result.x + 0.01, np.nan),
        y_meas=np.where(measured, result.y - 0.01, np.nan),
        theta_meas=np.where(measured, result.theta + 0.001, np.nan),
        constraint=constraint,
        reference=(np.arange(result.samples) >= result.samples // 2).astype(np.int64),
        transitions=[
            dataclasses.replace(
                result.transitions[0],
                reaction="retry: 1 (1 of 1)",
                why="phase 'out' timed out after 1 s at t = 1 s",
            ),
            *result.transitions[1:],
        ],
    )
    return result.write(tmp_path_factory.mktemp("export") / "circle", plots=False)


def _csv(path: Path) -> tuple[list[str], list[list[str]]]:
    with path.open(encoding="utf-8", newline="") as stream:
        rows = list(csv.reader(stream))
    return rows[0], rows[1:]


def _as_json(cell: str) -> Any:
    """A trajectory.csv number as wmr.Sample holds it."""
    value = float(cell)
    if math.isnan(value):
        return None
    return value if math.isfinite(value) else cell


def _messages(path: Path) -> dict[str, list[tuple[str, int, Any]]]:
    topics: dict[str, list[tuple[str, int, Any]]] = {}
    with path.open("rb") as stream:
        for schema, channel, message in make_reader(stream).iter_messages(log_time_order=False):
            assert schema is not None
            topics.setdefault(channel.topic, []).append(
                (schema.name, message.log_time, json.loads(message.data))
            )
    return topics


def _yaw(orientation: dict[str, float]) -> float:
    assert orientation["x"] == orientation["y"] == 0.0
    return 2.0 * math.atan2(orientation["z"], orientation["w"])


def _same_angle(a: float, b: float) -> bool:
    return abs(math.remainder(a - b, 2 * math.pi)) < 1e-12


def test_mcap_messages_read_back_equal_to_the_csv(run_dir: Path) -> None:
    assert export_command(run_dir, "mcap-json") == 0
    topics = _messages(run_dir / "run.json.mcap")
    header, rows = _csv(run_dir / "trajectory.csv")
    schemas = {topic: {m[0] for m in messages} for topic, messages in topics.items()}
    assert schemas == {
        "/pose": {"foxglove.PoseInFrame"},
        "/estimate": {"foxglove.PoseInFrame"},
        "/reference": {"foxglove.PoseInFrame"},
        "/measurement": {"foxglove.PoseInFrame"},
        "/regions": {"foxglove.SceneUpdate"},
        "/sample": {"wmr.Sample"},
        "/transitions": {"wmr.Transition"},
        "/summary": {"wmr.Summary"},
    }
    # every row, every column, exactly; log time from t
    samples = topics["/sample"]
    assert len(samples) == len(rows)
    for (_, log_time, message), row in zip(samples, rows, strict=True):
        assert log_time == round(float(row[0]) * 1e9)
        expected = {
            name: cell
            if name == "phase"
            else int(cell)
            if name in ("phase2_iterations", "reference")
            else _as_json(cell)
            for name, cell in zip(header, row, strict=True)
        }
        assert message == expected
    assert header[-1] == "reference"
    assert {m["reference"] for _, _, m in samples} == {0, 1}
    assert samples[1700][2]["constraint"] == "inf"

    column = {name: [row[j] for row in rows] for j, name in enumerate(header)}
    for topic, (x, y, theta) in {
        "/pose": ("x", "y", "theta"),
        "/estimate": ("x_est", "y_est", "theta_est"),
        "/reference": ("x_ref", "y_ref", None),
        "/measurement": ("x_meas", "y_meas", "theta_meas"),
    }.items():
        kept = [k for k in range(len(rows)) if math.isfinite(float(column[x][k]))]
        assert len(topics[topic]) == len(kept) > 0, topic
        for (_, log_time, message), k in zip(topics[topic], kept, strict=True):
            assert log_time == round(float(column["t"][k]) * 1e9)
            assert message["frame_id"] == "world"
            assert message["timestamp"] == {
                "sec": log_time // 1_000_000_000,
                "nsec": log_time % 1_000_000_000,
            }
            position = message["pose"]["position"]
            assert (position["x"], position["y"], position["z"]) == (
                float(column[x][k]),
                float(column[y][k]),
                0.0,
            )
            yaw = _yaw(message["pose"]["orientation"])
            assert _same_angle(yaw, float(column[theta][k]) if theta else 0.0), (topic, k)

    transitions = json.loads((run_dir / "transitions.json").read_text(encoding="utf-8"))
    assert [m for _, _, m in topics["/transitions"]] == [
        {"lap": None, "reaction": None, "why": None, **t} for t in transitions
    ]
    assert any("why" in t for t in transitions)  # a reaction's, said in the export too
    assert [t for _, t, _ in topics["/transitions"]] == [
        round(t["time"] * 1e9) for t in transitions
    ]
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    assert [m for _, _, m in topics["/summary"]] == [summary]


def test_mcap_regions_are_foxglove_scene_entities(run_dir: Path) -> None:
    from pydantic import TypeAdapter

    from wmr_mission.geometry.regions import region_outline
    from wmr_mission.spec.models import RegionSpec

    export_command(run_dir, "mcap-json")
    ((_, log_time, update),) = _messages(run_dir / "run.json.mcap")["/regions"]
    assert log_time == 0
    entities = {e["id"]: e for e in update["entities"]}
    assert set(entities) == {f"region/{name}" for name in REGIONS}
    required = {
        "timestamp", "frame_id", "id", "lifetime", "frame_locked", "metadata", "arrows", "cubes",
        "spheres", "cylinders", "lines", "triangles", "texts", "models",
    }  # fmt: skip
    for name, region in REGIONS.items():
        entity = entities[f"region/{name}"]
        assert set(entity) == required
        ((line,),) = [entity["lines"]]
        assert set(line) == {
            "type", "pose", "thickness", "scale_invariant", "points", "color", "colors", "indices"
        }  # fmt: skip
        assert entity["texts"][0]["text"] == name
        spec = TypeAdapter(RegionSpec).validate_python(region)
        if spec.type == "half-plane":
            assert line["type"] == 0  # a LINE_STRIP across the view
            assert {p["x"] for p in line["points"]} == {4.5}
            continue
        assert line["type"] == 1  # a LINE_LOOP: its first point is not repeated
        xs, ys = region_outline(spec)
        points = [(p["x"], p["y"]) for p in line["points"]]
        assert points == list(zip(xs.tolist(), ys.tolist(), strict=True))[: len(points)]
        assert len(points) == len(xs) - 1
    assert entities["region/ellipse"]["metadata"] == [
        {"key": "type", "value": "ellipse"},
        {"key": "constraint", "value": "inside"},
    ]


def test_parquet_rows_read_back_equal_to_trajectory_csv(run_dir: Path) -> None:
    assert export_command(run_dir, "parquet", run_dir / "t.parquet") == 0
    table = pq.read_table(run_dir / "t.parquet")
    header, rows = _csv(run_dir / "trajectory.csv")
    assert table.column_names == header
    types = {field.name: str(field.type) for field in table.schema}
    assert types.pop("phase") == "dictionary<values=string, indices=int32, ordered=0>"
    assert types.pop("phase2_iterations") == "int64"
    assert set(types.values()) == {"double"}
    assert table.num_rows == len(rows)
    for j, name in enumerate(header):
        values = table.column(name).to_pylist()
        cells = [row[j] for row in rows]
        if name == "phase":
            assert values == cells
        elif name == "phase2_iterations":
            assert values == [int(c) for c in cells]
        else:
            expected = np.array([float(c) for c in cells])
            assert np.array_equal(np.array(values), expected, equal_nan=True), name
    metadata = table.schema.metadata
    assert metadata[b"wmr_mission.mission"] == b"circle"
    assert metadata[b"wmr_mission.seed"] == b"7"


def test_parquet_of_runs_csv_has_its_columns_values_and_types(campaign_dir: Path) -> None:
    pandas = pytest.importorskip("pandas")
    out = campaign_dir.parent / "runs.parquet"
    assert export_command(campaign_dir, "parquet", out) == 0
    table = pq.read_table(out)
    header, rows = _csv(campaign_dir / "runs.csv")
    assert table.column_names == header
    types = {field.name: str(field.type) for field in table.schema}
    assert types == {
        "run": "int64",
        "seed": "int64",
        "outcome": "string",
        "robot.initial_state.theta": "double",
        "sensors.noise_std.x": "double",
        "estimator.type": "string",
        "controller.Q": "string",
        **dict.fromkeys(header[7:-2], "double"),  # the metrics, then the margin
        "margin_check": "string",
        "reason": "string",
    }
    for j, name in enumerate(header):
        values = table.column(name).to_pylist()
        cells = [row[j] for row in rows]
        if types[name] == "int64":
            assert values == [int(c) for c in cells]
        elif types[name] == "double":
            assert values == [float(c) if c else None for c in cells], name
        else:
            assert values == cells, name
    # the numeric columns as pandas reads the CSV
    frame = pandas.read_csv(campaign_dir / "runs.csv")
    read_back = table.to_pandas()
    for name in header:
        if types[name] != "string":
            assert read_back[name].dtype == frame[name].dtype, name
            assert read_back[name].equals(frame[name]), name


def test_an_extra_that_is_missing_is_named_in_one_line(
    run_dir: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    for module, fmt, package in (
        ("mcap", "mcap", "mcap"),
        ("mcap", "mcap-json", "mcap"),
        ("pyarrow", "parquet", "pyarrow"),
    ):
        with monkeypatch.context() as patch:
            for name in [m for m in sys.modules if m == module or m.startswith(module + ".")]:
                patch.setitem(sys.modules, name, None)
            patch.setitem(sys.modules, module, None)
            assert export_command(run_dir, fmt, run_dir / f"missing.{fmt}") == 2
        assert capsys.readouterr().err == (
            f"--format {fmt} needs the {package} package: pip install 'wmr-mission[export]'\n"
        )
        assert not (run_dir / f"missing.{fmt}").exists()


def test_usage_errors_and_damaged_files(
    run_dir: Path, campaign_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert export_command(campaign_dir, "mcap") == 2
    assert capsys.readouterr().err.startswith(f"{campaign_dir}: a campaign directory exports as")
    assert export_command(tmp_path, "parquet") == 2
    assert "neither a run directory" in capsys.readouterr().err
    before = (run_dir / "trajectory.csv").read_bytes()
    assert export_command(run_dir, "parquet", run_dir / "trajectory.csv") == 2
    assert capsys.readouterr().err == (
        f"{run_dir / 'trajectory.csv'}: is trajectory.csv of the run in {run_dir}; "
        "a record is never written over: choose another --out\n"
    )
    assert (run_dir / "trajectory.csv").read_bytes() == before
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    for name in ("manifest.json", "transitions.json", "trajectory.csv"):
        (damaged / name).write_bytes((run_dir / name).read_bytes())
    (damaged / "summary.json").write_text('{"outcome": "success",', encoding="utf-8")
    for fmt in ("mcap", "mcap-json", "parquet"):
        assert export_command(damaged, fmt) == 1
        err = capsys.readouterr().err
        assert err.startswith(f"{damaged}: summary.json:1:")
        assert err.count("\n") == 1
    assert list(damaged.glob("*.mcap")) == list(damaged.glob("*.parquet")) == []


def test_a_summary_number_that_is_not_finite_is_exported_as_null(
    run_dir: Path, tmp_path: Path
) -> None:
    """Python reads NaN and Infinity in summary.json (plot and view draw the run);
    the MCAP's JSON has neither: null, the rest of the summary as it is."""
    copy = tmp_path / "run"
    copy.mkdir()
    for name in ("manifest.json", "transitions.json", "trajectory.csv"):
        (copy / name).write_bytes((run_dir / name).read_bytes())
    summary = json.loads((run_dir / "summary.json").read_text(encoding="utf-8"))
    text = json.dumps({**summary, "duration": math.nan, "extra": [1e999, -math.inf, 2.5]})
    (copy / "summary.json").write_text(text, encoding="utf-8")
    for fmt in ("mcap-json", "mcap"):
        assert export_command(copy, fmt, tmp_path / f"{fmt}.mcap") == 0
    (_, _, exported) = _messages(tmp_path / "mcap-json.mcap")["/summary"][0]
    assert exported == {**summary, "duration": None, "extra": [None, None, 2.5]}


def test_a_campaign_json_nested_too_deeply_is_one_line(
    campaign_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from wmr_mission.review.view import view_command

    damaged = tmp_path / "campaign"
    damaged.mkdir()
    for name in ("manifest.json", "runs.csv"):
        (damaged / name).write_bytes((campaign_dir / name).read_bytes())
    (damaged / "campaign.json").write_text('{"a":' * 50_000, encoding="utf-8")
    for command in (lambda: export_command(damaged, "parquet"), lambda: view_command(damaged)):
        assert command() == 1
        assert capsys.readouterr().err == (
            f"{damaged}: campaign.json: nested too deeply to read "
            "(arrays and objects inside one another)\n"
        )
    assert sorted(p.name for p in damaged.iterdir()) == [
        "campaign.json",
        "manifest.json",
        "runs.csv",
    ]


@pytest.mark.parametrize(("t", "said"), [("1e12", "1e+12"), ("-1", "-1")])
def test_an_mcap_of_a_time_no_log_can_hold_is_a_positioned_error(
    run_dir: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], t: str, said: str
) -> None:
    """MCAP log times are unsigned 64-bit nanoseconds: a t beyond is the
    file's error at its line (it was "please report it"), as docs/reliability.md says."""
    damaged = tmp_path / "damaged"
    damaged.mkdir()
    for name in ("manifest.json", "transitions.json", "summary.json"):
        (damaged / name).write_bytes((run_dir / name).read_bytes())
    lines = (run_dir / "trajectory.csv").read_text(encoding="utf-8").splitlines(keepends=True)
    row = 1 if t.startswith("-") else len(lines) - 1  # t stays increasing
    lines[row] = t + lines[row][lines[row].index(",") :]
    (damaged / "trajectory.csv").write_text("".join(lines), encoding="utf-8")
    assert export_command(damaged, "mcap-json") == 1
    err = capsys.readouterr().err
    assert err == (
        f"{damaged}: trajectory.csv:{row + 1}: t = {said} s is not an MCAP log time "
        "(0 to 1.845e+10 s)\n"
    )
    assert list(damaged.glob("*.mcap")) == []


def test_export_command_line(run_dir: Path) -> None:
    result = CliRunner().invoke(app, ["export", str(run_dir), "--format", "parquet"])
    assert result.exit_code == 0, result.output
    assert result.output == f"{run_dir / 'trajectory.parquet'}\n"
    result = CliRunner().invoke(app, ["export", str(run_dir), "--format", "csv"])
    assert result.exit_code == 2
