"""The terminal's short answers: a mission given to `sweep` and a campaign given
to `run` in one line; `sweep --runs` instead of the campaign's `runs`; `sweep
--set` for a field of the mission in every run."""

from __future__ import annotations

import csv
import json
import re
import shlex
from pathlib import Path

import pytest
from conftest import the_tests_package
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


def _campaign(tmp_path: Path, runs: int = 2) -> Path:
    campaign = tmp_path / "c.yaml"
    campaign.write_text(
        f"version: 1\nname: c\nmission: {DATA / 'short.yaml'}\nruns: {runs}\nseed: 3\n"
        "vary:\n  robot.initial_state.theta: {uniform: [-3.0, 3.0]}\n",
        encoding="utf-8",
    )
    return campaign


def test_sweep_runs_replaces_the_campaigns_runs(tmp_path: Path) -> None:
    campaign = _campaign(tmp_path, runs=50)
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


def test_sweeps_rate_says_what_it_counts_and_where_the_time_went(tmp_path: Path) -> None:
    out = tmp_path / "out"
    code, stdout, err = _invoke(
        "sweep", str(_campaign(tmp_path)), "--workers", "1", "--no-plots", "--out", str(out)
    )
    assert code in (0, 1), err
    record = json.loads((out / "campaign.json").read_text())
    match = re.search(
        r"^2 runs simulated in ([\d.]+) s \(([\d.]+) runs per second of simulating\); the "
        r"sweep took ([\d.]+) s: start-up ([\d.]+) s, runs ([\d.]+) s, the rest \(checks, "
        r"worst runs, figures\) ([\d.]+) s$",
        stdout,
        re.MULTILINE,
    )
    assert match is not None, stdout
    simulating, rate, total, startup, runs, rest = map(float, match.groups())
    assert simulating == runs == round(record["wall_seconds"], 1)
    assert rate == round(record["missions_per_second"], 1)
    # the parts add up to the whole, to the rounding of each
    assert abs(startup + runs + rest - total) <= 0.2
    assert "missions/s" not in stdout


def test_sweep_set_sets_the_mission_of_every_run_and_its_replay(tmp_path: Path) -> None:
    campaign, out = _campaign(tmp_path), tmp_path / "out"
    code, _, err = _invoke(
        "sweep", str(campaign), "--set", "robot.dt=0.01", "--workers", "1", "--no-plots",
        "--out", str(out),
    )  # fmt: skip
    assert code in (0, 1), err
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["settings"] == ["robot.dt=0.01"]
    record = json.loads((out / "campaign.json").read_text())
    worst = record["worst"][0]
    words = shlex.split(worst["replay"])
    assert words[3:5] == ["--set", "robot.dt=0.01"]  # before the run's own values
    # The replay reproduces the run's row: its samples are 0.01 s apart.
    replayed = tmp_path / "replayed"
    code, _, err = _invoke(*words[1:], "--no-plots", "--out", str(replayed))
    assert code in (0, 1), err
    with (replayed / "trajectory.csv").open() as stream:
        rows_read = csv.DictReader(stream)
        times = [float(next(rows_read)["t"]) for _ in range(2)]
    assert times[1] - times[0] == pytest.approx(0.01, abs=1e-12)
    with (out / "runs.csv").open() as stream:
        rows = {row["run"]: row for row in csv.DictReader(stream)}
    summary = json.loads((replayed / "summary.json").read_text())
    assert (
        float(rows[str(worst["run"])]["final_position_error"])
        == (summary["final"]["position_error"])
    )


def test_sweep_set_refuses_a_varied_field_and_a_bad_value(tmp_path: Path) -> None:
    campaign, out = _campaign(tmp_path), tmp_path / "out"
    code, _, err = _invoke("sweep", str(campaign), "--set", "robot.initial_state.theta=1")
    assert code == 1
    assert err == (
        "--set robot.initial_state.theta=1: the campaign varies 'robot.initial_state.theta', "
        "which this sets for every run: set a field the campaign does not vary, or change its "
        "vary\n"
    )
    code, _, err = _invoke("sweep", str(campaign), "--set", "robot.dt=-1", "--out", str(out))
    assert code == 1
    assert err == "--set robot.dt=-1: robot.dt: should be greater than 0, got -1\n"  # one line
    assert not out.exists()
    # around the varied field: refused as such, before the mission it would break
    code, _, err = _invoke("sweep", str(campaign), "--set", "robot={}")
    assert code == 1
    assert err.startswith("--set robot={}: the campaign varies 'robot.initial_state.theta'")


