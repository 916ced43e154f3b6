"""Campaigns count recoveries: how often each reaction fired, success with and without one."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from wmr_mission.campaign.aggregate import clopper_pearson
from wmr_mission.campaign.recovery import RecoveryCounts
from wmr_mission.campaign.rows import Row
from wmr_mission.campaign.sweep import run_campaign

MISSION = """version: 1
name: pond-leg
robot:
  dt: 0.02
  initial_state: {x: 0, y: 0, theta: 0}
  limits: {v: 2, omega: 3}
regions:
  pond: {type: circle, center: [4, 0], radius: 1}
geofence: {keep_out: [pond], margin: 0.1}
on_breach: detour
contingencies:
  detour:
    phases:
      - name: around
        track:
          path:
            type: polyline
            points: [[3.4, -1.4], [5, -1.4], [6.2, 0]]
            corner_radius: 0.3
            speed: 1.0
        until: {near: {point: [6.2, 0], tolerance: 0.1}}
        timeout: 20
phases:
  - name: leg
    track:
      path: {type: polyline, points: [[8, 0]], speed: 1.0}
    until: {near: {point: [8, 0], tolerance: 0.1}}
    timeout: 30
expect:
  speed_at_limit: null
  turn_rate_at_limit: null
  tracking_error_max: null
"""

CAMPAIGN = """version: 1
name: ponds
mission: pond-leg.yaml
runs: 1
seed: 0
vary:
  regions.pond.center: {grid: [[4, 0], [4, 3], [4, 0.2]]}
"""


def _row(run: int, outcome: str, fired: tuple[str, ...]) -> Row:
    return Row(run, 0, outcome, (), (), "", np.zeros((2, 0), dtype=np.float32), fired)


def test_counts_split_success_with_and_without_recovery() -> None:
    counts = RecoveryCounts()
    for row in [
        _row(0, "success", ()),
        _row(1, "success", ("detour",)),
        _row(2, "success", ("retry", "retry", "detour")),
        _row(3, "breached", ("detour",)),
        _row(4, "timeout", ()),
    ]:
        counts.add(row)
    stats = counts.statistics(clopper_pearson)
    assert stats["success_without_recovery"]["count"] == 1
    assert stats["success_after_recovery"]["count"] == 2
    assert stats["needed"] == 3
    assert stats["recovery_rate"]["rate"] == pytest.approx(2 / 3)
    assert stats["recovery_rate"]["interval"] == list(clopper_pearson(2, 3))
    assert stats["fired"] == {
        "detour": {"times": 3, "runs": 3},
        "retry": {"times": 2, "runs": 1},
    }


def test_a_campaign_reports_its_recovery_rate(tmp_path: Path) -> None:
    (tmp_path / "pond-leg.yaml").write_text(MISSION)
    (tmp_path / "ponds.yaml").write_text(CAMPAIGN)
    result = run_campaign(tmp_path / "ponds.yaml", workers=1)
    record = result.summary
    recovery = record["recovery"]
    # the pond on the leg is detoured twice; the one 3 m north is never breached
    assert record["runs"] == 3
    assert recovery["needed"] == 2
    assert recovery["fired"] == {"detour": {"times": 2, "runs": 2}}
    assert recovery["success_without_recovery"]["count"] == 1
    assert recovery["success_after_recovery"]["count"] == record["succeeded"] - 1


def test_the_shipped_patrol_campaign_recovers_from_every_breach(tmp_path: Path) -> None:
    """A small version of missions/campaigns/patrol-detour-ponds.yaml (its 40
    runs in docs/campaigns.md): ponds on the route are breached and detoured,
    and each of those runs still succeeds."""
    import yaml

    root = Path(__file__).resolve().parents[1]
    shipped = root / "missions" / "campaigns" / "patrol-detour-ponds.yaml"
    campaign = yaml.safe_load(shipped.read_text(encoding="utf-8"))
    campaign["mission"] = str(root / "missions" / "patrol-detour.yaml")
    campaign["runs"] = 8
    campaign["vary"]["regions.pond.radius"] = {"uniform": [0.8, 1.2]}  # all on the route
    path = tmp_path / "ponds.yaml"
    path.write_text(yaml.safe_dump(campaign), encoding="utf-8")
    recovery = run_campaign(path, workers=1).summary["recovery"]
    assert recovery["needed"] == 8
    assert recovery["fired"] == {"detour": {"times": 8, "runs": 8}}
    assert recovery["recovery_rate"]["count"] == 8
    assert recovery["success_after_recovery"]["count"] == 8
