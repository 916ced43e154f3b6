from __future__ import annotations

from pathlib import Path

from test_output_synthetic import circle_run

from wmr_mission.output.metrics import check_expectations, judge, summarize
from wmr_mission.output.report import format_table


def test_table_has_a_row_per_phase_in_fixed_columns() -> None:
    summary = summarize(circle_run())
    text = format_table(summary, Path("runs/circle-20240611-090503"))
    lines = text.splitlines()
    assert lines[0].split("  ")[0] == "phase"
    assert lines[0].endswith("verdict")
    rows = lines[2:5]
    assert [row.split()[0] for row in rows] == ["approach", "orbit", "park"]
    # every column starts where its header starts
    headers = ("kind", "key metric", "at limit v/omega", "estimate converged after", "verdict")
    for header in headers:
        column = lines[0].index(header)
        assert all(row[column - 2 : column] == "  " for row in rows), header
    assert "off path rms 0.00525 m max 0.01 m, omega jitter 0 rad/s" in rows[0]
    assert "end error 2 m" in rows[2]
    assert "max constraint 0.02" in rows[2]
    assert rows[0].endswith("0 % / 0 %         0.29 s                    -")
    assert rows[0][: lines[0].index("duration") + 8].endswith(" 5.00 s")  # right-aligned
    assert "10.00 s" in rows[1]
    assert lines[-2] == "outcome: success after 20.00 s of simulated time - all phases done"
    assert lines[-1] == "outputs: runs/circle-20240611-090503"
    assert text.endswith("\n")


def test_table_lists_expectations() -> None:
    summary = summarize(circle_run())
    summary["expectations"] = check_expectations(
        summary, {"expect": {"final_position_error": {"max": 0.05}, "duration": {"max": 30.0}}}
    )
    text = format_table(summary, "out")
    assert "expect final_position_error <= 0.05: 2 (NOT MET)" in text
    assert "expect duration <= 30: 20 (met)" in text


def test_table_gives_each_phase_its_verdict() -> None:
    """The orbit's turn rate sits at its limit on 11 % of it: its row says so,
    and so does a line under the table; the phases that passed say ok."""
    run = circle_run()
    run.omega = run.omega.copy()
    run.omega[700:800] = 20.0
    mission = {
        "expect": {"settle_time": 1.0, "turn_rate_at_limit": {"max": 0.01}},
        "phases": [{"name": name, "expect": {}} for name in ("approach", "orbit", "park")],
    }
    lines = format_table(judge(run, mission), "out").splitlines()
    approach, orbit, park = lines[2:5]
    assert approach.endswith("  ok")
    assert orbit.endswith("  NOT MET: turn_rate_at_limit")
    assert "0 % / 11.1 %" in orbit
    assert park.endswith("  ok")
    assert "expect orbit: turn_rate_at_limit <= 0.01: 0.1111 (NOT MET)" in lines
    assert lines[-2].startswith(
        "outcome: expect-failed after 20.00 s of simulated time - expectation not met:"
    )
