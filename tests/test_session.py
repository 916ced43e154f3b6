"""A mission driven step by step from Python (docs/python-api.md, "A mission
step by step"): the samples of `run`, byte for byte."""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest
import yaml
from conftest import the_tests_package

from wmr_mission import load_mission, mission_from_dict, run_mission, start_mission
from wmr_mission.output.rundir import trajectory_csv_text

ROOT = Path(__file__).resolve().parent.parent
MISSIONS = ROOT / "missions"


@pytest.mark.parametrize(("name", "chunk"), [("case1", 100), ("case2", 100), ("case2", 37)])
def test_a_session_stepped_to_its_end_gives_the_bytes_of_run(name: str, chunk: int) -> None:
    mission = load_mission(MISSIONS / f"{name}.yaml")
    expected = trajectory_csv_text(run_mission(mission))
    session = start_mission(mission)
    steps = 0
    while session.step(chunk):
        steps += 1
        assert session.sample == steps * chunk
    result = session.result()
    assert result.succeeded, result.message
    assert result.reference is None  # no change: no reference column
    assert trajectory_csv_text(result) == expected
    assert session.done
    assert not session.step(1)


def _patrol_with_timed_updates() -> tuple[dict[str, object], list[dict[str, object]]]:
    """The re-planned patrol with its second update on time (52.0 s), and its updates."""
    data = yaml.safe_load((MISSIONS / "replanned-patrol.yaml").read_text())
    updates = data["phases"][0]["updates"]
    updates[1]["when"] = {"elapsed": 52.0}
    return data, updates


def test_a_path_set_from_python_gives_the_bytes_of_the_same_update_scripted() -> None:
    data, updates = _patrol_with_timed_updates()
    scripted = run_mission(mission_from_dict(data))
    assert [t.time for t in scripted.transitions if t.condition == "update"] == [25.0, 52.0]
    del data["phases"][0]["updates"]  # type: ignore[index]
    session = start_mission(mission_from_dict(data))
    for t, update in zip((25.0, 52.0), updates, strict=True):
        session.run_until(t)
        assert session.t == t
        assert session.phase == "patrol"
        session.set_path(update["path"])  # type: ignore[arg-type]
        # the new route is joined where it passes nearest the estimate
        reference = session.reference
        assert reference is not None
        assert abs(reference[0] - session.estimate[0]) < 0.05
    result = session.result()
    assert result.succeeded, result.message
    assert trajectory_csv_text(result) == trajectory_csv_text(scripted)
    why = [t.why for t in result.transitions if t.condition == "update"]
    assert all(w is not None and "set from Python" in w for w in why), why


def test_a_target_set_from_python_is_parked_at() -> None:
    session = start_mission(load_mission(MISSIONS / "park.yaml"))
    assert session.phase == "park"
    session.step(50)
    session.set_target(0.5, -0.5, 0.0)
    result = session.result()
    end = len(result.t) - 1
    assert abs(result.x[end] - 0.5) < 0.03
    assert abs(result.y[end] + 0.5) < 0.03


def test_changes_the_phase_cannot_take_are_refused_plainly() -> None:
    session = start_mission(load_mission(MISSIONS / "park.yaml"))
    with pytest.raises(ValueError, match="set_path applies to a track phase; phase 'park'"):
        session.set_path({"type": "line", "heading": 0, "speed": 1})
    with pytest.raises(ValueError, match="whole number of samples"):
        session.step(-1)
    tracked = start_mission(load_mission(MISSIONS / "case1.yaml"))
    with pytest.raises(ValueError, match=r"not a valid path: path\.line\.speed"):
        tracked.set_path({"type": "line", "heading": 0, "speed": -1})
    with pytest.raises(ValueError, match="set_target applies to a regulate phase"):
        tracked.set_target(0, 0, 0)
    tracked.result()
    with pytest.raises(RuntimeError, match="the mission has ended"):
        tracked.set_path({"type": "line", "heading": 0, "speed": 1})


def test_the_docs_example_replans_round_the_rock(tmp_path: Path) -> None:
    text = (ROOT / "docs" / "python-api.md").read_text(encoding="utf-8")
    section = text.split("## A mission step by step", 1)[1].split("\n## ", 1)[0]
    (block,) = re.findall(r"```python\n(.*?)```", section, re.S)
    completed = subprocess.run(
        [sys.executable, "-c", block],
        cwd=tmp_path,
        env=the_tests_package(dict(os.environ)),
        capture_output=True,
        text=True,
        check=False,
    )
    assert completed.returncode == 0, completed.stderr[-3000:]
    seen, clearance = completed.stdout.splitlines()
    assert re.fullmatch(r"rock seen at t = 2\.2 s; success: all phases completed", seen), seen
    margin = float(re.fullmatch(r"closest to the rock: (\S+) m off its edge", clearance)[1])  # type: ignore[index]
    assert margin > 0.3
