from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from test_output_synthetic import circle_run
from typer.testing import CliRunner

from wmr_mission.cli import app
from wmr_mission.output import report
from wmr_mission.output.report import format_table
from wmr_mission.verdicts.metrics import check_expectations, judge, summarize

UNDER_THE_TABLE = ("final error:", "estimation converged", "not reached", "expect ", "outcome:")


def _rows(lines: list[str]) -> dict[str, list[str]]:
    """Each phase's lines of the table: its row and the lines its cells wrap onto."""
    header = next(i for i, line in enumerate(lines) if line.startswith("phase "))
    rows: dict[str, list[str]] = {}
    for line in lines[header + 2 :]:
        if line.startswith(UNDER_THE_TABLE):
            break
        if not line.startswith(" "):
            rows[line.split()[0]] = [line]
        else:
            rows[list(rows)[-1]].append(line)
    return rows


def test_table_has_a_row_per_phase_in_fixed_columns() -> None:
    summary = summarize(circle_run())
    text = format_table(summary, Path("runs/circle-20240611-090503"), width=100)
    lines = text.splitlines()
    header = next(line for line in lines if line.startswith("phase "))
    assert header.split("  ")[0] == "phase"
    assert header.endswith("verdict")
    rows = _rows(lines)
    assert list(rows) == ["approach", "orbit", "park"]
    # every column starts where its header starts
    for name in ("kind", "key metric", "converged", "verdict"):
        column = header.index(name)
        assert all(row[0][column - 2 : column] == "  " for row in rows.values()), name
        assert all(row[0][column] != " " for row in rows.values()), name
    metric = header.index("key metric")
    # the reference runs 0.01 m east of the robot on the circle
    assert [line[metric:].split("  ")[0] for line in rows["approach"]] == [
        "cross-track max 0.01 m",
        "lag max 0.01 m",
        "omega jitter 0 rad/s",
    ]
    assert [line[metric:].split("  ")[0] for line in rows["park"]][:3] == [
        "end error 2 m",
        "end heading error 0.996 rad",
        "clearance 1 m",  # the least distance from the ellipse's edge
    ]
    assert rows["approach"][0].endswith("0 % / 0 %  0.29 s     -")
    # right-aligned under its header
    end = header.index("duration") + len("duration")
    assert rows["approach"][0][:end].endswith(" 5.00 s")
    assert rows["orbit"][0][:end].endswith("10.00 s")
    assert lines[-2] == "outcome: success after 20.00 s of simulated time - all phases done"
    assert lines[-1] == "outputs: runs/circle-20240611-090503"
    assert text.endswith("\n")
    assert max(map(len, lines)) <= 100


def test_a_phase_whose_least_clearance_is_at_its_start_says_so() -> None:
    """The park phase of the circle run comes no nearer than 1 m to its
    ellipse, mid-phase. Its first sample moved onto the ellipse's edge (as
    case 2's return starts where its orbit left the robot): its least
    clearance, 0 m, is where it began, and the row says so where the table
    has the run; a summary alone cannot tell."""

    def park_lines(run: Any, with_run: bool) -> list[str]:
        text = format_table(summarize(run), "out", result=run if with_run else None, width=100)
        metric = next(line for line in text.splitlines() if line.startswith("phase ")).index(
            "key metric"
        )
        return [line[metric:].split("  ")[0] for line in _rows(text.splitlines())["park"]]

    run = circle_run()
    assert "clearance 1 m" in park_lines(run, with_run=True)  # mid-phase: no more said
    a, rotation = 5.5, 0.3  # the end of the ellipse's major axis
    run.x[1500], run.y[1500] = a * math.cos(rotation), a * math.sin(rotation)
    assert "clearance 0 m at its start" in park_lines(run, with_run=True)
    assert "clearance 0 m" in park_lines(run, with_run=False)


def test_a_track_phase_judged_on_no_sample_says_why() -> None:
    """Case 2's spiral ends on the ellipse within its entry (the robot still
    closing the estimate's error): nothing of its tracking is judged, and the
    row showed `cross-track max -` and `lag max -` with no word of why."""
    phase = {"tracking": {"cross_track_error_max": None, "along_track_lag_max": None,
                          "entry_time": 0.9315, "detour_time": 0.0}}  # fmt: skip
    assert report.key_metric(phase) == "tracking not judged (entry 0.93 s)"
    phase["tracking"]["detour_time"] = 1.5
    assert report.key_metric(phase) == "tracking not judged (entry 0.93 s, detour 1.50 s)"
    phase["tracking"]["along_track_lag_max"] = 0.02
    assert report.key_metric(phase).splitlines() == ["cross-track max -", "lag max 0.02 m",
                                                     "detour 1.50 s, - off"]  # fmt: skip


