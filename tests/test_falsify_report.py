"""What `falsify` prints: each run is named by its evaluation number, the one
evaluations.csv, failing/N.yaml and the run lines give it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest

from wmr_mission.campaign.falsify.command import _report


def _record(failing: list[int]) -> dict[str, Any]:
    best = [
        {"evaluation": n, "outcome": "expect-failed", "objective": -0.5, "run": f"run {n}.yaml"}
        for n in failing
    ]
    return {
        "campaign": "park",
        "method": "cmaes",
        "evaluations": 40,
        "objective": "margin",
        "falsified": True,
        "failing_runs": len(failing),
        "runs_to_first_failure": failing[0] + 1,
        "lowest": -0.5,
        "best": best,
        "settings": {"budget": 40},
        "wall_seconds": 2.61,
    }


def test_the_first_failing_run_is_named_as_its_line_and_file_are() -> None:
    printed = _report(_record([21]), Path("out"), 1.0).splitlines()
    assert printed[1] == (
        "falsified: 1 failing run, the first run 21 (22 runs in); lowest margin -0.5"
    )
    assert printed[2] == "  21: expect-failed, margin -0.5: run 21.yaml"


def test_the_search_s_time_is_falsify_json_s_and_the_command_s_is_said_apart() -> None:
    """The runs' time printed is falsify.json's wall_seconds, not the whole
    command's (its checks, failing/ and figures too), which follows it."""
    printed = _report(_record([21]), Path("out"), 3.74).splitlines()
    assert printed[0] == "falsify park (cmaes): 40 runs in 2.6 s; the command took 3.7 s"


def test_several_failing_runs_are_counted_in_the_plural() -> None:
    printed = _report(_record([3, 9]), Path("out"), 1.0).splitlines()
    assert printed[1] == (
        "falsified: 2 failing runs, the first run 3 (4 runs in); lowest margin -0.5"
    )


def test_margins_png_places_each_run_at_its_evaluation_number(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The failing dot of evaluation 2 is at 2 on the axis named evaluation,
    the number of its row and of failing/2.yaml, not at 3."""
    from wmr_mission.campaign.falsify import figures
    from wmr_mission.campaign.falsify.evaluate import Evaluation

    drawn: list[Any] = []
    monkeypatch.setattr(figures, "save_figure", lambda fig, path: drawn.append(fig))
    runs = [
        Evaluation(n, n, {}, "success" if m > 0 else "expect-failed", m, None, m, "")
        for n, m in enumerate([0.4, 0.3, -0.2, 0.5])
    ]
    figures._margins(runs, None, tmp_path / "margins.png")
    (ax,) = drawn[0].axes
    assert ax.get_xlabel() == "evaluation"
    passing, failing = (c.get_offsets() for c in ax.collections[:2])
    assert failing.tolist() == [[2.0, -0.2]]
    assert [x for x, _ in passing.tolist()] == [0.0, 1.0, 3.0]


def test_a_failure_at_the_first_run_is_one_run_in() -> None:
    printed = _report(_record([0]), Path("out"), 1.0).splitlines()
    assert printed[1] == "falsified: 1 failing run, the first run 0 (1 run in); lowest margin -0.5"


def test_failing_runs_are_named_when_no_lowest_objective_run_fails() -> None:
    """With --objective the lowest runs may all meet every check while others
    fail: the report names the failing runs' files, never an empty list."""
    record = _record([3])
    record.update(
        objective="park: stall_time",
        failing_runs=2,
        runs_to_first_failure=4,
        lowest=0.5,
        best=[{"evaluation": 1, "outcome": "success", "objective": 0.5, "replay": "r"}],
        failing=[{"evaluation": n, "mission": f"failing/{n}.yaml"} for n in (3, 7)],
    )
    printed = _report(record, Path("out"), 1.0).splitlines()
    assert printed[1] == (
        "falsified: 2 failing runs, the first run 3 (4 runs in); lowest park: stall_time 0.5"
    )
    out = Path("out").resolve()
    assert printed[2:4] == [
        f"  3: wmr-mission run {out / 'failing' / '3.yaml'}",
        f"  7: wmr-mission run {out / 'failing' / '7.yaml'}",
    ]
