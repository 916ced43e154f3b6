"""What docs/mission-format.md says the shipped missions do, checked by running
them: which succeed and which fail ("Verdicts"), and what the phase table
prints of a threshold missed."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from failing import UNGATED_SET
from typer.testing import CliRunner

from wmr_mission.api import load_mission, run_mission
from wmr_mission.cli import app

ROOT = Path(__file__).resolve().parents[1]
MISSIONS = ROOT / "missions"
DOC = (ROOT / "docs" / "mission-format.md").read_text(encoding="utf-8")


def _said_to_fail() -> set[str]:
    """The shipped missions the docs say fail: ``all succeed but `A.yaml` and `B.yaml```,
    or none: ``all succeed (``."""
    found = re.search(r"all\s+succeed( but ((?:`[\w-]+\.yaml`(?:,\s+|\s+and\s+)?)+)|\s+\()", DOC)
    assert found is not None, "docs/mission-format.md no longer says which missions fail"
    return set(re.findall(r"`([\w-]+)\.yaml`", found.group(2) or ""))


def _outcome(name: str) -> str:
    return run_mission(load_mission(MISSIONS / f"{name}.yaml")).outcome.value


@pytest.mark.slow
@pytest.mark.parametrize("name", ["keep-out", "noisy-ekf", "disturbed"])
def test_the_missions_the_docs_name_succeed_or_fail_as_they_say(name: str) -> None:
    failing = _said_to_fail()
    assert failing == set()
    assert _outcome(name) == ("expect-failed" if name in failing else "success")


@pytest.mark.sweep
@pytest.mark.parametrize("path", sorted(MISSIONS.glob("*.yaml")), ids=lambda p: p.stem)
def test_every_shipped_mission_succeeds_unless_the_docs_say_it_fails(path: Path) -> None:
    assert _outcome(path.stem) == ("expect-failed" if path.stem in _said_to_fail() else "success")


@pytest.mark.slow
def test_the_table_names_each_threshold_missed(tmp_path: Path) -> None:
    # disturbed.yaml with its outliers let through to the inputs
    command = ["run", str(MISSIONS / "disturbed.yaml"), "--no-plots", "--out", str(tmp_path / "r")]
    command += UNGATED_SET
    result = CliRunner(env={"COLUMNS": "100"}).invoke(app, command)
    assert result.exit_code == 1
    lines = result.stdout.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("circle "))
    end = next(i for i, line in enumerate(lines) if line.startswith("stop "))
    verdict = [line[line.rindex("  ") :].strip() for line in lines[start:end] if "  " in line]
    assert lines[start].endswith("NOT MET")
    # each threshold missed, then its value and bound, in the verdict column
    assert "turn_rate_jump_max" in verdict
    value = verdict[verdict.index("turn_rate_jump_max") + 1]
    assert re.fullmatch(r"[\d.e+-]+ \(max 6\)", value), verdict
    assert DOC.count("`turn_rate_jump_max` / `12 (max 6)`") == 1
    assert value == "12 (max 6)"
