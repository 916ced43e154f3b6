"""`sweep` and `falsify` take Ctrl-C alike (wmr_mission.campaign.stops): before
the first run, one line and exit 130 with nothing kept; during the runs, the
runs that finished kept and the record saying why it stopped."""

from __future__ import annotations

import csv
import json
import os
import signal
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest

from wmr_mission.campaign import engine, sweep
from wmr_mission.campaign.falsify import command as falsify
from wmr_mission.campaign.falsify import evaluate
from wmr_mission.campaign.falsify.command import falsify_command
from wmr_mission.campaign.sweep import sweep_command

ROOT = Path(__file__).resolve().parents[1]
SHORT = ROOT / "tests" / "data" / "campaigns" / "short.yaml"
PARK = ROOT / "tests" / "data" / "falsify" / "park-campaign.yaml"


def _campaign(directory: Path, runs: int) -> Path:
    path = directory / "c.yaml"
    path.write_text(
        f"version: 1\nname: headings\nmission: {SHORT}\nruns: {runs}\nseed: 11\n"
        "vary:\n  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n",
        encoding="utf-8",
    )
    return path


def _ctrl_c() -> None:
    os.kill(os.getpid(), signal.SIGINT)


def _sweep(tmp_path: Path, out: Path) -> int:
    path = _campaign(tmp_path, 12)
    return sweep_command(path, out=out, workers=1, scheduler=None, plots=False)


def _falsify(tmp_path: Path, out: Path) -> int:
    return falsify_command(
        PARK, budget=12, method="random", seed=1, objective=None, first=False, workers=1,
        scheduler=None, out=out, plots=False,
    )  # fmt: skip


def _files(out: Path) -> list[str]:
    return sorted(p.name for p in out.iterdir()) if out.is_dir() else []


@pytest.mark.parametrize(
    ("command", "warm_up", "path"),
    [(_sweep, (sweep, "warm_up"), "c.yaml"), (_falsify, (falsify, "_warm_up"), str(PARK))],
    ids=["sweep", "falsify"],
)
def test_ctrl_c_before_the_first_run_exits_130_in_one_line_with_nothing_kept(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    command: Callable[[Path, Path], int],
    warm_up: tuple[Any, str],
    path: str,
) -> None:
    def stopped(*_: Any) -> float:
        _ctrl_c()
        raise AssertionError("Ctrl-C did not stop the warm-up")

    monkeypatch.setattr(*warm_up, stopped)
    out = tmp_path / "out"
    assert command(tmp_path, out) == 130
    err = capsys.readouterr().err
    assert "interrupted by Ctrl-C before the first run; nothing was written" in err
    assert "Traceback" not in err
    assert not any(name.endswith((".csv", ".json")) for name in _files(out))


def test_a_stop_owed_before_the_command_starts_is_taken_before_any_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A signal held since the command started (stop_owed) stops it at once."""
    from wmr_mission.campaign import stops

    monkeypatch.setattr(stops, "stop_owed", lambda: True)
    assert _sweep(tmp_path, tmp_path / "out") == 130
    assert "interrupted by Ctrl-C before the first run" in capsys.readouterr().err
    assert not (tmp_path / "out").exists()


def _stop_after_first(module: Any, name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Ctrl-C once the first task or batch of ``module.name`` has finished."""
    real = getattr(module, name)
    calls = []

    def then_stopped(*args: Any) -> Any:
        done = real(*args)
        calls.append(1)
        if len(calls) == 1:
            _ctrl_c()
        return done

    monkeypatch.setattr(module, name, then_stopped)


def test_ctrl_c_during_a_sweep_keeps_the_finished_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    one_run_each = lambda _s, runs, _w: [range(i, i + 1) for i in range(runs)]  # noqa: E731
    monkeypatch.setattr(engine, "tasks", one_run_each)
    _stop_after_first(engine, "run_rows", monkeypatch)
    out = tmp_path / "out"
    assert _sweep(tmp_path, out) == 130
    record = json.loads((out / "campaign.json").read_text(encoding="utf-8"))
    rows = list(csv.reader((out / "runs.csv").read_text(encoding="utf-8").splitlines()))[1:]
    assert record["interrupted"] is True
    assert record["stopped_by"] == "Ctrl-C"
    assert record["runs"] == len(rows) == 1
    assert "interrupted (Ctrl-C); the 1 finished runs are kept" in capsys.readouterr().err


def test_ctrl_c_during_a_search_keeps_the_finished_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    _stop_after_first(evaluate, "evaluate_draws", monkeypatch)
    out = tmp_path / "out"
    assert _falsify(tmp_path, out) == 130
    record = json.loads((out / "falsify.json").read_text(encoding="utf-8"))
    rows = (out / "evaluations.csv").read_text(encoding="utf-8").splitlines()[1:]
    assert record["interrupted"] is True
    assert record["stopped_by"] == "Ctrl-C"
    assert 1 <= record["evaluations"] == len(rows) < 12
    err = capsys.readouterr().err
    assert f"interrupted (Ctrl-C); the {len(rows)} finished runs are kept" in err


# --- an interrupted campaign's expect --------------------------------------------


