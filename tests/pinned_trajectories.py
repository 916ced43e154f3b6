"""Trajectories pinned as numbers, so that a pin holds on every machine.

A pin is the run's sample count, outcome and transitions, and every
``EVERY``-th sample (and the last) of its states, estimates, inputs, reference
and measurements, stored to the bit in ``tests/data/pinned/NAME.json``.
Outcome, counts, phases and transition samples must match exactly, the
numbers within ``TOLERANCE`` (``INPUT_TOLERANCE`` for the inputs): the bytes
of a run are the same on every x86-64 CPU with the same C library, but
glibc's variants with and without FMA differ in the last bit of sin, cos,
exp ..., which moves the shipped missions' samples by at most 2.3e-10
(docs/reliability.md). Byte for byte, runs are compared on one machine
(tests/test_same_bytes.py).

    python tests/pinned_trajectories.py case1 ...   # pin anew, after a change meant to move them
"""

from __future__ import annotations

import json
import math
import sys
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from wmr_mission.output.result import RunResult

PINNED = Path(__file__).resolve().parent / "data" / "pinned"
MISSIONS = Path(__file__).resolve().parent.parent / "missions"
COLUMNS = (
    "t",
    "x",
    "y",
    "theta",
    "x_est",
    "y_est",
    "theta_est",
    "v",
    "omega",
    "x_ref",
    "y_ref",
    "x_meas",
    "y_meas",
    "theta_meas",
)
EVERY = 50
# [m, rad]: poses, estimates, references, measurements; and [m/s, rad/s]: the
# inputs, which a controller working at its limits can move more than the
# poses (1.3e-7 at most, where tests/data/same-bytes/paths.yaml chatters at
# its turn-rate limit; docs/reliability.md).
TOLERANCE = 1e-8
INPUT_TOLERANCE = 1e-6
INPUTS = ("v", "omega")


def _rows(result: RunResult) -> list[int]:
    return sorted({*range(0, result.samples, EVERY), result.samples - 1})


def _number(value: float) -> float | str:
    return value if math.isfinite(value) else str(value)  # JSON has no nan


def record(result: RunResult) -> dict[str, Any]:
    """What is pinned of ``result``."""
    rows = _rows(result)
    columns = {name: getattr(result, name) for name in COLUMNS}
    return {
        "samples": result.samples,
        "outcome": result.outcome.value,
        "every": EVERY,
        "transitions": [
            [tr.time, tr.from_phase, tr.to_phase, tr.condition, _number(tr.value)]
            for tr in result.transitions
        ],
        "columns": ["sample", "phase", *COLUMNS],
        "rows": [
            [k, result.phases[int(result.phase[k])].name]
            + [_number(float(columns[name][k])) for name in COLUMNS]
            for k in rows
        ],
    }


def assert_matches_pin(name: str, result: RunResult) -> None:
    """``result`` against ``tests/data/pinned/NAME.json``: exact where it counts
    or names, within TOLERANCE where it measures."""
    pinned = json.loads((PINNED / f"{name}.json").read_text(encoding="utf-8"))
    now = record(result)
    assert (now["samples"], now["outcome"]) == (pinned["samples"], pinned["outcome"]), name
    assert [row[:2] for row in now["rows"]] == [row[:2] for row in pinned["rows"]], name
    got_transitions = [row[:4] for row in now["transitions"]]
    assert got_transitions == [row[:4] for row in pinned["transitions"]], name
    np.testing.assert_allclose(
        np.array([float(row[4]) for row in now["transitions"]]),
        np.array([float(row[4]) for row in pinned["transitions"]]),
        rtol=0.0,
        atol=TOLERANCE,
        err_msg=f"{name}: the values of the transitions' conditions",
    )
    got = np.array([[float(v) for v in row[2:]] for row in now["rows"]])
    want = np.array([[float(v) for v in row[2:]] for row in pinned["rows"]])
    assert_close(got, want, COLUMNS, name)


def assert_close(got: np.ndarray, want: np.ndarray, columns: Sequence[str], name: str) -> None:
    """Each column of ``got`` within its tolerance of ``want``'s (NaN where it is NaN)."""
    assert got.shape == want.shape, name
    tolerance = np.array([INPUT_TOLERANCE if c in INPUTS else TOLERANCE for c in columns])
    with np.errstate(invalid="ignore"):
        close = (np.abs(got - want) <= tolerance) | (np.isnan(got) & np.isnan(want))
    far = [
        f"{column} at row {row}: {got[row, j]!r} against {want[row, j]!r}"
        for row, j in zip(*np.nonzero(~close), strict=True)
        for column in [columns[j]]
    ]
    assert not far, f"{name}: {len(far)} numbers out of tolerance: {'; '.join(far[:5])}"


def _json_text(pin: dict[str, Any]) -> str:
    """JSON with a line per transition and per row (each float to the bit)."""
    parts = [f'"{key}": {json.dumps(pin[key])}' for key in ("samples", "outcome", "every")]
    for key in ("transitions", "rows"):
        lines = ",\n".join(f"  {json.dumps(item)}" for item in pin[key])
        parts.append(f"{json.dumps(key)}: [\n{lines}\n]")
        if key == "transitions":
            parts.append(f'"columns": {json.dumps(pin["columns"])}')
    return "{\n" + ",\n".join(parts) + "\n}\n"


def _pin(names: list[str]) -> None:
    from wmr_mission.sim.runner import run_mission
    from wmr_mission.spec.loader import load_mission

    PINNED.mkdir(parents=True, exist_ok=True)
    for name in names:
        result = run_mission(load_mission(MISSIONS / f"{name}.yaml"))
        (PINNED / f"{name}.json").write_text(_json_text(record(result)), encoding="utf-8")
        print(f"{name}: {result.samples} samples, {result.outcome.value}")


if __name__ == "__main__":
    _pin(sys.argv[1:])
