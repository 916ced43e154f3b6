"""The catalog of metrics (wmr_mission.spec.catalog): every list of metric names
derives from it, and a metric added from here with one entry and its
computation appears in the schema, summary.json, runs.csv, the signals
figure and ``view``."""

from __future__ import annotations

import csv
import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from wmr_mission.campaign.rows import METRICS
from wmr_mission.spec import catalog, models
from wmr_mission.verdicts.metrics import MEASURES
from wmr_mission.verdicts.signals import PANELS

ROOT = Path(__file__).resolve().parents[1]
SHORT = ROOT / "tests" / "data" / "campaigns" / "short.yaml"


def test_every_list_of_metrics_is_the_catalogs() -> None:
    phase = [m.name for m in catalog.phase_metrics()]
    run = [m.name for m in catalog.run_metrics()]
    assert set(MEASURES) == set(phase)  # each of a phase's has its computation
    # the settings every phase has (its settle time, its temporal formulas), then the metrics
    assert list(models.PhaseExpect.model_fields) == ["settle_time", "temporal", *phase]
    expect = list(models.Expect.model_fields)
    assert expect == ["settle_time", "temporal", *phase, "convergence_tolerance", *run]
    assert all(m.panel in PANELS for m in catalog.CATALOG.values())
    assert METRICS[: len(run) + 1] == (*run, "clearance_min")
    assert models.Expect().threshold("zone_intrusion_max") == models.Threshold(max=0.005)
    # a metric the models were built without would be judged but refused by `expect`
    late = catalog.Metric("late", "m", "A metric added too late.", "phase", ("inputs", "late"))
    with pytest.raises(ValueError, match=r"before wmr_mission\.spec\.models is imported"):
        catalog.add(late)
    assert "late" not in catalog.CATALOG


# A metric of a phase, added as a user of the catalog adds one: its entry,
# before the mission models are built, and its computation.
TOY = """
import json, sys
from pathlib import Path

from wmr_mission.spec import catalog

catalog.add(
    catalog.Metric(
        "toy_speed_max",
        "m/s",
        "[m/s] the largest |v| of a phase (a metric added from tests/).",
        "phase",
        ("inputs", "toy_speed_max"),
        default={"max": 0.3},
        default_words="{max: 0.3} unless set.",
        panel="saturation",
        column=True,
        where_measured=True,
    )
)

import numpy as np
from typer.testing import CliRunner

from wmr_mission.cli import app
from wmr_mission.commands.schema import schema_text
from wmr_mission.output.reader import load_run
from wmr_mission.verdicts import metrics
from wmr_mission.verdicts.signals import run_signals

metrics.MEASURES["toy_speed_max"] = lambda phase: float(np.max(np.abs(phase.v)))

out = Path(sys.argv[1])
mission, campaign = sys.argv[2], sys.argv[3]
(out / "schema.json").write_text(schema_text())
runner = CliRunner()
said = {}
for args in (
    ["run", mission, "--out", str(out / "run")],
    ["sweep", campaign, "--out", str(out / "campaign"), "--workers", "1", "--no-plots"],
    ["view", str(out / "run")],
):
    said[args[0]] = runner.invoke(app, args).exit_code
placed = [c for c in run_signals(load_run(out / "run")).checks if c.metric == "toy_speed_max"]
said["signals"] = [(c.phase, c.bound, c.value, c.met) for c in placed]
print(json.dumps(said))
"""


def test_a_metric_added_with_one_entry_is_everywhere(tmp_path: Path) -> None:
    campaign = tmp_path / "c.yaml"
    campaign.write_text(
        f"version: 1\nname: toy\nmission: {SHORT}\nruns: 2\nseed: 3\n"
        "vary:\n  robot.initial_state.theta: {choice: [0.5, -0.5]}\n"
    )
    env = {**os.environ, "WMR_MISSION_NO_JIT": "1"}
    done = subprocess.run(
        [sys.executable, "-c", TOY, str(tmp_path), str(SHORT), str(campaign)],
        capture_output=True,
        text=True,
        env=env,
        timeout=600,
        check=False,
    )
    assert done.returncode == 0, done.stderr
    said = json.loads(done.stdout.splitlines()[-1])
    # the park drives faster than the toy's bound of 0.3 m/s: expect-failed
    assert said["run"] == 1
    assert (said["sweep"], said["view"]) == (0, 0)
    # the schema: a key of the mission's and of each phase's `expect`
    schema = json.loads((tmp_path / "schema.json").read_text())
    key = schema["$defs"]["Expect"]["properties"]["toy_speed_max"]
    assert key["description"].endswith("{max: 0.3} unless set.")
    assert key["default"] == {"max": 0.3}
    assert "toy_speed_max" in schema["$defs"]["PhaseExpect"]["properties"]
    # summary.json: the phase's value, its check, and the run's worst
    run = tmp_path / "run"
    summary = json.loads((run / "summary.json").read_text())
    with (run / "trajectory.csv").open() as lines:
        v = np.array([float(row["v"]) for row in csv.DictReader(lines)])
    fastest = summary["phases"][0]["inputs"]["toy_speed_max"]
    assert fastest == pytest.approx(float(np.max(np.abs(v))), rel=1e-11)  # CSV: 12 digits
    assert fastest == pytest.approx(1.525, abs=1e-3)
    assert summary["toy_speed_max"] == fastest
    check = next(c for c in summary["expectations"] if c["metric"] == "toy_speed_max")
    assert (check["phase"], check["max"], check["value"]) == ("park", 0.3, fastest)
    assert check["met"] is False
    assert check["margin"] == pytest.approx(1 - fastest / 0.3)
    assert f"park: toy_speed_max = {fastest:.6g} (max 0.3)" in summary["message"]
    # the signals figure: the check placed on its panel, and drawn
    assert said["signals"] == [["park", 0.3, fastest, False]]
    assert (run / "verdicts.png").stat().st_size > 0
    # runs.csv: a column, each run's worst phase
    with (tmp_path / "campaign" / "runs.csv").open() as lines:
        rows = list(csv.DictReader(lines))
    speeds = [float(row["toy_speed_max"]) for row in rows]
    assert all(0.3 < speed <= 2.0 for speed in speeds)  # above the bound, within limits.v
    assert [row["outcome"] for row in rows] == ["expect-failed"] * 2
    statistics = json.loads((tmp_path / "campaign" / "campaign.json").read_text())
    assert statistics["metrics"]["toy_speed_max"]["max"] == max(speeds)
    # view: the check in the page's verdicts, with its unit, and the phases' column
    page = (run / "report.html").read_text()
    assert '{"name": "toy_speed_max", "unit": "m/s"}' in page
    assert '"metric": "toy_speed_max"' in page or '"metric":"toy_speed_max"' in page
    assert '"unit": "m/s"' in page or '"unit":"m/s"' in page


def test_a_check_of_a_metric_the_catalog_lacks_is_shown_not_drawn() -> None:
    """A summary.json written by a build with another metric: view shows its
    check without a unit, verdicts.png draws it on no panel."""
    from wmr_mission.verdicts.signals import line_of, panel_of

    assert catalog.unit_of("toy_speed_max") == ""
    assert (panel_of("toy_speed_max"), line_of("toy_speed_max")) == (None, None)
    assert catalog.unit_of("estimation_rms.theta") == "rad"
    assert catalog.unit_of("turn_rate_jitter") == "rad/s"
    assert (panel_of("final_position_error"), line_of("final_position_error")) == (
        "goal",
        "distance to the target",
    )
