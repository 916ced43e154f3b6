from __future__ import annotations

from pathlib import Path

from test_output_synthetic import circle_run

from wmr_mission.output.metrics import check_expectations, summarize
from wmr_mission.output.report import format_table


def test_table_has_a_row_per_phase_in_fixed_columns() -> None:
    summary = summarize(circle_run())
    text = format_table(summary, Path("runs/circle-20240611-090503"))
    lines = text.splitlines()
    assert lines[0].split("  ")[0] == "phase"
    assert lines[0].endswith("estimate < 0.05 after")
    rows = lines[2:5]
    assert [row.split()[0] for row in rows] == ["approach", "orbit", "park"]
    # every column starts where its header starts
    for header in ("kind", "key metric", "estimate < 0.05 after"):
        column = lines[0].index(header)
        assert all(row[column - 2 : column] == "  " for row in rows), header
    assert "track rms 0.01 m" in rows[0]
    assert "end error 2 m" in rows[2]
    assert "max constraint 0.02" in rows[2]
    assert rows[0].endswith("  0.29 s")
    assert rows[0][: lines[0].index("duration") + 8].endswith(" 5.00 s")  # right-aligned
    assert "10.00 s" in rows[1]
    assert lines[-2] == "outcome: success after 20.00 s of simulated time - all phases done"
    assert lines[-1] == "outputs: runs/circle-20240611-090503"
    assert text.endswith("\n")


def test_table_lists_expectations() -> None:
    summary = summarize(circle_run())
    summary["expectations"] = check_expectations(
        summary, {"final_position_error": {"max": 0.05}, "duration": {"max": 30.0}}
    )
    text = format_table(summary, "out")
    assert "expect final_position_error <= 0.05: 2 (NOT MET)" in text
    assert "expect duration <= 30: 20 (met)" in text
