"""The wait for a plant's confirmed stop comes after the run's record
(wmr_mission.commands.run._confirm_stop): it settles only the acknowledgement,
and a record that vanished or cannot be read meanwhile is said, not a traceback."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import pytest

from wmr_mission.commands.run import _confirm_stop


class _Plant:
    """A plant whose robot acknowledged its zero command, and whose planner
    had a plan refused during the wait."""

    def confirm_stop(self) -> None:
        pass

    def report(self) -> dict[str, Any]:
        return {"zero_command_acknowledged": True, "plans_refused": 1}


def _ended() -> Any:
    return SimpleNamespace(realtime={"zero_command_acknowledged": None, "plans_refused": 0})


def test_only_the_acknowledgement_is_settled_after_the_record(tmp_path: Path) -> None:
    result = _ended()
    (tmp_path / "summary.json").write_text(json.dumps({"realtime": result.realtime}))
    _confirm_stop(_Plant(), result, tmp_path)  # type: ignore[arg-type]
    written = json.loads((tmp_path / "summary.json").read_text())["realtime"]
    # what the run ended with stays: the refused plan came after it
    assert written == {"zero_command_acknowledged": True, "plans_refused": 0}
    assert result.realtime == written


@pytest.mark.parametrize("damage", ["vanished", "torn"])
def test_a_record_gone_or_torn_in_the_wait_is_said_in_a_line(
    tmp_path: Path, damage: str, capsys: pytest.CaptureFixture[str]
) -> None:
    if damage == "torn":
        (tmp_path / "summary.json").write_text('{"realtime": {')
    _confirm_stop(_Plant(), _ended(), tmp_path)  # type: ignore[arg-type]
    [line] = capsys.readouterr().err.splitlines()
    assert line.startswith(f"{tmp_path / 'summary.json'}: cannot update: ")
    assert line.endswith("before the plant confirmed its stop")
