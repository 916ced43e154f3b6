"""The worst runs of a campaign per kind of failure: each check a run missed
(its row's checks, as data) or each outcome that ended a run."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
from conftest import the_tests_package

from wmr_mission.campaign.aggregate import WORST_PER_FAILURE, WORST_RUNS, Aggregate, failures_of
from wmr_mission.campaign.rows import METRICS, Row
from wmr_mission.campaign.sweep import _beyond
from wmr_mission.verdicts.check import Check
from wmr_mission.verdicts.metrics import unmet

PATH = np.zeros((2, 0), dtype=np.float32)
DATA = Path(__file__).parent / "data" / "campaigns"


def _row(run: int, outcome: str, missed: tuple[Check, ...] | str = (), error: float = 0.0) -> Row:
    """A row that missed the checks ``missed``, or ended with the reason ``missed``."""
    metrics = tuple(error if name == "final_position_error" else 0.0 for name in METRICS)
    if isinstance(missed, str):
        return Row(run, 1000 + run, outcome, (), metrics, missed, PATH, margin_check=outcome)
    reason = "expectation not met: " + "; ".join(unmet(list(missed))) if missed else ""
    least = min(missed, key=lambda c: c.margin, default=None)
    margin = None if least is None else least.margin
    check = None if least is None else least.name
    return Row(run, 1000 + run, outcome, (), metrics, reason, PATH, (), margin, check, missed)


def _missed(*checks: tuple[str | None, str, float, float]) -> tuple[Check, ...]:
    return tuple(Check(metric, phase, bound, value) for phase, metric, value, bound in checks)


def test_a_runs_missed_checks_are_read_as_data_never_from_its_words() -> None:
    """The row carries the checks it missed: the value as judged, not as its
    message rounds it to 6 digits, and the phase whatever its name holds."""
    missed = _missed(("leg; 2", "speed_jump_max", 2.3345678912, 2.0))
    row = _row(1, "expect-failed", missed)
    assert row.reason == "expectation not met: leg; 2: speed_jump_max = 2.33457 (max 2)"
    [failure] = failures_of(row)
    assert (failure.kind, failure.phase, failure.value, failure.bound) == (
        "speed_jump_max",
        "leg; 2",
        2.3345678912,
        2.0,
    )
    assert failure.margin == (2.0 - 2.3345678912) / 2.0
    assert failure.margin_check == "leg; 2: speed_jump_max"


def test_each_kind_keeps_the_runs_that_failed_it_worst() -> None:
    aggregate = Aggregate({})
    # jumps: worse by the ratio to each run's own bound, not by the value
    jumps = {1: (3.0, 2.0), 2: (5.0, 4.0), 3: (2.1, 1.0), 4: (2.6, 2.0), 5: (9.0, 8.0)}
    for run, (value, bound) in jumps.items():
        aggregate.add(_row(run, "expect-failed", _missed(("go", "speed_jump_max", value, bound))))
    aggregate.add(_row(6, "timeout", "phase 'go' timed out", error=0.5))
    aggregate.add(_row(7, "timeout", "phase 'go' timed out", error=2.0))
    aggregate.add(_row(8, "expect-failed", _missed((None, "max_constraint_violation", 0.01, 1e-3))))
    aggregate.add(_row(9, "success"))
    # a run missing one metric in two phases counts once, by its worst phase
    aggregate.add(
        _row(
            10,
            "expect-failed",
            _missed(("a", "stall_time", 1.0, 0.5), ("b", "stall_time", 3.0, 0.5)),
        )
    )
    kinds = aggregate.worst_by_failure()
    assert [(kind, count) for kind, count, _ in kinds] == [
        ("speed_jump_max", 5),
        ("timeout", 2),
        ("max_constraint_violation", 1),
        ("stall_time", 1),
    ]
    worst = {kind: [f.run for f in runs] for kind, _, runs in kinds}
    assert worst["speed_jump_max"] == [3, 1, 4][:WORST_PER_FAILURE]  # 2.1x, 1.5x, 1.3x
    assert worst["timeout"] == [7, 6]  # the larger final position error first
    (stall,) = kinds[3][2]
    assert (stall.phase, stall.value, stall.bound) == ("b", 3.0, 0.5)
    # worst/ holds the worst run of every kind, then the others by final error
    runs = [run for run, *_ in aggregate.worst_runs()]
    assert runs[:4] == [3, 7, 8, 10]
    assert len(runs) == max(WORST_RUNS, 4)
    assert failures_of(_row(9, "success")) == []


def test_the_histograms_show_few_failures_on_a_log_scale_with_units() -> None:
    """17 failures beside 1983 successes: drawn in front on a log scale where
    the fullest bin holds ten times more runs than the failures' fullest, so
    that they are seen; linear where the failures gather in one bin; every
    metric with a value names its unit."""
    from wmr_mission.campaign import figures
    from wmr_mission.campaign.rows import METRICS

    rng = np.random.default_rng(0)
    aggregate = Aggregate({})
    aggregate.success = [True] * 1983 + [False] * 17
    aggregate.metric_values = {
        # the failures spread beyond the bound, one or two a bin
        "max_constraint_violation": [*rng.uniform(0, 0.001, 1983), *rng.uniform(0.001, 0.003, 17)],
        # the failures all at one value: a bin of 17 beside bins of about 70
        "duration": [*rng.uniform(30, 32, 1983), *[32.0] * 17],
    }
    figure = figures._histograms(aggregate, {"max_constraint_violation": ("max", 0.001)})
    axes = {ax.get_title(): ax for ax in figure.axes}
    assert axes["max_constraint_violation"].get_yscale() == "symlog"
    assert axes["max_constraint_violation"].get_ylabel() == "runs (log scale)"
    assert axes["duration"].get_yscale() == "linear"
    assert axes["duration"].get_ylabel() == "runs"
    assert set(figures.UNITS) >= set(METRICS)  # every metric has its unit
    assert axes["max_constraint_violation"].get_xlabel() == "[constraint value]"
    assert axes["duration"].get_xlabel() == "[s]"


def test_the_histograms_draw_the_mission_s_clearance_min_as_a_lower_bound() -> None:
    """`clearance_min: 0.15`, the number alone, bounds every run's clearance
    from below: metrics.png draws it as `expect min 0.15` beside the upper
    bounds (it was left out: only `{max: ...}` was read)."""
    from wmr_mission.campaign import figures
    from wmr_mission.campaign.sweep import _bounds

    expect = {"clearance_min": 0.15, "final_position_error": {"max": 0.05}}
    bounds = _bounds({"expect": expect})
    assert bounds == {"final_position_error": ("max", 0.05), "clearance_min": ("min", 0.15)}
    aggregate = Aggregate({})
    aggregate.success = [True, True, False]
    aggregate.metric_values = {
        "clearance_min": [0.2, 0.17, 0.1],
        "final_position_error": [0.01, 0.02, 0.03],
    }
    axes = {ax.get_title(): ax for ax in figures._histograms(aggregate, bounds).axes}
    for name, label, at in (
        ("clearance_min", "expect min 0.15", 0.15),
        ("final_position_error", "expect max 0.05", 0.05),
    ):
        (line,) = [x for x in axes[name].get_lines() if x.get_label() == label]
        assert list(line.get_xdata()) == [at, at]


def test_a_lower_bound_s_failure_is_said_and_written_with_min(tmp_path: Path) -> None:
    """A formula's rho, or clearance_min, is bounded from below: the failures
    of campaign.json and the sweep's words give its bound as ``min``, as the
    run's summary.json does (they said ``max 0``)."""
    missed = (Check("always(speed >= 100)", "park", 0.0, -0.97, lower=True),)
    [failure] = failures_of(_row(1, "expect-failed", missed))
    assert failure.side == "min"
    assert _beyond({"phase": "park", "value": -0.97, "min": 0.0}) == " (park: -0.97, min 0)"
    assert _beyond({"phase": None, "value": 2.5, "max": 2.0}) == " (2.5, max 2)"
    mission = (
        (DATA / "short.yaml")
        .read_text()
        .replace("expect:\n", "expect:\n  temporal: ['always(speed >= 100)']\n")
    )
    (tmp_path / "short.yaml").write_text(mission)
    (tmp_path / "campaign.yaml").write_text(
        "version: 1\nname: never-fast\nmission: short.yaml\nruns: 2\nseed: 1\n"
        "vary:\n  robot.initial_state.theta: {uniform: [-0.5, 0.5]}\n"
    )
    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "sweep", str(tmp_path / "campaign.yaml"),
         "--no-plots", "--workers", "1", "--out", str(out)],
        capture_output=True, text=True, check=False, cwd=tmp_path,
        env=the_tests_package(dict(os.environ)),
    )  # fmt: skip
    assert done.returncode == 0, done.stderr  # no success_rate expected: the sweep ran
    [kind] = json.loads((out / "campaign.json").read_text())["failures"]
    assert kind["failure"] == "always(speed >= 100)"
    assert [sorted(w) for w in kind["worst"]] == [
        ["min", "phase", "replay", "run", "seed", "value"]
    ] * 2
    assert all(w["min"] == 0.0 and w["value"] < 0.0 for w in kind["worst"])
    assert ", min 0)" in done.stdout + done.stderr
    assert ", max 0)" not in done.stdout + done.stderr
