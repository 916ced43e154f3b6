"""The terminal's short answers: a mission given to `sweep` and a campaign given
to `run` in one line; `sweep --runs` instead of the campaign's `runs`."""

from __future__ import annotations

import json
from pathlib import Path

from typer.testing import CliRunner

from wmr_mission.campaign.models import MAX_RUNS
from wmr_mission.cli import MAX_SWEEP_RUNS, app

ROOT = Path(__file__).resolve().parents[1]
DATA = ROOT / "tests" / "data" / "campaigns"


def _invoke(*arguments: str) -> tuple[int, str, str]:
    result = CliRunner().invoke(app, list(arguments))
    return result.exit_code, result.stdout, result.stderr


def test_a_mission_given_to_sweep_is_answered_in_one_line() -> None:
    mission = ROOT / "missions" / "case2.yaml"
    code, out, err = _invoke("sweep", str(mission))
    assert code == 1
    assert out == ""
    assert err == f"{mission}: this is a mission: run it with `wmr-mission run {mission}`\n"


def test_a_campaign_given_to_run_is_answered_in_one_line(tmp_path: Path) -> None:
    campaign = ROOT / "missions" / "campaigns" / "case2-headings.yaml"
    code, _, err = _invoke("run", str(campaign), "--out", str(tmp_path / "r"))
    assert code == 1
    assert err == (f"{campaign}: this is a campaign: run it with `wmr-mission sweep {campaign}`\n")
    assert not (tmp_path / "r").exists()


def test_a_broken_campaign_still_gets_its_errors(tmp_path: Path) -> None:
    broken = tmp_path / "c.yaml"
    broken.write_text("version: 1\nname: c\nmission: nowhere.yaml\nruns: 0\n", encoding="utf-8")
    code, _, err = _invoke("sweep", str(broken))
    assert code == 1
    assert "this is a mission" not in err
    assert len(err.splitlines()) >= 1


def test_sweep_runs_replaces_the_campaigns_runs(tmp_path: Path) -> None:
    campaign = tmp_path / "c.yaml"
    campaign.write_text(
        f"version: 1\nname: c\nmission: {DATA / 'short.yaml'}\nruns: 50\nseed: 3\n"
        "vary:\n  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n",
        encoding="utf-8",
    )
    out = tmp_path / "out"
    code, stdout, err = _invoke(
        "sweep", str(campaign), "--runs", "3", "--workers", "1", "--no-plots", "--out", str(out)
    )
    assert code in (0, 1), err
    assert "3 runs" in stdout
    record = json.loads((out / "campaign.json").read_text())
    assert record["runs"] == record["planned_runs"] == 3
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["resolved_campaign"]["runs"] == 3  # the directory reads back as run
    assert len((out / "runs.csv").read_text().splitlines()) == 1 + 3
    assert MAX_SWEEP_RUNS == MAX_RUNS