def test_table_lists_expectations_and_leaves_a_failure_to_its_message() -> None:
    """Met ones with their values; an unmet mission-wide one NOT MET, even when
    it is the failure's message, which `run` prints once, on stderr: no phase's
    verdict says it, and the table would read as a success."""
    summary = summarize(circle_run())
    summary["expectations"] = [
        check.record()
        for check in check_expectations(
            summary, {"expect": {"final_position_error": {"max": 0.05}, "duration": {"max": 30.0}}}
        )
    ]
    text = format_table(summary, "out")
    assert "expect duration <= 30: 20 (met)" in text
    assert "expect final_position_error <= 0.05: 2 (NOT MET)" in text  # not in the message
    summary["outcome"] = "expect-failed"
    summary["message"] = "expectation not met: final_position_error = 2 (max 0.05)"
    text = format_table(summary, "out")
    assert "expect duration <= 30: 20 (met)" in text
    assert "expect final_position_error <= 0.05: 2 (NOT MET)" in text
    assert "expectation not met" not in text
    assert "outcome: expect-failed after 20.00 s of simulated time\n" in text


def _orbit_at_its_limit() -> dict[str, Any]:
    """The circle run judged, its orbit's turn rate at its limit on 11 % of it."""
    run = circle_run()
    run.omega = run.omega.copy()
    run.omega[700:800] = 20.0
    mission = {
        "expect": {"settle_time": 1.0, "turn_rate_at_limit": {"max": 0.01}},
        "phases": [{"name": name, "expect": {}} for name in ("approach", "orbit", "park")],
    }
    return judge(run, mission)


def test_table_gives_each_phase_its_verdict() -> None:
    """The orbit's turn rate sits at its limit on 11 % of it: its row says so;
    the phases that passed say ok."""
    summary = _orbit_at_its_limit()
    lines = format_table(summary, "out", width=100).splitlines()
    rows = _rows(lines)
    assert rows["approach"][0].endswith("  ok")
    assert rows["orbit"][0].endswith("  NOT MET")
    assert "0 % / 11.1 %" in rows["orbit"][0]
    assert rows["park"][0].endswith("  ok")
    assert lines[-2] == "outcome: expect-failed after 20.00 s of simulated time"
    assert (
        summary["message"] == "expectation not met: orbit: turn_rate_at_limit = 0.111111 (max 0.01)"
    )
    # The row of the phase that missed says which threshold, its value and its bound.
    assert [line.split("  ")[-1].strip() for line in rows["orbit"][1:3]] == [
        "turn_rate_at_limit",
        "0.111 (max 0.01)",
    ]


def test_a_phase_entered_twice_gets_each_entry_s_own_verdict() -> None:
    """A phase resumed after a contingency has two entries of one name: each
    row says its own entry's misses, not the other's (both read NOT MET
    before); two entries in a row are told apart by a check named again."""

    def check(phase: str, metric: str, met: bool) -> dict[str, Any]:
        return {"metric": metric, "phase": phase, "max": 3.0, "value": 2.0 if met else 4.0,
                "met": met}  # fmt: skip

    phases = [{"name": name} for name in ("drive", "sidestep", "drive", "stop")]
    checks = [
        {"metric": "final_position_error", "phase": None, "max": 1.0, "value": 0.1, "met": True},
        check("drive", "turn_rate_jump_max", False),
        check("drive", "speed_jump_max", True),
        check("sidestep", "turn_rate_jump_max", True),
        check("drive", "turn_rate_jump_max", True),
        check("drive", "speed_jump_max", True),
    ]
    assert report._verdicts(checks, phases) == [
        "NOT MET\nturn_rate_jump_max\n4 (max 3)",
        "ok",
        "ok",
        "-",
    ]
    twice = [{"name": "go"}, {"name": "go"}]
    checks = [check("go", "a", True), check("go", "b", True), check("go", "a", False)]
    assert report._verdicts(checks, twice) == ["ok", "NOT MET\na\n4 (max 3)"]


