"""runs.csv's cells of a row (wmr_mission.campaign.rows.Row.cells): each drawn
value as the YAML text that reads back to it (campaign.load.value_text)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from wmr_mission.campaign import rows
from wmr_mission.campaign.load import value_text
from wmr_mission.campaign.rows import METRICS, Row

FLOATS = [0.1, -3.141592653589793, 5e-324, 1e16, 1.0, -0.0, 2.5e-7, 1.2345678901234567e-300]


def _row(values: tuple[object, ...]) -> Row:
    empty = np.zeros((2, 0), dtype=np.float32)
    return Row(3, 7, "success", values, (None,) * len(METRICS), "", empty)


def test_each_drawn_value_is_written_as_its_text() -> None:
    values = (*FLOATS, math.nan, math.inf, 3, True, "kanayama", {"x": 0.005, "y": 0}, [1, 2.5])
    cells = _row(values).cells()
    assert cells[3 : 3 + len(values)] == [
        v if isinstance(v, str) else value_text(v) for v in values
    ]


def test_a_drawn_float_is_written_without_the_json_encoder(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # a finite float's shortest text is its repr, as JSON writes it: the
    # encoder was a tenth of the sweep's own time a row
    encoded: list[object] = []

    def counted(value: object) -> str:
        encoded.append(value)
        return value_text(value)

    monkeypatch.setattr(rows, "value_text", counted)
    cells = _row((*FLOATS, {"x": 0.01})).cells()
    assert cells[3 : 3 + len(FLOATS)] == [value_text(v) for v in FLOATS]
    assert encoded == [{"x": 0.01}]