def test_run_campaign_overrides_set_the_mission_as_sweep_set_does(tmp_path: Path) -> None:
    from wmr_mission import run_campaign

    campaign = _campaign(tmp_path)
    code, _, err = _invoke(
        "sweep", str(campaign), "--set", "robot.dt=0.01", "--workers", "1", "--no-plots",
        "--out", str(tmp_path / "cli"),
    )  # fmt: skip
    assert code in (0, 1), err
    result = run_campaign(campaign, workers=1, overrides={"robot.dt": 0.01})
    with (tmp_path / "cli" / "runs.csv").open() as stream:
        expected = list(csv.DictReader(stream))
    assert [str(row["final_position_error"]) for row in result.rows] == [
        row["final_position_error"] for row in expected
    ]
    unset = run_campaign(campaign, workers=1)
    assert [row["final_position_error"] for row in unset.rows] != [
        row["final_position_error"] for row in result.rows
    ]


def test_a_sweeps_manifest_says_how_its_runs_ran(tmp_path: Path) -> None:
    """In a fresh process the loop is compiled (or its cache loaded) by the
    sweep's warm-up, after the directory and its first manifest are made: the
    manifest is written again with the loop as the runs ran it."""
    import os
    import subprocess
    import sys

    out = tmp_path / "out"
    done = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "sweep", str(_campaign(tmp_path)), "--workers",
         "1", "--no-plots", "--out", str(out)],
        cwd=tmp_path, env=the_tests_package(dict(os.environ)),
        capture_output=True, text=True, timeout=600, check=False,
    )  # fmt: skip
    assert done.returncode in (0, 1), done.stderr
    manifest = json.loads((out / "manifest.json").read_text())
    plain = os.environ.get("WMR_MISSION_NO_JIT") == "1"
    assert manifest["loop"] == ("plain Python" if plain else "compiled")


def test_sweep_set_reaches_the_figures_the_report_and_refuses_the_seed(tmp_path: Path) -> None:
    """The settings are the mission every run starts from: the campaign's
    figures draw its regions and bounds, `view`'s replays carry them; the
    sensors' seed is the campaign's to draw."""
    import numpy as np

    from wmr_mission import run_campaign
    from wmr_mission.campaign import sweep
    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.campaign.reader import load_campaign_dir
    from wmr_mission.spec.loader import overrides_of

    campaign, out = _campaign(tmp_path), tmp_path / "out"
    code, _, err = _invoke("sweep", str(campaign), "--set", "sensors.seed=5")
    assert (code, err) == (1, "--set sensors.seed=5: each run's sensor seed is drawn from the "
                              "campaign's seed; set the campaign's seed instead\n")  # fmt: skip
    settings = overrides_of(
        {"regions.yard.max": [0.5, 1.5], "expect.final_position_error.max": np.float32(0.5)}
    )
    loaded = load_campaign(campaign, settings)
    mission = sweep._mission(loaded)
    assert mission["regions"]["yard"]["max"] == [0.5, 1.5]
    assert mission["expect"]["final_position_error"]["max"] == 0.5
    # numpy values are written as the numbers they are, in the replay and the manifest
    result = run_campaign(campaign, out=out, workers=1, overrides={"robot.limits.v": np.int64(2)})
    assert result.summary["worst"][0]["replay"].split()[3:5] == ["--set", "robot.limits.v=2"]
    report = load_campaign_dir(out)
    assert report.replay(0).split()[3:5] == ["--set", "robot.limits.v=2"]
    assert report.replay(0) == next(w["replay"] for w in result.summary["worst"] if w["run"] == 0)
