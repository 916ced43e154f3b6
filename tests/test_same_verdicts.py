"""scripts/same_verdicts.py: runs judged by two versions of the judge,
compared float by float (docs/performance.md, "Judging a run")."""

from __future__ import annotations

import json
import pickle
from pathlib import Path

import pytest
from same_verdicts import ROOT, compare, judged

from wmr_mission.sim.plan import plan_mission
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission


def _verdicts(path: Path, margins: dict[str, float]) -> Path:
    path.write_text(json.dumps({name: {"margin": repr(m)} for name, m in margins.items()}))
    return path


def test_a_float_a_rounding_apart_is_a_difference(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    before = _verdicts(tmp_path / "before.json", {"case2": 0.1 + 0.2, "park": 0.5})
    after = _verdicts(tmp_path / "after.json", {"case2": 0.3, "park": 0.5})
    assert compare(before, after) == 1
    said = capsys.readouterr().out
    assert "case2: differs" in said
    assert "park" not in said
    assert compare(before, before) == 0


def test_a_run_judged_by_one_side_only_is_a_difference(tmp_path: Path) -> None:
    before = _verdicts(tmp_path / "before.json", {"case2": 0.5})
    after = _verdicts(tmp_path / "after.json", {"case2": 0.5, "park": 0.5})
    assert compare(before, after) == 1


def test_each_run_is_judged_as_run_and_as_a_row_under_its_mission_and_tight(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("WMR_MISSION_NO_JIT", "1")
    mission = load_mission(ROOT / "missions" / "case1.yaml")
    result = run_mission(plan_mission(mission))
    runs = tmp_path / "runs.pickle"
    runs.write_bytes(pickle.dumps([("case1", result, mission.model_dump(mode="json"))]))
    out = tmp_path / "verdicts.json"
    judged(runs, out)
    found = json.loads(out.read_text())
    assert set(found) == {"case1", "case1 (tight)"}
    assert found["case1"]["outcomes"][0] == found["case1"]["outcomes"][2] == "success"
    tight = found["case1 (tight)"]
    assert tight["outcomes"][0] == tight["outcomes"][2] == "expect-failed"
    assert tight["row"]["missed"]
    assert "loop_us_per_sample" not in tight["summary"]
    assert isinstance(tight["row"]["margin"], str)  # a float as its repr
    judged(runs, tmp_path / "again.json")
    assert compare(out, tmp_path / "again.json") == 0
