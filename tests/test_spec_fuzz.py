"""Mutated missions never make the loader or `validate` crash."""

from __future__ import annotations

import tempfile
from pathlib import Path
from typing import Any

import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from wmr_mission.cli import app
from wmr_mission.spec.loader import check_mission_text

ROOT = Path(__file__).resolve().parents[1]
CASE2 = (ROOT / "missions" / "case2.yaml").read_text(encoding="utf-8")
CASE1 = (ROOT / "missions" / "case1.yaml").read_text(encoding="utf-8")

# Characters that mean something to YAML or to expressions, plus some that mean nothing.
YAML_ALPHABET = st.sampled_from(
    [*list(":{}[]&*!|>'\"#%@`\n\t -,.0123456789e_xyt()+/"), "é", "\x00"]
)

Edit = tuple[str, int, str]


@st.composite
def character_edits(draw: st.DrawFn, text: str) -> str:
    edits = draw(
        st.lists(
            st.tuples(
                st.sampled_from(["delete", "insert", "replace"]),
                st.integers(0, len(text) - 1),
                st.text(YAML_ALPHABET, min_size=1, max_size=4),
            ),
            min_size=1,
            max_size=6,
        )
    )
    for kind, position, piece in edits:
        position = min(position, max(len(text) - 1, 0))
        if kind == "delete":
            text = text[:position] + text[position + 1 :]
        elif kind == "insert":
            text = text[:position] + piece + text[position:]
        else:
            text = text[:position] + piece + text[position + len(piece) :]
    return text


VALUES = st.recursive(
    st.none()
    | st.booleans()
    | st.integers(-(10**12), 10**12)
    | st.floats(allow_nan=True, allow_infinity=True)
    | st.text(max_size=12)
    | st.sampled_from(["current", "ellipse", "0.4*pi", "t", "ekf", "x", "1/0", "-1", "1e-3"]),
    lambda children: (
        st.lists(children, max_size=3) | st.dictionaries(st.text(max_size=6), children, max_size=3)
    ),
    max_leaves=6,
)


def _paths(data: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    found = [prefix]
    if isinstance(data, dict):
        for key, value in data.items():
            found += _paths(value, (*prefix, key))
    elif isinstance(data, list):
        for index, value in enumerate(data):
            found += _paths(value, (*prefix, index))
    return found


@st.composite
def value_edits(draw: st.DrawFn, text: str) -> str:
    data = yaml.safe_load(text)
    for _ in range(draw(st.integers(1, 3))):
        paths = [p for p in _paths(data) if p]
        path = draw(st.sampled_from(paths))
        parent = data
        for part in path[:-1]:
            parent = parent[part]
        if draw(st.booleans()) and isinstance(parent, dict):
            del parent[path[-1]]
        else:
            parent[path[-1]] = draw(VALUES)
    return yaml.safe_dump(data, sort_keys=False, allow_unicode=True)


MUTATED = st.one_of(
    character_edits(CASE2), character_edits(CASE1), value_edits(CASE2), value_edits(CASE1)
)


def _assert_handled(text: str) -> None:
    mission, diagnostics = check_mission_text(text, "mutated.yaml")
    assert all("internal error" not in d.message for d in diagnostics), diagnostics
    assert all(d.line >= 1 and d.column >= 1 for d in diagnostics)
    errors = [d for d in diagnostics if d.severity == "error"]
    assert (mission is None) == bool(errors)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(MUTATED)
def test_mutated_missions_never_crash_the_loader(text: str) -> None:
    _assert_handled(text)


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(MUTATED)
def test_mutated_missions_never_crash_validate(text: str) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "mutated.yaml"
        path.write_text(text, encoding="utf-8", errors="surrogatepass")
        result = CliRunner().invoke(app, ["validate", str(path)])
        assert result.exception is None or isinstance(result.exception, SystemExit)
        assert result.exit_code in (0, 1)
        assert "Traceback" not in result.output
        assert "internal error" not in result.stderr


@settings(max_examples=100, deadline=None)
@given(st.binary(max_size=200))
def test_arbitrary_bytes_never_crash_validate(data: bytes) -> None:
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "bytes.yaml"
        path.write_bytes(data)
        result = CliRunner().invoke(app, ["validate", str(path)])
        assert result.exit_code in (0, 1)
        assert result.exception is None or isinstance(result.exception, SystemExit)
