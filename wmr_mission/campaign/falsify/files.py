"""What a falsification writes: evaluations.csv, falsify.json, failing/N.yaml.

Each failing run is written as a mission of its own: the campaign's mission
with the run's values and its sensor seed in place, so that
``wmr-mission run failing/N.yaml`` is that run, byte for byte.
"""

from __future__ import annotations

import copy
import math
from collections.abc import Sequence
from typing import Any, Final

import yaml

from wmr_mission.campaign.falsify.evaluate import Evaluation
from wmr_mission.campaign.load import LoadedCampaign, override, replay_line, value_text
from wmr_mission.spec.loader import Document, apply_override

__all__ = [
    "BEST",
    "EVALUATIONS_FILE",
    "FAILING_DIR",
    "FALSIFY_FILE",
    "columns",
    "mission_text",
    "replay",
]

EVALUATIONS_FILE: Final = "evaluations.csv"
FALSIFY_FILE: Final = "falsify.json"
FAILING_DIR: Final = "failing"
BEST: Final = 5
"""Runs listed in falsify.json's ``best``, the lowest objective first."""


def columns(paths: Sequence[str]) -> list[str]:
    return [
        "evaluation",
        "seed",
        "outcome",
        *paths,
        "margin",
        "margin_check",
        "objective",
        "reason",
    ]


def number_text(value: float) -> str:
    """A margin as text that reads back to the same float: ``-inf``, ``inf`` included."""
    return repr(value) if math.isfinite(value) else ("inf" if value > 0 else "-inf")


def cells(evaluation: Evaluation) -> list[str]:
    return [
        str(evaluation.index),
        str(evaluation.seed),
        evaluation.outcome,
        *(v if isinstance(v, str) else value_text(v) for v in evaluation.values.values()),
        number_text(evaluation.margin),
        evaluation.margin_check or "",
        number_text(evaluation.objective),
        evaluation.reason,
    ]


def replay(loaded: LoadedCampaign, evaluation: Evaluation) -> str:
    """The ``wmr-mission run`` line of an evaluation, from the campaign's mission."""
    from wmr_mission.output.environment import own_fingerprint

    return replay_line(
        str(loaded.mission_path),
        loaded.setting_texts(),
        evaluation.values,
        evaluation.seed,
        own_fingerprint(),
        loaded.mission_sha256,
    )


def mission_text(loaded: LoadedCampaign, evaluation: Evaluation, campaign: str) -> str:
    """The run of ``evaluation`` as a standalone mission file: the campaign's
    mission with its values and sensor seed written in."""
    document = Document(data=copy.deepcopy(loaded.mission_document.data))
    overrides = [override(path, value) for path, value in evaluation.values.items()]
    overrides.append(override("sensors.seed", evaluation.seed))
    for one in overrides:
        problem = apply_override(document, one)
        if problem is not None:  # the run ran with these values: they fit
            raise ValueError(f"{one.source}: {problem}")
    head = [
        f"# Evaluation {evaluation.index} of `wmr-mission falsify {campaign}`:",
        f"# {evaluation.outcome}, margin {number_text(evaluation.margin)}"
        + (f" ({evaluation.margin_check})" if evaluation.margin_check else "")
        + ".",
        f"# The mission {loaded.mission_path.name} with these values in place:",
        *(f"#   {path} = {value_text(value)}" for path, value in evaluation.values.items()),
        f"#   sensors.seed = {evaluation.seed}",
    ]
    body = yaml.safe_dump(
        _plain(document.data),
        sort_keys=False,
        allow_unicode=True,
        width=100,
        default_flow_style=None,
    )
    return "\n".join(head) + "\n" + body


def _plain(data: Any) -> Any:
    """The document's data as plain dicts and lists, for yaml.safe_dump."""
    if isinstance(data, dict):
        return {str(k): _plain(v) for k, v in data.items()}
    if isinstance(data, list | tuple):
        return [_plain(v) for v in data]
    return data