# Creeps at 0.1 m/s towards a point 10 m away: times out, is retried, times
# out again and goes on; then dashes into a keep-out box: breached, the run fails.
ENDS_BADLY = """\
version: 1
name: ends-badly
robot: {limits: {v: 2, omega: 4}}
regions:
  wall: {type: box, min: [0.5, -1], max: [1.5, 1]}
geofence: {keep_out: [wall]}
phases:
  - name: creep
    track: {path: {type: line, heading: 0, speed: 0.1}}
    until: {near: {point: [10, 0], tolerance: 0.1}}
    timeout: 1
    on_timeout: {retry: {times: 1, then: next}}
  - name: dash
    track: {path: {type: line, heading: 0, speed: 1}}
    until: {near: {point: [10, 0], tolerance: 0.1}}
    timeout: 5
"""


def test_a_phase_that_timed_out_or_was_breached_says_so(tmp_path: Path) -> None:
    """A phase that ended by its timeout or a breach, not by its `until`, is not
    'ok': its row says how it ended, whether the run ended there (the dash,
    breached) or went on (the creep, retried once, then on to the next phase:
    a row per entry), here and where the table has only the summary."""
    mission = tmp_path / "ends-badly.yaml"
    mission.write_text(ENDS_BADLY)
    command = ["run", str(mission), "--no-plots", "--out", str(tmp_path / "r")]
    result = CliRunner(env={"COLUMNS": "100"}).invoke(app, command)
    assert result.exit_code == 1
    lines = result.stdout.splitlines()
    rows = _rows(lines)
    creeps = [line for line in lines if line.startswith("creep ")]
    assert len(creeps) == 2
    assert all(line.endswith("  timed out") for line in creeps)
    assert rows["dash"][0].endswith("  breached")
    assert "outcome: breached after " in result.stdout
    summary = {"phases": [{"name": "go"}, {"name": "dock"}], "outcome": "timeout"}
    assert report._ends(summary) == [[], ["timed out"]]
    assert report._ends({**summary, "outcome": "breached"}) == [[], ["breached"]]
    assert report._ends({**summary, "outcome": "expect-failed"}) == [[], []]


def test_a_timed_out_phase_that_missed_a_threshold_says_both() -> None:
    """How it ended first, then NOT MET with what it missed; met thresholds
    beside a timeout leave no 'ok'."""
    checks = [
        {"metric": "stall_time", "phase": "dock", "max": 3.0, "value": 4.0, "met": False},
        {"metric": "stall_time", "phase": "wait", "max": 3.0, "value": 2.0, "met": True},
    ]
    phases = [{"name": "dock"}, {"name": "wait"}]
    assert report._verdicts(checks, phases, [["timed out"], ["breached"]]) == [
        "timed out\nNOT MET\nstall_time\n4 (max 3)",
        "breached",
    ]
    assert report._verdicts([], phases, [["timed out"], []]) == ["timed out", "-"]


def test_a_stopped_run_s_table_judges_only_up_to_the_stop() -> None:
    """Stopped by a signal in its last phase so far: that phase was cut short,
    so its row says 'stopped', not a verdict; the mission's expectations were
    judged on the samples up to the stop, and their lines say so."""
    judged = _orbit_at_its_limit()
    wide = {"metric": "final_position_error", "max": 0.05, "value": 0.01, "met": True}
    summary = {**judged, "outcome": "interrupted", "expectations": [*judged["expectations"], wide]}
    lines = format_table(summary, "out", width=100).splitlines()
    rows = _rows(lines)
    assert rows["approach"][0].endswith("  ok")
    assert rows["orbit"][0].endswith("  NOT MET")
    assert rows["park"][0].endswith("  stopped")
    expects = [line for line in lines if line.startswith("expect ")]
    # the mission-wide check, judged up to the stop; the orbit's, judged whole
    assert expects == [
        "expect orbit: turn_rate_at_limit <= 0.01: 0.1111 (NOT MET)",
        "expect final_position_error <= 0.05: 0.01 (met up to the stop)",
    ]
    # Stopped in a phase entered again (a retry, a goto): only its last row.
    again = {**summary, "phases": [*summary["phases"], summary["phases"][0]]}
    lines = format_table(again, "out", width=100).splitlines()
    verdicts = [line.split()[-1] for line in lines if line.startswith("approach ")]
    assert verdicts == ["ok", "stopped"]


