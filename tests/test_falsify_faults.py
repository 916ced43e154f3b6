"""`falsify` under faults, as `sweep` is (docs/reliability.md, "Campaigns"):
a full disk keeps every complete row and says in one line what could not be
written and what is kept (exit 2); a signal after the search, while the record
is written or the figures drawn, ends the command as the signal asked (130,
143) and draws no more."""

from __future__ import annotations

import errno
import json
import os
import signal
from pathlib import Path
from typing import Any

import pytest
from test_campaign_faults import disk_full_after, leftovers, one_line

from wmr_mission.campaign.falsify import command, figures
from wmr_mission.campaign.falsify.command import falsify_command

ROOT = Path(__file__).resolve().parents[1]
PARK = ROOT / "tests" / "data" / "falsify" / "park-campaign.yaml"
BUDGET = 12


def _falsify(out: Path, *, plots: bool = True) -> int:
    return falsify_command(
        PARK, budget=BUDGET, method="random", seed=1, objective=None, first=False, workers=1,
        scheduler=None, out=out, plots=plots,
    )  # fmt: skip


def _rows(out: Path) -> list[str]:
    return (out / "evaluations.csv").read_text(encoding="utf-8").splitlines()[1:]


def _record(out: Path) -> dict[str, Any]:
    data: dict[str, Any] = json.loads((out / "falsify.json").read_text(encoding="utf-8"))
    return data


def _figures(out: Path) -> list[str]:
    return sorted(p.name for p in out.glob("*.png"))


# --- a full disk ------------------------------------------------------------------


def test_a_full_disk_while_writing_rows_keeps_every_complete_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    with disk_full_after(700, "evaluations.csv"):  # the header and a few rows of ~150 bytes
        code = _falsify(out)
    assert code == 2
    line = one_line(capsys.readouterr().err)
    assert f"{out / 'evaluations.csv'}: cannot write: No space left on device" in line
    rows = _rows(out)
    record = _record(out)
    assert 0 < record["evaluations"] == len(rows) < BUDGET
    assert f"the search stopped after {len(rows)} runs" in line
    assert "evaluations.csv and falsify.json hold" in line
    assert [int(row.split(",")[0]) for row in rows] == list(range(len(rows)))
    assert record["interrupted"] is True
    assert "No space left on device" in record["stopped_by"]
    assert _figures(out) == []  # nothing more is written to a full disk
    assert leftovers(out) == []


@pytest.mark.parametrize("stage", ["falsify.json", "failing", "figures"])
def test_a_full_disk_after_the_search_is_one_line_and_keeps_the_runs(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    stage: str,
) -> None:
    out = tmp_path / "out"

    def full(*_: Any) -> Any:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(out / f"{stage}.tmp"))

    real = command.write_bytes_atomic

    def filling(path: Path, data: bytes) -> Path:
        if (stage == "falsify.json" and path.name == stage) or (
            stage == "failing" and path.parent.name == stage
        ):
            full()
        return real(path, data)

    monkeypatch.setattr(command, "write_bytes_atomic", filling)
    if stage == "figures":
        monkeypatch.setattr(figures, "draw_falsification", full)
    # a budget that finds failing runs: failing/N.yaml is written
    code = _falsify(out)
    assert code == 2
    line = one_line(capsys.readouterr().err)
    assert f"{out / stage}.tmp: cannot write: No space left on device" in line
    assert len(_rows(out)) == BUDGET
    if stage == "falsify.json":
        assert f"evaluations.csv holds the {BUDGET} runs done" in line
        assert not (out / "falsify.json").exists()
    else:
        assert _record(out)["evaluations"] == BUDGET
        assert f"evaluations.csv and falsify.json are in {out}" in line
    assert leftovers(out) == []


# --- a signal after the search -----------------------------------------------------


@pytest.mark.parametrize("number", [signal.SIGTERM, signal.SIGINT])
def test_a_signal_while_the_record_is_written_ends_the_command_without_figures(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    number: int,
) -> None:
    """The signal comes as falsify.json is written (held there, so that the
    record is whole): no figures are drawn, the record says it stopped."""
    out = tmp_path / "out"
    real = command.write_bytes_atomic

    def signalled(path: Path, data: bytes) -> Path:
        if path.name == "falsify.json":
            os.kill(os.getpid(), number)
        return real(path, data)

    monkeypatch.setattr(command, "write_bytes_atomic", signalled)
    assert _falsify(out) == 128 + number
    record = _record(out)
    assert record["interrupted"] is True
    assert record["stopped_by"] == ("Ctrl-C" if number == signal.SIGINT else "SIGTERM")
    assert record["evaluations"] == len(_rows(out)) == BUDGET
    assert _figures(out) == []
    err = capsys.readouterr().err
    assert f"the {BUDGET} finished runs are kept in {out}" in err
    assert "Traceback" not in err
    assert leftovers(out) == []


def test_a_signal_while_the_figures_are_drawn_stops_them(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    real = figures.draw_falsification

    def signalled(*args: Any) -> None:
        os.kill(os.getpid(), signal.SIGTERM)
        real(*args)

    monkeypatch.setattr(figures, "draw_falsification", signalled)
    assert _falsify(out) == 143
    record = _record(out)
    assert record["interrupted"] is True
    assert record["stopped_by"] == "SIGTERM"
    assert record["evaluations"] == len(_rows(out)) == BUDGET
    assert _figures(out) == []
    err = capsys.readouterr().err
    assert "Traceback" not in err
    assert leftovers(out) == []