def _grid_campaign(directory: Path, least: float) -> Path:
    """Four grid cells of one run each, in run order: a stop after the first
    run leaves three cells without runs."""
    path = directory / "grid.yaml"
    path.write_text(
        f"version: 1\nname: cells\nmission: {SHORT}\nruns: 1\nseed: 11\n"
        "vary:\n  robot.initial_state.theta: {grid: [0.1, 0.2, 0.3, 0.4]}\n"
        f"expect:\n  success_rate: {{min: {least}}}\n",
        encoding="utf-8",
    )
    return path


def _stopped_after_one_run(
    path: Path, out: Path, monkeypatch: pytest.MonkeyPatch, settings: tuple[str, ...] = ()
) -> dict[str, Any]:
    one_run_each = lambda _s, runs, _w: [range(i, i + 1) for i in range(runs)]  # noqa: E731
    monkeypatch.setattr(engine, "tasks", one_run_each)
    _stop_after_first(engine, "run_rows", monkeypatch)
    code = sweep_command(path, out=out, workers=1, scheduler=None, plots=False, settings=settings)
    assert code == 130
    record: dict[str, Any] = json.loads((out / "campaign.json").read_text(encoding="utf-8"))
    assert record["interrupted"] is True
    assert record["runs"] == 1
    return record


def test_an_interrupted_sweep_does_not_judge_its_expect_on_the_runs_done(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """One run of four, a success: 100 % of the runs done, but the campaign's
    rate is unknown, and three grid cells have no run."""
    out = tmp_path / "out"
    record = _stopped_after_one_run(_grid_campaign(tmp_path, 0.9), out, monkeypatch)
    assert record["success_rate"] == 1.0
    assert record["expectations"] == [
        {
            "metric": "success_rate",
            "min": 0.9,
            "value": 1.0,
            "met": None,
            "verdict": "not judged: interrupted after 1 of 4 runs",
        }
    ]
    assert record["planned_runs"] == 4
    assert record["missing_runs"] == 3
    assert [c["values"] for c in record["cells"]] == [{"robot.initial_state.theta": 0.1}]
    assert record["cells_without_runs"] == [
        {"robot.initial_state.theta": 0.2},
        {"robot.initial_state.theta": 0.3},
        {"robot.initial_state.theta": 0.4},
    ]
    assert record["cells_without_runs_count"] == 3
    report = capsys.readouterr().out
    assert "runs missing: 3 of the 4 planned (interrupted after 1)" in report
    assert (
        "grid cells with no runs (3): robot.initial_state.theta=0.2; "
        "robot.initial_state.theta=0.3; robot.initial_state.theta=0.4"
    ) in report
    assert "expect success_rate (min 0.9): not judged: interrupted after 1 of 4 runs" in report

    from wmr_mission.review import view

    meta = view.campaign_meta(out, tmp_path / "report.html")
    assert meta["missing_runs"] == 3
    assert meta["cells_without_runs"] == [
        "robot.initial_state.theta=0.2",
        "robot.initial_state.theta=0.3",
        "robot.initial_state.theta=0.4",
    ]
    assert [(e["met"], e["verdict"]) for e in meta["expectations"]] == [
        (None, "not judged: interrupted after 1 of 4 runs")
    ]


def test_an_interrupted_sweep_says_an_expect_missed_whatever_the_missing_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Every run times out: after one of four, even three successes would make
    0.75 of the campaign, below its 0.9."""
    out = tmp_path / "out"
    path = _grid_campaign(tmp_path, 0.9)
    record = _stopped_after_one_run(path, out, monkeypatch, ("phases.0.timeout=0.1",))
    assert record["succeeded"] == 0
    (expectation,) = record["expectations"]
    assert expectation["met"] is False
    assert expectation["verdict"] == "not met whatever the 3 missing runs give (at most 0.75)"
    report = capsys.readouterr().out
    assert "expect success_rate (min 0.9): not met whatever the 3 missing runs give" in report


def test_an_interrupted_record_without_verdicts_is_viewed_not_judged(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A campaign.json that says `met` of the runs done only (no `verdict`,
    fewer runs than planned) is not shown met."""
    out = tmp_path / "out"
    record = _stopped_after_one_run(_grid_campaign(tmp_path, 0.9), out, monkeypatch)
    for key in ("missing_runs", "cells_without_runs", "cells_without_runs_count"):
        record.pop(key, None)
    record["expectations"] = [{"metric": "success_rate", "min": 0.9, "value": 1.0, "met": True}]
    (out / "campaign.json").write_text(json.dumps(record), encoding="utf-8")

    from wmr_mission.review import view

    meta = view.campaign_meta(out, tmp_path / "report.html")
    assert meta["missing_runs"] == 3
    assert [(e["met"], e["verdict"]) for e in meta["expectations"]] == [
        (None, "not judged: interrupted after 1 of 4 runs")
    ]


def test_a_whole_sweep_judges_its_expect_and_lists_no_missing_cell(tmp_path: Path) -> None:
    out = tmp_path / "out"
    code = sweep_command(
        _grid_campaign(tmp_path, 0.5), out=out, workers=1, scheduler=None, plots=False
    )
    record = json.loads((out / "campaign.json").read_text(encoding="utf-8"))
    assert code == 0
    assert record["interrupted"] is False
    assert record["missing_runs"] == 0
    assert record["cells_without_runs"] == []
    assert record["cells_without_runs_count"] == 0
    (expectation,) = record["expectations"]
    assert (expectation["met"], expectation["verdict"]) == (True, "met")
