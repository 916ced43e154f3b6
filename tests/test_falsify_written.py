"""A falsification checks and plans its campaign's mission once per
combination of the choice values, and writes each evaluation's drawn pose into
the plan, as a sweep does (wmr_mission.campaign.written)."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import pytest

from wmr_mission.campaign import written
from wmr_mission.campaign.falsify import evaluate
from wmr_mission.campaign.falsify.evaluate import evaluate_draws
from wmr_mission.campaign.falsify.loop import draws_of
from wmr_mission.campaign.falsify.space import Space
from wmr_mission.campaign.load import LoadedCampaign, load_campaign

ROOT = Path(__file__).resolve().parents[1]
CASE2 = ROOT / "missions" / "campaigns" / "case2-headings.yaml"


def test_case2_evaluations_check_the_mission_once_per_noise_level(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Twelve evaluations of case2-headings in one process meet its three
    noise levels: three missions checked and planned, the heading and the
    initial estimate of the others written into the plan."""
    monkeypatch.setattr(written, "_current", written._Current())  # no base kept from before
    loaded = load_campaign(CASE2)
    space = Space(loaded.campaign)
    rng = np.random.default_rng(7)
    points = rng.uniform(space.lower(), space.upper(), size=(12, space.dimension))
    draws = draws_of(space, 3, 0, points.tolist())
    checked = []
    across, whole = LoadedCampaign.mission_across_fields, LoadedCampaign.mission_with

    def counted_across(self: LoadedCampaign, overrides: Any) -> Any:
        checked.append(overrides)
        return across(self, overrides)

    def counted_whole(self: LoadedCampaign, overrides: Any) -> Any:
        checked.append(overrides)
        return whole(self, overrides)

    monkeypatch.setattr(LoadedCampaign, "mission_across_fields", counted_across)
    monkeypatch.setattr(LoadedCampaign, "mission_with", counted_whole)
    evaluations = evaluate_draws(loaded, draws, None)
    noise = {str(draw.values["sensors.noise_std"]) for draw in draws}
    assert len(noise) == 3
    assert all(e.ran for e in evaluations)
    assert len(checked) == len(noise)
    # and each is the evaluation of its mission checked and planned whole
    whole_runs = written.Written(loaded)
    whole_runs.writes = False
    monkeypatch.setattr(evaluate, "written_runs", lambda _: whole_runs)
    assert evaluate_draws(loaded, draws, None) == evaluations
    assert len(checked) == len(noise) + len(draws)
