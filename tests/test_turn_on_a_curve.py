"""Under a turn-rate acceleration limit the tracking law's turn is stopped at
the way its output must move, relative to the part of the path's own turn
rate the robot already turns at (controllers/paper.py, ``track_input``;
docs/paper-notes.md, "Eq. (27) under acceleration limits: the turn stopped
relative to the path's")."""

from __future__ import annotations

import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "scripts"))

from judge_generated import GENERATED, judge_all  # noqa: E402


@pytest.mark.slow
def test_a_spiral_under_acceleration_limits_is_tracked_at_its_own_turn_rate(
    tmp_path: Path,
) -> None:
    """With the turn stopped at the way as if the way stood still, the turn
    rate was held below the spiral's, the heading short of the way and the
    robot 0.148 m off its spiral as the entry ended (0.105 allowed)."""
    [judged] = judge_all([GENERATED / "gen-021-elliptical-spiral.yaml"], tmp_path, workers=1)
    assert (judged.outcome, judged.sound, judged.problems) == ("success", True, ())
    assert judged.margin is not None
    assert judged.margin > 0.5
