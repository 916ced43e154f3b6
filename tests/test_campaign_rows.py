"""runs.csv's cells of a row (wmr_mission.campaign.rows.Row.cells): each drawn
value as the YAML text that reads back to it (campaign.load.value_text)."""

from __future__ import annotations

import math
import pickle
from pathlib import Path

import numpy as np
import pytest

from wmr_mission.campaign import rows
from wmr_mission.campaign.load import value_text
from wmr_mission.campaign.rows import METRICS, Row

GRID = Path(__file__).resolve().parent / "data" / "campaigns" / "valid" / "grid_only.yaml"
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


def test_a_campaign_that_draws_no_figure_sends_its_rows_without_their_paths(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # only the trajectory figure draws a row's path (some 4 KB of a case-2
    # row): without figures the workers send none, the rest of the row the same
    from wmr_mission.campaign import sweep
    from wmr_mission.campaign.engine import execute
    from wmr_mission.campaign.load import load_campaign
    from wmr_mission.stopping import StopSignals

    loaded = load_campaign(GRID)
    kept = rows.run_rows(loaded, 0, 4)
    sent = {}
    with StopSignals() as stop:
        for workers in (1, 2):
            found = execute(
                loaded,
                workers=workers,
                scheduler=None,
                seconds_per_run=1e-3,
                stop=stop,
                paths=False,
            )
            sent[workers] = [row for task in found for row in task]
    for without in sent.values():
        assert [row.cells() for row in without] == [row.cells() for row in kept]
        assert all(row.path_xy.shape == (2, 0) for row in without)
    assert all(row.path_xy.shape[1] > 0 for row in kept)
    assert len(pickle.dumps(sent[1][:4])) < len(pickle.dumps(kept)) - 4 * 1000

    added: list[tuple[int, ...]] = []
    add = sweep.Aggregate.add

    def adding(self: sweep.Aggregate, row: Row) -> None:
        added.append(row.path_xy.shape)
        add(self, row)

    monkeypatch.setattr(sweep.Aggregate, "add", adding)
    code = sweep.sweep_command(GRID, out=tmp_path / "out", workers=1, scheduler=None, plots=False)
    assert code in (0, 1)
    assert added
    assert all(shape == (2, 0) for shape in added)