def test_a_narrower_table_wraps_its_cells_within_the_width() -> None:
    summary = summarize(circle_run())
    for width in (100, 80, 72):
        lines = format_table(summary, "out", width=width).splitlines()
        table = lines[: lines.index(next(line for line in lines if line.startswith("final")))]
        assert len(table) > 5
        assert max(map(len, table)) <= width
        assert list(_rows(lines)) == ["approach", "orbit", "park"]


def test_an_80_column_table_folds_two_columns_into_the_key_metric() -> None:
    """On an 80-column terminal (the common default) the inputs at their
    limits and the estimate's convergence are lines of the key metric, not
    columns that squeeze it: no phase name or metric is wrapped inside a word."""
    summary = summarize(circle_run())
    wide = format_table(summary, "out", width=100).splitlines()
    lines = format_table(summary, "out", width=80).splitlines()
    assert (
        max(map(len, lines[: lines.index(next(x for x in lines if x.startswith("final")))])) <= 80
    )
    assert lines[0].split() == ["phase", "kind", "duration", "key", "metric", "verdict"]
    assert max(len(line) for line in lines if "at limit" in line) < 80
    assert list(_rows(lines)) == list(_rows(wide)) == ["approach", "orbit", "park"]
    for name in ("approach", "orbit", "park"):
        # each of the wide table's cells whole, the two columns as lines of the key metric
        folded = _rows(lines)[name]
        at_limit, converged = _cells(wide, name)
        assert f"v / omega at limit {at_limit}" in "\n".join(folded)
        assert f"estimate converged {converged}" in "\n".join(folded)


def _cells(lines: list[str], name: str) -> tuple[str, str]:
    """The at-limit and converged cells of phase ``name``'s row of a wide table."""
    header = next(line for line in lines if "converged" in line and "phase" in line)
    row = next(line for line in lines if line.startswith(f"{name} "))
    at, converged = header.index("v / omega"), header.index("converged")
    verdict = header.index("verdict")
    return row[at:converged].strip(), row[converged:verdict].strip()


class _CountedCheck(dict):  # type: ignore[type-arg]
    """A check that counts how often the table reads it."""

    reads = 0

    def get(self, key: object, default: object = None) -> object:
        _CountedCheck.reads += 1
        return super().get(key, default)

    def __getitem__(self, key: object) -> object:
        _CountedCheck.reads += 1
        return super().__getitem__(key)


def test_the_table_reads_each_check_a_bounded_number_of_times() -> None:
    """Linear in the phases: each phase used to scan every check, and a run of
    15,000 one-sample phases was still printing its table after a minute."""
    phases = 2000
    summary = {
        "phases": [{"name": f"p{i}", "kind": "hold", "duration": 0.01} for i in range(phases)],
        "expectations": [
            _CountedCheck(phase=f"p{i}", metric="settle_time", max=1.0, value=0.5, met=i != 7)
            for i in range(phases)
        ],
        "outcome": "success",
        "duration": 20.0,
    }
    _CountedCheck.reads = 0
    lines = format_table(summary, "out", width=100).splitlines()
    assert _CountedCheck.reads <= 10 * phases  # 4,000,000 reads before
    rows = _rows(lines)
    assert rows["p7"][0].endswith("  NOT MET")
    assert rows["p8"][0].endswith("  ok")


def test_a_table_that_fits_is_laid_out_as_rich_lays_it_out() -> None:
    """Laid out without rich where every cell fits (rich's import and layout
    cost a run 0.02-0.03 s), character for character as rich would; rich
    wraps the rest."""
    judged = _orbit_at_its_limit()
    rows = report._phase_rows(judged, list(judged.get("expectations", [])))
    tables = [
        rows,
        rows[:1],
        [],
        [["a-much-longer-phase-name-than-usual", "track", "-", "-", "-", "never", "-"]],
        [[*rows[1][:6], "NOT MET\nturn_rate_at_limit\n0.111 (max 0.01)"]],
        [["a:x:b", "track", ":smile:", "-", "-", "never", "-"]],  # text, not emoji codes
    ]
    fitted = 0
    for table in tables:
        for width in range(40, 130):
            fitting = report._fitting_table(table, width)
            if fitting is not None:
                fitted += 1
                assert fitting == report._wrapped_table(table, width), (table, width)
    assert fitted > 200
    assert report._fitting_table(rows, 60) is None  # wrapped by rich: too narrow
    wide = [[*rows[0][:6], "a verdict wider than its column"]]
    assert report._fitting_table(wide, 200) is None
    assert report._fitting_table([["\u00e9t\u00e9", *rows[0][1:]]], 200) is None
