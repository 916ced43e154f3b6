"""A run's mission, its drawn values set and checked as ``run --set`` checks them.

The checks that sample paths and regions cost more than the run: they are
left out where `validate`'s checks at the axes' values cover the run
(:func:`mission_of`); :func:`checked_mission` runs every check, as the
run's ``replay`` command does.
"""

from __future__ import annotations

from collections.abc import Mapping

from wmr_mission.campaign.load import LoadedCampaign, override
from wmr_mission.campaign.models import Axis
from wmr_mission.campaign.plan import Draw
from wmr_mission.spec.checks import read_by_sampling_checks
from wmr_mission.spec.models import Mission

__all__ = ["checked_mission", "mission_of"]


def mission_of(loaded: LoadedCampaign, draw: Draw) -> tuple[Mission | None, str]:
    """The mission with the run's values, or None and why the mission refuses them.

    Checked as ``run --set`` checks it (:func:`checked_mission`), except that
    the checks that sample paths and regions (they cost more than the run) are
    left out where `validate`'s checks at the axes' values cover the run: no
    varied field is one they read, or one discrete axis is.
    """
    overrides = [override(path, value) for path, value in draw.values.items()]
    vary = loaded.campaign.vary
    if all(
        path in vary and vary[path].within_extremes(value) for path, value in draw.values.items()
    ):
        mission = loaded.mission_across_fields(overrides)
        if mission is not None and _sampled_by_validate(vary, mission):
            return mission, ""
    return checked_mission(loaded, draw)


def _sampled_by_validate(vary: Mapping[str, Axis], mission: Mission) -> bool:
    """Whether the checks `validate` ran at the axes' values cover this run:
    none of the varied fields is read by the sampling checks, or only one is and
    `validate` checked each value it takes (choice, grid). A value between the
    extremes of a continuous axis can break a path the extremes do not."""
    read = [path for path in vary if read_by_sampling_checks(path, mission)]
    return not read or (len(read) == 1 and vary[read[0]].kind in ("choice", "grid"))


def checked_mission(loaded: LoadedCampaign, draw: Draw) -> tuple[Mission | None, str]:
    """The mission with the run's values checked exactly as ``run --set`` checks
    it, or None and every error."""
    overrides = [override(path, value) for path, value in draw.values.items()]
    mission, diagnostics = loaded.mission_with(overrides)
    if mission is None:
        errors = [str(d) for d in diagnostics if d.severity == "error"]
        return None, "; ".join(errors)
    return mission, ""
