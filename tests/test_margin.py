"""A margin for every check (wmr_mission.verdicts.check): signed, in the
metric's unit (``rho``) and over the bound (``margin``); the run's margin is
its least and names its check, in summary.json, runs.csv and campaign.json."""

from __future__ import annotations

import csv
import json
import math
from pathlib import Path

import numpy as np
import pytest
from test_output_synthetic import circle_run

from wmr_mission.campaign.aggregate import Aggregate
from wmr_mission.campaign.rows import METRICS, Row, header
from wmr_mission.output.rundir import write_run
from wmr_mission.verdicts.check import Check, margin_fields, run_margin
from wmr_mission.verdicts.metrics import judge

PATH = np.zeros((2, 0), dtype=np.float32)
JUMP = "speed_jump_max"


def test_a_checks_margin_is_signed_and_in_units_of_its_bound() -> None:
    met = Check("cross_track_error_max", "go", 0.1, 0.025)
    assert (met.met, met.rho, met.margin) == (True, pytest.approx(0.075), pytest.approx(0.75))
    missed = Check("speed_jump_max", None, 2.0, 3.0)
    assert (missed.met, missed.rho, missed.margin) == (False, -1.0, -0.5)
    # a bound of 0: missed, the margin is rho in the metric's unit; met (at 0),
    # 1 as a value of 0 is under any bound, while rho is 0
    zero = Check("zone_intrusion_max", "go", 0.0, 0.02)
    assert (zero.met, zero.margin) == (False, -0.02)
    never = Check("stall_time", "park", 0.0, 0.0)
    assert (never.met, never.rho, never.margin) == (True, 0.0, 1.0)
    assert Check("stall_time", "park", 4.0, 0.0).margin == 1.0
    # no value (a divergence): missed by -inf, written null
    blank = Check("duration", None, 30.0, None)
    assert (blank.met, blank.margin) == (False, -math.inf)
    assert blank.record()["margin"] is None
    assert blank.record()["met"] is False


def test_a_check_is_written_and_read_back_as_the_same_data() -> None:
    check = Check("turn_rate_jitter", "orbit", 0.07, 0.2, advice="a longer look-ahead")
    assert Check.read(json.loads(json.dumps(check.record()))) == check


def test_a_runs_margin_is_its_least_and_names_its_check() -> None:
    checks = [
        Check("duration", None, 30.0, 12.0),
        Check("cross_track_error_max", "go", 0.1, 0.09),
        Check("speed_jump_max", "go", 2.0, 0.5),
    ]
    margin, name = run_margin(checks, "success")
    assert (margin, name) == (pytest.approx(0.1), "go: cross_track_error_max")
    # a run its checks do not decide: -inf, named by its outcome
    assert run_margin(checks, "timeout") == (-math.inf, "timeout")
    assert margin_fields([], "diverged") == {
        "margin": None,
        "margin_check": "diverged",
        "margin_metric": "diverged",
    }
    # nothing checked: +inf, no check named
    assert margin_fields([], "success") == {
        "margin": None,
        "margin_check": None,
        "margin_metric": None,
    }
    # the check's metric as data, for a campaign to count the runs' margins by
    assert margin_fields(checks, "success")["margin_metric"] == "cross_track_error_max"


@pytest.mark.parametrize("bound", [0.05, 5.0])
def test_summary_json_holds_the_runs_margin(tmp_path: Path, bound: float) -> None:
    """Judged as a run is, missed (2 m from the target, max 0.05 m) and met."""
    result = circle_run()
    mission = {
        "version": 1,
        "name": "circle",
        "robot": {"dt": 0.01, "limits": {"v": 10.0, "omega": 20.0, "v_rate": None}},
        "expect": {"final_position_error": {"max": bound}, "duration": {"max": 40.0}},
    }
    result.mission = mission
    judge(result, mission)
    write_run(result, tmp_path, plots=False, animate=False)
    summary = json.loads((tmp_path / "summary.json").read_text())
    margins = {c["metric"]: c["margin"] for c in summary["expectations"]}
    assert summary["margin"] == min(margins.values())
    assert summary["margin_check"] == min(margins, key=lambda name: margins[name])
    for check in summary["expectations"]:
        assert check["rho"] == pytest.approx(check["max"] - check["value"])
        assert (check["margin"] >= 0.0) == check["met"]
    assert (summary["margin"] >= 0.0) == (summary["outcome"] == "success")
    assert summary["outcome"] == ("success" if bound == 5.0 else "expect-failed")


