from __future__ import annotations

import dataclasses
import json
import math
import os
import re
import sys
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_output_synthetic import circle_run

import wmr_mission.output.rundir as rundir_module
from wmr_mission.output.files import atomic_path
from wmr_mission.output.reader import RunDirError, load_run
from wmr_mission.output.result import RunResult
from wmr_mission.output.rundir import (
    RunDirExistsError,
    default_run_dir,
    prepare_run_dir,
    trajectory_csv_text,
    write_run,
)
from wmr_mission.record import (
    EXTRA_COLUMNS,
    TRAJECTORY_COLUMNS,
    Outcome,
    PhaseRecord,
    csv_columns,
)

RESOLVED: dict[str, Any] = {
    "version": 1,
    "name": "circle",
    "robot": {"dt": 0.01, "limits": {"v": 10.0, "omega": 20.0, "v_rate": None}},
    "expect": {
        "final_position_error": {"max": 0.05},
        "final_heading_error": None,
        "max_constraint_violation": None,
        "estimation_convergence_time": {"max": 1.0},
        "duration": None,
    },
}
DATA_FILES = {"trajectory.csv", "manifest.json", "transitions.json", "summary.json"}


def write(result: RunResult, out: Path) -> list[Path]:
    return write_run(
        result,
        out,
        mission_sha256="ab" * 32,
        resolved_mission=RESOLVED,
        mission_file="missions/circle.yaml",
        plots=False,
        animate=False,
    )


def test_default_run_dir_is_name_and_timestamp() -> None:
    path = default_run_dir("case2", datetime(2024, 6, 11, 9, 5, 3))
    assert path == Path("runs") / "case2-20240611-090503"


def test_prepare_run_dir_creates_missing_and_accepts_empty(tmp_path: Path) -> None:
    assert prepare_run_dir(tmp_path / "a" / "b").is_dir()
    (tmp_path / "empty").mkdir()
    assert prepare_run_dir(tmp_path / "empty") == tmp_path / "empty"


def test_prepare_run_dir_refuses_a_non_empty_directory(tmp_path: Path) -> None:
    (tmp_path / "old").mkdir()
    (tmp_path / "old" / "summary.json").write_text("{}\n")
    with pytest.raises(RunDirExistsError, match=r"^run directory exists and is not empty"):
        prepare_run_dir(tmp_path / "old")
    assert (tmp_path / "old" / "summary.json").read_text() == "{}\n"


def test_prepare_run_dir_refuses_a_file(tmp_path: Path) -> None:
    (tmp_path / "f").write_text("x")
    with pytest.raises(FileExistsError, match="not a directory"):
        prepare_run_dir(tmp_path / "f")


def test_trajectory_header_and_column_order(tmp_path: Path) -> None:
    write(circle_run(), tmp_path)
    lines = (tmp_path / "trajectory.csv").read_bytes().split(b"\n")
    header = lines[0].decode().split(",")
    first = ["t", "x", "y", "theta", "x_est", "y_est", "theta_est", "v", "omega", "phase"]
    assert header[:10] == first
    assert header == [*TRAJECTORY_COLUMNS, *EXTRA_COLUMNS]
    assert header[10:] == [
        "x_ref",
        "y_ref",
        "constraint",
        "x_meas",
        "y_meas",
        "theta_meas",
        "phase2_iterations",
    ]
    assert len(lines) == 2001 + 2
    assert lines[-1] == b""  # '\n' after every row
    assert b"\r" not in lines[1]


def test_trajectory_values_are_12_significant_digits_and_nan(tmp_path: Path) -> None:
    run = circle_run()
    write(run, tmp_path)
    rows = (tmp_path / "trajectory.csv").read_text().splitlines()
    first = rows[1].split(",")
    assert first[0] == "0"
    assert first[1] == "2"
    assert first[3] == "%.12g" % (math.pi / 2)
    assert first[9] == "approach"
    assert first[13:16] == ["nan", "nan", "nan"]  # no measurement recorded
    assert first[16] == "3"
    park = rows[1 + 1700].split(",")
    assert park[9] == "park"
    assert park[10:12] == ["nan", "nan"]  # no reference outside track phases
    assert park[12] == "-0.5"
    assert float(park[1]) == pytest.approx(run.x[1700], rel=1e-11)


