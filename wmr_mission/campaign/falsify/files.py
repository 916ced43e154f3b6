"""What a falsification writes: evaluations.csv, falsify.json, failing/N.yaml.

Each failing run is written as a mission of its own: the campaign's mission
with the run's values and its sensor seed in place, so that
``wmr-mission run failing/N.yaml`` is that run, byte for byte.
"""

from __future__ import annotations

import copy
import csv
import io
import math
import os
from collections.abc import Sequence
from pathlib import Path
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
    "EvaluationsFile",
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


class EvaluationsFile:
    """``evaluations.csv``, a batch appended as it is known (nothing lost to a
    stop). A batch that cannot be written whole (a full disk) is cut back to
    its last complete row, so that the file never ends inside a row;
    :attr:`kept` says how many of the batch's rows it holds."""

    def __init__(self, path: Path, paths: Sequence[str]) -> None:
        self.path = path
        self.size = 0
        self.kept = 0
        self._fd = os.open(path, os.O_WRONLY | os.O_CREAT | os.O_TRUNC, 0o666)
        try:
            self._write([columns(paths)])
        except BaseException:
            os.close(self._fd)
            raise

    def append(self, evaluations: Sequence[Evaluation]) -> None:
        self._write([cells(e) for e in evaluations])

    def _write(self, lines: list[list[str]]) -> None:
        ends: list[int] = []  # where each row ends, in bytes from the batch's start
        pieces: list[bytes] = []
        for line in lines:
            text = io.StringIO()
            csv.writer(text, lineterminator="\n").writerow(line)
            # A file name that is not UTF-8 (in a reason) is written escaped.
            pieces.append(text.getvalue().encode("utf-8", "backslashreplace"))
            ends.append((ends[-1] if ends else 0) + len(pieces[-1]))
        data = memoryview(b"".join(pieces))
        written = 0
        try:
            while written < len(data):
                written += os.write(self._fd, data[written:])
        except OSError as error:
            self.kept = sum(end <= written for end in ends)
            self.size += ends[self.kept - 1] if self.kept else 0
            os.ftruncate(self._fd, self.size)  # back to the last complete row
            os.lseek(self._fd, self.size, os.SEEK_SET)
            raise OSError(error.errno, error.strerror, str(self.path)) from error
        self.kept = len(lines)
        self.size += written

    def close(self) -> None:
        """Sync and close the file; raises OSError (naming it) when the sync fails."""
        try:
            os.fsync(self._fd)
        except OSError as error:
            raise OSError(error.errno, error.strerror, str(self.path)) from error
        finally:
            os.close(self._fd)


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