def test_runs_csv_and_campaign_json_carry_the_margins() -> None:
    metrics = (0.0,) * len(METRICS)
    rows = [
        Row(0, 1, "success", (), metrics, "", PATH, (), 0.5, "go: speed_jump_max", (), JUMP),
        Row(
            1,
            2,
            "expect-failed",
            (),
            metrics,
            "...",
            PATH,
            (),
            -0.25,
            "go: duration",
            (),
            "duration",
        ),
        Row(
            2,
            3,
            "timeout",
            (),
            metrics,
            "phase 'go' timed out",
            PATH,
            (),
            None,
            "timeout",
            (),
            "timeout",
        ),
        Row(3, 4, "success", (), metrics, "", PATH, (), 0.1, "park: speed_jump_max", (), JUMP),
    ]
    columns = header([])
    assert columns[-3:] == ["margin", "margin_check", "reason"]
    lines = list(csv.reader([",".join(r.cells()) for r in rows[:3]]))
    assert [line[-3:-1] for line in lines] == [
        ["0.5", "go: speed_jump_max"],
        ["-0.25", "go: duration"],
        ["", "timeout"],
    ]
    aggregate = Aggregate({})
    for row in rows:
        aggregate.add(row)
    margin = aggregate.statistics()["margin"]
    assert (margin["min"], margin["max"], margin["below_zero"]) == (-0.25, 0.5, 2)
    # the quantiles are over the 3 finite margins; the timeout missed without one
    assert (margin["finite"], margin["minus_inf"]) == (3, 1)
    assert margin["set_by"] == {"speed_jump_max": 2, "duration": 1, "timeout": 1}
    # the worst runs by margin: the timeout (-inf), then the smaller margin
    assert [run for run, *_ in aggregate.worst_runs()][:2] == [2, 1]
    assert aggregate.worst_runs()[1][4:] == (-0.25, "go: duration")


def test_a_failed_check_says_when_it_first_failed(tmp_path: Path) -> None:
    """A failed peak check's first sample beyond its bound, as verdicts.png
    marks it; a level check (the duration) has none."""
    result = circle_run()
    mission = {
        "version": 1,
        "name": "circle",
        "robot": {"dt": 0.01, "limits": {"v": 10.0, "omega": 20.0, "v_rate": None}},
        "expect": {"final_position_error": {"max": 0.05}, "duration": {"max": 10.0}},
    }
    result.mission = mission
    judge(result, mission)
    write_run(result, tmp_path, plots=False, animate=False)
    summary = json.loads((tmp_path / "summary.json").read_text())
    failed = {c["metric"]: c for c in summary["expectations"] if not c["met"]}
    last = result.samples - 1  # the final error is the last sample's
    assert failed["final_position_error"]["first_violation"] == {
        "time": float(result.t[last]),
        "sample": last,
    }
    assert failed["duration"]["first_violation"] is None
    met = [c for c in summary["expectations"] if c["met"]]
    assert all("first_violation" not in c for c in met)


def test_a_miss_by_a_hair_is_said_with_the_digits_that_tell_it() -> None:
    """3.0000000116 against a maximum of 3 read `3 (max 3)`, a miss that reads
    as met: the value is given to as many digits as tell it from its bound."""
    from wmr_mission.output.report import _missed
    from wmr_mission.verdicts.check import Check, beside

    assert beside(3.0000000116, 3.0, 3) == ("3.00000001", "3")
    assert beside(2.3601, 10.0, 3) == ("2.36", "10")
    assert beside(3.0, 3.0, 3) == ("3", "3")
    assert Check("turn_rate_jump_max", "drive", 3.0, 3.0000000116).words() == (
        "drive: turn_rate_jump_max = 3.00000001 (max 3)"
    )
    record = Check("turn_rate_jump_max", "drive", 3.0, 3.0000000116).record()
    assert _missed(record) == "turn_rate_jump_max\n3.00000001 (max 3)"