def test_round_trip_gives_equal_arrays(tmp_path: Path) -> None:
    run = circle_run()
    write(run, tmp_path)
    back = load_run(tmp_path)
    for field in (
        "t",
        "x",
        "y",
        "theta",
        "x_est",
        "y_est",
        "theta_est",
        "v",
        "omega",
        "x_ref",
        "y_ref",
        "constraint",
    ):
        np.testing.assert_allclose(
            getattr(back, field),
            getattr(run, field),
            rtol=1e-11,
            atol=1e-15,
            equal_nan=True,
            err_msg=field,
        )
    np.testing.assert_array_equal(back.phase, run.phase)
    np.testing.assert_array_equal(back.phase2_iterations, run.phase2_iterations)
    np.testing.assert_array_equal(back.compute_ns, np.zeros(run.samples, dtype=np.int64))
    assert back.phases == run.phases
    assert back.transitions == run.transitions
    assert (back.outcome, back.message, back.seed, back.dt) == (run.outcome, run.message, 7, 0.01)
    assert back.mission_name == "circle"
    assert back.limits == run.limits
    assert back.error_bounds[:2] == run.error_bounds[:2]
    assert all(math.isnan(b) for b in back.error_bounds[2])
    assert back.regions == run.regions


def test_same_result_twice_gives_byte_identical_csv(tmp_path: Path) -> None:
    write(circle_run(), tmp_path / "one")
    write(circle_run(), tmp_path / "two")
    one = (tmp_path / "one" / "trajectory.csv").read_bytes()
    assert one == (tmp_path / "two" / "trajectory.csv").read_bytes()
    assert len(one) > 100_000


def _awkward_run(samples: int) -> RunResult:
    """circle_run with values that format awkwardly in every float column: NaN,
    infinities, -0.0, the smallest and largest doubles, ties at the 12th digit;
    a reference column, and big integers."""
    run = circle_run(samples)
    awkward = np.array(
        [math.nan, math.inf, -math.inf, -0.0, 5e-324, 1.7976931348623157e308,
         0.1 + 0.2, 1e-5, 123456789012.5, 1e12, -2.5e-7, 1 / 3]
    )  # fmt: skip
    rng = np.random.default_rng(5)
    for name in ("x", "y", "theta", "x_est", "y_est", "theta_est", "v", "omega", "x_ref",
                 "y_ref", "constraint", "x_meas", "y_meas", "theta_meas"):  # fmt: skip
        column = rng.normal(0, 10.0 ** rng.integers(-8, 9), samples)
        column[rng.integers(0, samples, 40)] = rng.choice(awkward, 40)
        setattr(run, name, column)
    run.phase2_iterations = rng.integers(-(2**62), 2**62, samples)
    run.reference = rng.integers(0, 3, samples)
    return run


def test_the_csv_is_each_value_formatted_in_its_column_across_blocks() -> None:
    """trajectory.csv is, byte for byte, each row's values formatted one by one
    (floats ``%.12g``, integers ``%d``, the phase's name) on runs that end
    inside a block of lines, on its boundary, and past it."""
    for samples in (1, rundir_module._ROWS_PER_BLOCK, 2 * rundir_module._ROWS_PER_BLOCK + 7):
        run = _awkward_run(samples)
        names = [p.name for p in run.phases]
        columns = csv_columns(run)
        lines = [",".join(columns)]
        for k in range(samples):
            fields = []
            for name in columns:
                value = getattr(run, name)[k]
                if name == "phase":
                    fields.append(names[value])
                elif name in ("phase2_iterations", "reference"):
                    fields.append(str(int(value)))
                else:
                    fields.append("%.12g" % float(value))  # noqa: UP031 (the writer's format)
            lines.append(",".join(fields))
        assert trajectory_csv_text(run) == "\n".join(lines) + "\n"


def test_the_csv_writer_works_per_column_not_per_value() -> None:
    """The Python the writer runs grows with its blocks, not with its values:
    a few calls per block (numpy's), none per sample (a tuple built value by
    value resumed a generator 17 times per sample)."""
    run = circle_run(20_000)
    calls = [0]

    def count(frame: Any, event: str, arg: Any) -> None:
        if event == "call":
            calls[0] += 1

    sys.setprofile(count)
    try:
        text = trajectory_csv_text(run)
    finally:
        sys.setprofile(None)
    assert text.count("\n") == 20_001
    assert calls[0] < 200


def test_phase_names_needing_quotes_round_trip(tmp_path: Path) -> None:
    run = circle_run(50)
    run.phases = [PhaseRecord('go, "fast"', "track"), *run.phases[1:]]
    run.transitions = []
    write(run, tmp_path)
    assert '"go, ""fast"""' in (tmp_path / "trajectory.csv").read_text()
    assert load_run(tmp_path).phases[0].name == 'go, "fast"'


def test_writes_only_final_files_and_summary_last(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    renamed: list[str] = []
    real_replace = os.replace

    def recording_replace(src: Any, dst: Any) -> None:
        renamed.append(Path(dst).name)
        real_replace(src, dst)

    monkeypatch.setattr(os, "replace", recording_replace)
    written = write(circle_run(), tmp_path)
    assert renamed[:2] == ["trajectory.csv", "manifest.json"]
    assert renamed[-1] == "summary.json"
    assert [p.name for p in written] == renamed
    assert {p.name for p in tmp_path.iterdir()} == DATA_FILES  # no temporary files left


def test_failed_write_leaves_neither_file_nor_temporary(tmp_path: Path) -> None:
    target = tmp_path / "summary.json"

    def interrupted_write() -> None:
        with atomic_path(target) as tmp:
            tmp.write_text('{"outcome": ')
            raise RuntimeError("interrupted")

    with pytest.raises(RuntimeError, match="interrupted"):
        interrupted_write()
    assert list(tmp_path.iterdir()) == []


def test_json_files_are_deterministic_and_finite(tmp_path: Path) -> None:
    write(circle_run(), tmp_path)
    for name in ("manifest.json", "transitions.json", "summary.json"):
        text = (tmp_path / name).read_text()
        assert text.endswith("}\n") or text.endswith("]\n")
        assert "NaN" not in text
        assert "Infinity" not in text
        assert text.startswith('{\n  "') or text.startswith("[\n  {")
    manifest = json.loads((tmp_path / "manifest.json").read_text())
    assert list(manifest) == [
        "mission_file",
        "mission_sha256",
        "resolved_mission",
        "seed",
        "versions",
        "environment",
        "loop",
        "run",
    ]
    environment = manifest["environment"]
    assert list(environment) == ["fingerprint", "libc", "libm", "numpy_simd", "numba_cpu"]
    assert re.fullmatch("[0-9a-f]{8}", environment["fingerprint"])
    assert re.fullmatch("[0-9a-f]{8}", environment["libm"])
    assert manifest["mission_sha256"] == "ab" * 32
    assert manifest["resolved_mission"] == RESOLVED
    assert {"python", "wmr-mission", "numpy", "scipy", "pydantic", "matplotlib"} <= set(
        manifest["versions"]
    )
    assert manifest["run"]["error_bounds"]["theta"] == [None, None]
    transitions = json.loads((tmp_path / "transitions.json").read_text())
    assert transitions[0] == {
        "time": 5.0,
        "from": "approach",
        "to": "orbit",
        "condition": "reaches",
        "value": 0.0,
    }
    assert transitions[-1]["to"] is None


def test_summary_lists_the_expectations(tmp_path: Path) -> None:
    write(circle_run(), tmp_path)
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["outcome"] == "success"
    assert summary["expectations"] == [
        {
            "metric": "final_position_error",
            "phase": None,
            "max": 0.05,
            "value": pytest.approx(2.0),
            "met": False,
            "rho": pytest.approx(-1.95),
            "margin": pytest.approx(-39.0),
        },
        {
            "metric": "estimation_convergence_time",
            "phase": None,
            "max": 1.0,
            "value": pytest.approx(0.29),
            "met": True,
            "rho": pytest.approx(0.71),
            "margin": pytest.approx(0.71),
        },
    ]
    assert (summary["margin"], summary["margin_check"]) == (
        pytest.approx(-39.0),
        "final_position_error",
    )


def test_load_run_without_summary_says_incomplete(tmp_path: Path) -> None:
    write(circle_run(50), tmp_path)
    (tmp_path / "summary.json").unlink()
    with pytest.raises(RunDirError, match=r"summary.json is missing"):
        load_run(tmp_path)


@pytest.mark.parametrize(
    ("name", "damage", "message"),
    [
        ("manifest.json", lambda text: text[:40], r"manifest.json:\d+:\d+: not valid JSON"),
        ("manifest.json", lambda text: text.replace('"dt"', '"step"'), r"'dt' is missing"),
        ("transitions.json", lambda text: "{}", "expected a list of transitions"),
        (
            "summary.json",
            lambda text: text.replace('"success"', '"fine"'),
            "unknown outcome 'fine'",
        ),
        (
            "trajectory.csv",
            lambda text: text.replace("t,x,", "time,x,", 1),
            "trajectory.csv:1: header",
        ),
        (
            "trajectory.csv",
            lambda text: text[: text.index("\n", 200)] + "\n1,2\n",
            r"trajectory.csv:\d+: expected 17 fields, found 2",
        ),
        (
            "trajectory.csv",
            lambda text: text.replace("\n0.01,", "\nabc,", 1),
            r"trajectory.csv:3: t is not a number: 'abc'",
        ),
        (
            "trajectory.csv",
            lambda text: text.replace(",3\n", ",1.5\n", 1),
            r"trajectory.csv:2: phase2_iterations is not an integer: '1.5'",
        ),
        (
            "trajectory.csv",
            lambda text: text.replace(",orbit,", ",orbiting,", 1),
            r"trajectory.csv:\d+: unknown phase 'orbiting'",
        ),
    ],
)
def test_load_run_reports_a_damaged_file_in_one_line(
    tmp_path: Path, name: str, damage: Any, message: str
) -> None:
    write(circle_run(600), tmp_path)
    path = tmp_path / name
    path.write_text(damage(path.read_text()))
    with pytest.raises(RunDirError, match=message) as error:
        load_run(tmp_path)
    assert "\n" not in str(error.value)


def test_load_run_of_a_missing_directory(tmp_path: Path) -> None:
    with pytest.raises(RunDirError, match="not a directory"):
        load_run(tmp_path / "nowhere")


def test_write_run_keeps_a_diverged_run(tmp_path: Path) -> None:
    run = circle_run(300)
    run = dataclasses.replace(
        run,
        x=run.x.copy(),
        outcome=Outcome.diverged,
        message="state not finite at t = 2.50 s in phase approach",
    )
    run.x[250:] = np.nan
    run.x[249] = np.inf
    write(run, tmp_path)
    back = load_run(tmp_path)
    assert np.isinf(back.x[249])
    assert np.isnan(back.x[250:]).all()
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["outcome"] == "diverged"
    assert summary["final"]["position_error"] is None


def test_load_run_of_a_run_without_samples(tmp_path: Path) -> None:
    write(circle_run(10), tmp_path)
    csv_path = tmp_path / "trajectory.csv"
    csv_path.write_text(csv_path.read_text().partition("\n")[0] + "\n")
    summary_path = tmp_path / "summary.json"
    summary = json.loads(summary_path.read_text())
    summary["samples"] = 0  # a run stopped before its first sample says so
    summary_path.write_text(json.dumps(summary))
    assert load_run(tmp_path).samples == 0
