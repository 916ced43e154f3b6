"""Temporal `expect` formulas: their grammar and errors, their robustness
against rtamt's (an independent monitor of signal temporal logic), the shipped
example of missions/case2.yaml, and the built-in metrics they restate."""

from __future__ import annotations

import copy
import json
import os
import subprocess
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from wmr_mission.spec.loader import MissionError, load_mission
from wmr_mission.spec.temporal import (
    SIGNALS,
    Always,
    Atom,
    Both,
    Either,
    Eventually,
    FormulaError,
    Node,
    Until,
    Window,
    parse_formula,
)
from wmr_mission.verdicts.temporal import robustness, robustness_at_start

ROOT = Path(__file__).resolve().parent.parent
CASE2 = ROOT / "missions" / "case2.yaml"

# rtamt (the [test] extra's, where it installs) runs on Python 3.8 to 3.12: its
# ANTLR 4.7 runtime imports typing.io, which Python 3.13 no longer has. The
# reference written from the definitions below runs everywhere.
needs_rtamt = pytest.mark.skipif(
    sys.version_info >= (3, 13), reason="rtamt's ANTLR 4.7 runtime needs typing.io (< 3.13)"
)


def _rtamt() -> Any:
    with warnings.catch_warnings():  # its ANTLR runtime's import of typing.io
        warnings.simplefilter("ignore", DeprecationWarning)
        import rtamt

    return rtamt


# --- the grammar --------------------------------------------------------------


def test_a_formula_is_read_as_written() -> None:
    node = parse_formula("eventually[0, 10](always(cross_track <= 0.02)) or lag >= -1e-1")
    assert node == Either(
        Eventually(Window(0.0, 10.0), Always(Window(0.0, "end"), Atom("cross_track", 0.02))),
        Atom("lag", -0.1, above=True),
    )
    # and before or, until before and; windows of named instants
    node = parse_formula("speed <= 1 and turn_rate <= 2 until[settle, end] lag <= 3 or speed >= 0")
    assert node == Either(
        Both(
            Atom("speed", 1.0),
            Until(Window("settle", "end"), Atom("turn_rate", 2.0), Atom("lag", 3.0)),
        ),
        Atom("speed", 0.0, above=True),
    )


@pytest.mark.parametrize(
    ("text", "column", "words"),
    [
        ("always(cross_tack <= 0.1)", 8, "did you mean 'cross_track'"),
        ("eventualy[0, 2](always(cross_track <= 0.05))", 1, "did you mean 'eventually'"),
        ("always(speed < 1)", 14, "write '<='"),
        ("always[2, 1](speed <= 1)", 11, "ends (1 s) before it starts (2 s)"),
        ("always[0, 10(speed <= 1)", 13, "expected ']'"),
        ("always(speed <= 1", 7, "unclosed '('"),
        ("always(speed <= one)", 17, "expected a number"),
        ("always[-1, 2](speed <= 1)", 8, "0 or more seconds"),
        ("always[0, later](speed <= 1)", 11, "entry, settle, end"),
        ("speed <= 1 until lag <= 1 until lag <= 2", 27, "does not chain"),
        ("always(speed <= 1) lag <= 2", 20, "expected 'and', 'or'"),
        ("not speed <= 1", 1, "there is no negation: compare the other way"),
        (
            "cross_track <= 5cm",
            17,
            "units are not written: cross_track is in m; write 0.05 for 5 cm",
        ),
        ("always(speed <= 1.8 km / h)", 21, "speed is in m/s; write 0.5 for 1.8 km / h"),
        ("always(heading_error <= 5 deg)", 27, "heading_error is in rad; write 0.0872665"),
        ("always(cross_track <= 1 s)", 25, "cross_track is in m; write the number alone, in m"),
        ("", 1, "empty formula"),
    ],
)
def test_a_mistake_is_reported_at_its_column(text: str, column: int, words: str) -> None:
    with pytest.raises(FormulaError) as error:
        parse_formula(text)
    assert error.value.column == column
    assert words in error.value.message


def test_an_unknown_signal_lists_the_signals() -> None:
    with pytest.raises(FormulaError) as error:
        parse_formula("always(depth <= 0)")
    assert error.value.message.endswith("signals: " + ", ".join(SIGNALS))


def _with_formula(formula: str) -> str:
    text = CASE2.read_text()
    orbit = "    until: {elapsed: 20}\n"
    assert orbit in text
    return text.replace(orbit, f'{orbit}    expect: {{temporal: ["{formula}"]}}\n')


def test_a_mistake_in_a_mission_is_at_its_file_line_and_column(tmp_path: Path) -> None:
    mission = tmp_path / "case2.yaml"
    mission.write_text(_with_formula("eventually[0, 10](always(cross_tack <= 0.02))"))
    line = (
        mission.read_text()
        .splitlines()
        .index('    expect: {temporal: ["eventually[0, 10](always(cross_tack <= 0.02))"]}')
    )
    column = len('    expect: {temporal: ["eventually[0, 10](always(') + 1
    with pytest.raises(MissionError) as error:
        load_mission(mission)
    assert str(error.value).startswith(f"{mission}:{line + 1}:{column}: ")
    assert "unknown signal 'cross_tack'; did you mean 'cross_track'?" in str(error.value)
    done = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "validate", str(mission)],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 1
    assert f"{mission}:{line + 1}:{column}: " in done.stdout + done.stderr
    assert "Traceback" not in done.stderr


def _with_formula_written(written: str) -> str:
    """case2.yaml with its orbit's formulas written as ``written`` (after `temporal:`)."""
    text = CASE2.read_text()
    orbit = '      temporal: ["eventually[0, 10](always(cross_track <= 0.02))"]'
    assert orbit in text
    return text.replace(orbit, f"      temporal:{written}")


@pytest.mark.parametrize(
    ("written", "line", "column"),
    [
        # a folded block: the mistake on its second line
        (
            ">-\n        eventually[0, 10](always(cross_track"
            "\n        <= 0.02) and cross_tack <= 1)",
            2,
            22,
        ),
        # a literal block, each line break kept
        (
            "|-\n        eventually[0, 10](always(cross_track <= 0.02))"
            "\n        and cross_tack <= 1",
            2,
            13,
        ),
        # a plain text over two lines, the second indented further
        ("eventually[0, 10](always(cross_track <= 0.02))\n          and cross_tack <= 1", 1, 15),
    ],
)
def test_a_mistake_in_a_formula_over_several_lines_is_at_its_own_line(
    written: str, line: int, column: int
) -> None:
    """The error points into the line of the file where the mistake is, not at
    the text's first line or its `>-` marker."""
    from wmr_mission.spec.loader import check_mission_text

    text = _with_formula_written(f"\n      - {written}")
    _, found = check_mission_text(text, "case2.yaml")
    (error,) = found
    assert "unknown signal 'cross_tack'" in error.message
    first = text.splitlines().index("      temporal:") + 2  # the line of `- ` (from 1)
    assert (error.line, error.column) == (first + line, column)
    assert text.splitlines()[error.line - 1][error.column - 1 :].startswith("cross_tack")


def test_a_formula_folded_with_a_blank_line_is_placed_at_its_start() -> None:
    """A text whose characters are not its lines joined (a blank line folds to a
    line break) gets no guessed position: the error is at the text's start."""
    from wmr_mission.spec.loader import check_mission_text

    formula = (
        ">-\n        eventually[0, 10](always(cross_track\n\n        <= 0.02)) and cross_tack <= 1"
    )
    text = _with_formula_written(f"\n      - {formula}")
    _, found = check_mission_text(text, "case2.yaml")
    (error,) = found
    assert (error.line, error.column) == (text.splitlines().index("      temporal:") + 2, 9)


def test_a_formula_on_a_signal_its_phase_does_not_measure_is_a_warning() -> None:
    from wmr_mission.spec.loader import check_mission_text

    text = CASE2.read_text().replace("target_distance <= 0.05", "cross_track <= 0.05")
    mission, found = check_mission_text(text, "case2.yaml")
    assert mission is not None  # a warning: the mission runs
    (warning,) = found
    assert warning.severity == "warning"
    assert warning.message == (
        "cross_track is measured on track phases, but phase 'return' is not one: "
        "the formula is never checked"
    )
    assert (warning.line, warning.column) == (
        text.splitlines().index(
            '      temporal: ["eventually[0, 10](always(cross_track <= 0.05))"]'
        )
        + 1,
        18,
    )


@pytest.mark.parametrize(
    ("formula", "said"),
    [
        ("always(cross_track <= -0.1)", "cross_track <= -0.1 never holds: it is 0 or more"),
        (
            "eventually(speed >= 12) or always(lag <= 1)",
            "speed >= 12 never holds: it is at most limits.v = 10",
        ),
        ("always(turn_rate >= 25)", "turn_rate >= 25 never holds: it is at most limits.omega = 20"),
        ("always(lag >= -0.3)", None),  # the lag is signed: ahead is below 0
        ("eventually(speed >= 10)", None),  # at the limit, which the robot may reach
    ],
)
def test_a_comparison_no_sample_meets_is_a_warning(formula: str, said: str | None) -> None:
    from wmr_mission.spec.loader import check_mission_text

    text = _with_formula_written(f' ["{formula}"]')
    mission, found = check_mission_text(text, "case2.yaml")
    assert mission is not None  # a warning: the mission runs
    messages = [d.message for d in found]
    if said is None:
        assert messages == []
    else:
        assert messages == [f"{said}; write a bound it can meet"]
        assert found[0].severity == "warning"


def test_a_mission_wide_formula_that_no_phase_measures_is_a_warning() -> None:
    # case study 2's orbit and return keep lists of their own: the mission's
    # formulas apply to the spiral out alone, a track phase without constraints
    from wmr_mission.spec.loader import check_mission_text

    formulas = ["always(lag <= 1)", "always(clearance >= 0.5)", "always(lag <= 1 or speed <= 1)"]
    shared = f"  temporal: {json.dumps(formulas)}"
    text = CASE2.read_text().replace("\nexpect:\n", f"\nexpect:\n{shared}\n", 1)
    mission, found = check_mission_text(text, "case2.yaml")
    assert mission is not None  # a warning: the mission runs
    (warning,) = found
    assert warning.severity == "warning"
    assert warning.message == (
        "no phase that takes the mission's formulas measures clearance (phases with "
        "constraints): the formula is never checked"
    )
    line = text.splitlines().index(shared) + 1
    assert (warning.line, warning.column) == (line, shared.index('"always(clearance') + 1)
    # without its own list, the return takes them: clearance is measured there,
    # but no phase measures it and the lag together
    together = "always(clearance >= 0.5 and lag <= 1)"
    mine = '      temporal: ["eventually[0, 10](always(target_distance <= 0.05))"]'
    text = text.replace(mine, "      settle_time: 0").replace(shared, f'  temporal: ["{together}"]')
    _, found = check_mission_text(text, "case2.yaml")
    assert [w.message for w in found] == [
        "no phase that takes the mission's formulas measures clearance and lag together "
        "(clearance: phases with constraints; lag: track phases): the formula is never checked"
    ]


# --- the robustness, against rtamt's ------------------------------------------

NAMES = ("speed", "turn_rate", "lag")


def _random_window(rng: np.random.Generator, n: int) -> Window:
    kind = rng.integers(4)
    if kind == 0:
        return Window()  # [0, end]
    start = float(rng.integers(0, 8))
    if kind == 1:
        return Window(start, "end")
    return Window(start, start + float(rng.integers(0, 8)))


def _random_formula(rng: np.random.Generator, n: int, depth: int) -> Node:
    kind = rng.integers(6) if depth > 0 else 0
    if kind == 0:
        bound = float(np.round(rng.normal(), 2)) if rng.random() > 0.1 else 0.0
        return Atom(str(rng.choice(NAMES)), bound, bool(rng.integers(2)))
    if kind in (1, 2):
        parts = _random_formula(rng, n, depth - 1), _random_formula(rng, n, depth - 1)
        return Both(*parts) if kind == 1 else Either(*parts)
    window = _random_window(rng, n)
    if kind == 5:
        return Until(window, _random_formula(rng, n, depth - 1), _random_formula(rng, n, depth - 1))
    body = _random_formula(rng, n, depth - 1)
    return Always(window, body) if kind == 3 else Eventually(window, body)


def _rtamt_text(node: Node, n: int, atoms: list[Atom], normalised: bool, dt: float = 1.0) -> str:
    """The formula in rtamt's syntax, its windows in samples of ``dt`` s;
    normalised: each atom over a signal of its own, scaled by its bound's size."""

    def window(w: Window) -> str:
        assert isinstance(w.start, float)
        stop = n if w.stop == "end" else round(float(w.stop) / dt)  # beyond the trace: its end
        return f"[{round(w.start / dt)}:{stop}]"

    if isinstance(node, Atom):
        atoms.append(node)
        name = f"a{len(atoms) - 1}" if normalised else node.signal
        bound = node.bound / (abs(node.bound) or 1.0) if normalised else node.bound
        return f"({name} {'>=' if node.above else '<='} {bound!r})"
    if isinstance(node, Both | Either):
        left = _rtamt_text(node.left, n, atoms, normalised, dt)
        right = _rtamt_text(node.right, n, atoms, normalised, dt)
        return f"({left} {'and' if isinstance(node, Both) else 'or'} {right})"
    if isinstance(node, Always | Eventually):
        word = "always" if isinstance(node, Always) else "eventually"
        body = _rtamt_text(node.body, n, atoms, normalised, dt)
        return f"({word}{window(node.window)}{body})"
    left = _rtamt_text(node.left, n, atoms, normalised, dt)
    right = _rtamt_text(node.right, n, atoms, normalised, dt)
    return f"({left} until{window(node.window)} {right})"


def _rtamt_robustness(
    node: Node, signals: dict[str, np.ndarray], normalised: bool = False, dt: float = 1.0
) -> np.ndarray:
    n = len(next(iter(signals.values())))
    atoms: list[Atom] = []
    spec = _rtamt().StlDiscreteTimeSpecification()
    spec.spec = _rtamt_text(node, n, atoms, normalised, dt)
    data: dict[str, list[float]] = {"time": list(range(n))}
    if normalised:
        for i, atom in enumerate(atoms):
            spec.declare_var(f"a{i}", "float")
            data[f"a{i}"] = list(signals[atom.signal] / (abs(atom.bound) or 1.0))
    else:
        for name in signals:
            spec.declare_var(name, "float")
            data[name] = list(signals[name])
    spec.parse()
    return np.array([value for _, value in spec.evaluate(data)])


def _traces(count: int, seed: int) -> list[tuple[Node, dict[str, np.ndarray]]]:
    rng = np.random.default_rng(seed)
    found = []
    for _ in range(count):
        n = int(rng.integers(2, 40))  # rtamt fails on a trace of one sample
        signals = {name: np.round(rng.normal(size=n), 3) for name in NAMES}
        found.append((_random_formula(rng, n, int(rng.integers(1, 4))), signals))
    return found


def _reference(node: Node, signals: dict[str, np.ndarray], normalised: bool) -> np.ndarray:
    """The robustness at every sample, straight from the definitions
    (verdicts/temporal.py's docstring), one sample and one window at a time."""
    n = len(signals[NAMES[0]])
    inf = float("inf")

    def span(w: Window, k: int) -> range:
        stop = n - 1 if w.stop == "end" else min(k + int(w.stop), n - 1)
        return range(k + int(w.start), stop + 1)

    if isinstance(node, Atom):
        x = signals[node.signal]
        rho = x - node.bound if node.above else node.bound - x
        return rho / (abs(node.bound) or 1.0) if normalised else rho
    if isinstance(node, Both | Either):
        left, right = (
            _reference(node.left, signals, normalised),
            _reference(node.right, signals, normalised),
        )
        return np.minimum(left, right) if isinstance(node, Both) else np.maximum(left, right)
    if isinstance(node, Always | Eventually):
        body = _reference(node.body, signals, normalised)
        pick, empty = (min, inf) if isinstance(node, Always) else (max, -inf)
        return np.array(
            [pick((body[m] for m in span(node.window, k)), default=empty) for k in range(n)]
        )
    left, right = (
        _reference(node.left, signals, normalised),
        _reference(node.right, signals, normalised),
    )
    return np.array(
        [
            max(
                (min(right[m], min(left[k:m], default=inf)) for m in span(node.window, k)),
                default=-inf,
            )
            for k in range(n)
        ]
    )


@pytest.mark.parametrize("normalised", [False, True])
def test_the_robustness_is_the_definitions_on_generated_traces(normalised: bool) -> None:
    # 300 random formulas (up to three operators deep, windows cut by the
    # trace's end or not) on as many random traces: every sample's rho
    for node, signals in _traces(300, seed=34):
        ours = robustness(node, signals, 1.0, {}, normalised=normalised)
        assert np.allclose(ours, _reference(node, signals, normalised), rtol=0.0, atol=1e-9), node


@needs_rtamt
@pytest.mark.parametrize("normalised", [False, True])
def test_the_robustness_is_rtamts_on_generated_traces(normalised: bool) -> None:
    for node, signals in _traces(300, seed=34):
        ours = robustness(node, signals, 1.0, {}, normalised=normalised)
        theirs = _rtamt_robustness(node, signals, normalised)
        assert np.allclose(ours, theirs, rtol=0.0, atol=1e-9), node


@needs_rtamt
def test_each_operator_is_rtamts_on_long_windows() -> None:
    # the window minimum and maximum in blocks and the doubling scan of until,
    # on windows wider than a block and as wide as the trace
    rng = np.random.default_rng(5)
    signals = {name: rng.normal(size=120) for name in NAMES}
    a, b = Atom("speed", 0.5), Atom("lag", -0.2, above=True)
    for window in (Window(), Window(0.0, 119.0), Window(17.0, 60.0), Window(3.0, "end")):
        for node in (Always(window, a), Eventually(window, a), Until(window, a, b)):
            ours = robustness(node, signals, 1.0, {}, normalised=False)
            assert np.allclose(ours, _rtamt_robustness(node, signals), rtol=0.0, atol=1e-9)


def test_windows_are_in_seconds_and_named_instants_are_the_phases() -> None:
    dt = 0.01
    speed = np.linspace(0.0, 1.0, 101)  # 1 m/s at 1 s
    signals = {"speed": speed}
    node = parse_formula("eventually[settle, end](speed >= 0.5)")
    assert robustness(node, signals, dt, {"settle": 0.2})[0] == pytest.approx(1.0)
    node = parse_formula("always[0.1, 0.3](speed <= 0.5)")  # samples 10 to 30
    assert robustness(node, signals, dt, {}, normalised=False)[0] == pytest.approx(0.2)
    node = parse_formula("always[entry, 0.5](speed >= 0.25)")
    assert robustness(node, signals, dt, {"entry": 0.25}, normalised=False)[0] == pytest.approx(0)


def _nested_formula(rng: np.random.Generator) -> Node:
    """An atom under one or two windows (the inner one to the end, or not), as
    a formula's value picks it without its rho at every sample, or a formula of
    any other shape."""
    atom = _random_formula(rng, 0, 0)
    kinds = (Always, Eventually)
    start = float(rng.integers(0, 8))
    inner = kinds[rng.integers(2)](
        Window(start, "end" if rng.random() < 0.7 else start + float(rng.integers(0, 40))), atom
    )
    start = float(rng.integers(0, 8))
    outer = Window(start, "end" if rng.random() < 0.3 else start + float(rng.integers(0, 40)))
    shape = rng.integers(3)
    if shape == 0:
        return kinds[rng.integers(2)](outer, inner)
    if shape == 1:
        return kinds[rng.integers(2)](outer, atom)
    return _random_formula(rng, 0, int(rng.integers(1, 4)))


def test_a_formulas_value_is_its_robustness_at_the_first_sample() -> None:
    # The value of a window over an atom, or over a window to the end of one, is
    # one pick over the signal: the same bits as the robustness at the first
    # sample (a 0 the same number: its sign is the picks' own), on signals
    # with ties, zeros of both signs and as short as one sample.
    rng = np.random.default_rng(8)
    for _ in range(3000):
        n = int(rng.integers(1, 30))
        signals = {name: np.round(rng.normal(size=n), int(rng.integers(0, 3))) for name in NAMES}
        for values in signals.values():
            values[rng.random(n) < 0.2] = 0.0 if rng.random() < 0.5 else -0.0
        node = _nested_formula(rng)
        instants = {"entry": float(rng.integers(0, 5)), "settle": float(rng.integers(0, 5))}
        whole = robustness(node, signals, 1.0, instants)[0]
        value = robustness_at_start(node, signals, 1.0, instants)
        assert value == whole, node
        if whole != 0.0:
            assert np.float64(value).tobytes() == np.float64(whole).tobytes(), node


# --- on runs: the shipped example and the built-in metrics it restates --------


@pytest.fixture(scope="module")
def case2_run() -> Any:
    from wmr_mission.api import run_mission

    return run_mission(load_mission(CASE2))


def _phase(result: Any, name: str) -> tuple[Any, slice, Any]:
    from wmr_mission.spec.numbers import mission_numbers
    from wmr_mission.verdicts.metrics import phase_segments

    for index, start, end, _ in phase_segments(result):
        if result.phases[index].name == name:
            numbers = mission_numbers(result.mission, result.dt, result.limits)
            return result.phases[index], slice(start, end), numbers
    raise AssertionError(name)


def _checks(summary: dict[str, Any], phase: str) -> dict[str, dict[str, Any]]:
    return {e["metric"]: e for e in summary["expectations"] if e["phase"] == phase}


@needs_rtamt
def test_case2s_formulas_hold_with_rtamts_robustness(case2_run: Any) -> None:
    # The shipped example: on the ellipse within 10 s of the orbit's start and
    # on it to the end; inside the ellipse on the way home, and home within
    # 10 s and there to the end. Both are checks of the run, met, with their
    # rho as margin, and rtamt reads the same rho from the recorded signals.
    from wmr_mission.verdicts.temporal import PhaseSignals, phase_formulas

    summary = case2_run.judged
    assert case2_run.outcome.value == "success"
    for name in ("orbit", "return"):
        (formula,) = phase_formulas(case2_run.mission, name)
        check = _checks(summary, name)[formula]
        assert check["met"]
        assert check["min"] == 0.0
        assert check["rho"] == check["margin"] == check["value"] > 0.5
        info, window, numbers = _phase(case2_run, name)
        phase = PhaseSignals(case2_run, info, window, numbers)
        node = parse_formula(formula)
        signals = {s: phase.get(s) for s in sorted({a for a in SIGNALS if a in formula})}
        theirs = _rtamt_robustness(node, signals, normalised=True, dt=case2_run.dt)[0]
        assert abs(check["rho"] - theirs) <= 1e-9


def _with_expect(extra: dict[str, dict[str, Any]]) -> Any:
    from wmr_mission.api import mission_from_dict

    data = load_mission(CASE2).model_dump(mode="json", exclude_defaults=True)
    for phase in data["phases"]:
        phase["expect"] = extra.get(phase["name"], {})
    return mission_from_dict(data)


def test_built_in_metrics_read_as_formulas() -> None:
    # docs/mission-format.md's table: the margin of a built-in check is the
    # rho of the formula that restates it (the case 2 orbit: no detour)
    from wmr_mission.api import run_mission

    orbit = {
        "cross_track_error_max": {"max": 0.00005},
        "along_track_lag_max": {"max": 0.002},
        "temporal": [
            "always[entry, end](cross_track <= 0.00005)",
            "always[entry, end](lag <= 0.002 and lag >= -0.002)",
        ],
    }
    home = {"clearance_min": 0.5, "temporal": ["always(clearance >= 0.5)"]}
    summary = run_mission(_with_expect({"orbit": orbit, "return": home})).judged
    checks = _checks(summary, "orbit")
    for metric, formula in (
        ("cross_track_error_max", "always[entry, end](cross_track <= 0.00005)"),
        ("along_track_lag_max", "always[entry, end](lag <= 0.002 and lag >= -0.002)"),
    ):
        assert checks[metric]["margin"] == pytest.approx(checks[formula]["margin"], abs=1e-12)
        assert checks[metric]["met"] == checks[formula]["met"]
    assert not checks["cross_track_error_max"]["met"]  # 0.07 mm: a miss and a hit
    assert checks["along_track_lag_max"]["met"]
    # the clearance is given to a micrometre (verdicts/clearance.py): so is its margin
    checks = _checks(summary, "return")
    built_in, formula = checks["clearance_min"], checks["always(clearance >= 0.5)"]
    assert built_in["met"] == formula["met"] is False  # it starts on the ellipse
    assert built_in["margin"] == pytest.approx(formula["margin"], abs=1e-6 / 0.5)


# A line joined at once by a robot held to 0.5 m/s^2 with noise, then a stop
# (a new user's mission): it keeps up with its reference seconds before its
# entry's allowance, and is judged from there.
KEPT_UP_EARLY = """\
version: 1
name: kept-up-early
robot:
  dt: 0.01
  initial_state: {x: 0, y: 0, theta: 0.1}
  limits: {v: 1.0, omega: 1.0, acceleration: {v: 0.5, omega: 2.0}}
sensors: {noise_std: {x: 0.015, y: 0.015, theta: 0.01}, seed: 7}
estimator: {type: ekf}
phases:
  - name: run
    track: {path: {type: line, start: [0, 0], heading: 0, speed: 0.6}}
    until: {near: {point: [8, 0], tolerance: 0.1}}
    timeout: 25
    expect:
      along_track_lag_max: {max: 0.1}
      temporal: ["always[entry, end](lag <= 0.1 and lag >= -0.1)"]
  - name: stop
    regulate: {target: {x: 8.5, y: 0, theta: 0}}
    until: {settled: {position: 0.05, heading: 0.05}}
    timeout: 15
"""


def test_the_entry_a_formula_names_is_the_one_the_tracking_leaves_out() -> None:
    """`entry` in a formula, `entry_time` in the summary and the samples the
    tracking judges are one instant: the robot kept up at 2.8 s, and the
    formula read its entry's allowance (6.99 s), a margin of 0.99 where the
    built-in check had 0.65."""
    from wmr_mission.api import run_mission
    from wmr_mission.spec.loader import load_mission_text

    summary = run_mission(load_mission_text(KEPT_UP_EARLY)).judged
    checks = _checks(summary, "run")
    formula = "always[entry, end](lag <= 0.1 and lag >= -0.1)"
    lag = checks["along_track_lag_max"]
    assert lag["margin"] == pytest.approx(checks[formula]["margin"], abs=1e-12)
    entry = summary["phases"][0]["tracking"]["entry_time"]
    assert 1.0 < entry < 4.0  # well within its allowance of 6.99 s


def test_a_formula_check_is_drawn_on_its_first_signals_panel() -> None:
    from wmr_mission.verdicts.signals import panel_of

    assert panel_of("eventually[0, 10](always(cross_track <= 0.02))") == "cross_track"
    assert panel_of("(speed <= 1 or lag <= 2) until target_distance <= 0.1") == "saturation"


def test_a_mission_wide_formula_applies_where_its_signals_are_measured(case2_run: Any) -> None:
    # judged again with the mission-wide formulas, the phases' own left out but
    # the return's, which turns them off there
    from wmr_mission.verdicts.metrics import judge

    mission = copy.deepcopy(case2_run.mission)
    mission["expect"]["temporal"] = ["always(speed <= 10)", "eventually(cross_track <= 0.1)"]
    for phase in mission["phases"]:
        phase["expect"]["temporal"] = [] if phase["name"] == "return" else None
    checks = [
        (e["phase"], e["metric"], e["met"])
        for e in judge(case2_run, mission)["expectations"]
        if "(" in e["metric"]
    ]
    assert checks == [
        ("spiral-out", "always(speed <= 10)", True),
        ("spiral-out", "eventually(cross_track <= 0.1)", True),
        ("orbit", "always(speed <= 10)", True),
        ("orbit", "eventually(cross_track <= 0.1)", True),
    ]


def test_a_mistake_after_an_escape_is_never_placed_past_it(tmp_path: Path) -> None:
    # "\t" is two characters of the file and one of the formula: a column counted
    # in the formula would point 1 character short of the mistake, so the
    # message points at the text's opening quote instead.
    mission = tmp_path / "case2.yaml"
    written = r"always(speed\t<= 1 and turn_rate <= fast)"
    mission.write_text(_with_formula(written))
    lines = mission.read_text().splitlines()
    line = next(i for i, text in enumerate(lines) if written in text)
    with pytest.raises(MissionError) as error:
        load_mission(mission)
    quote = lines[line].index('"') + 1
    assert str(error.value).startswith(f"{mission}:{line + 1}:{quote}: ")
    assert "unexpected 'fast': expected a number to compare with" in str(error.value)


def test_the_figure_words_a_formula_as_a_lower_bound() -> None:
    """verdicts.png says a missed formula's rho fell below its min 0, as
    summary.json's check and the run's message do, not above a max."""
    from wmr_mission.api import mission_from_text, run_mission
    from wmr_mission.verdicts.signals import run_signals

    park = """
version: 1
name: park
robot: {dt: 0.01, initial_state: {x: 0, y: 0, theta: 0}, limits: {v: 1, omega: 2}}
phases:
  - name: park
    regulate: {target: {x: 1, y: 0, theta: 0}}
    until: {settled: {position: 0.02, heading: 0.02}}
    timeout: 20
    expect: {temporal: ["always(target_distance >= 0.5)"]}
"""
    result = run_mission(mission_from_text(park))
    assert result.judged is not None
    (missed,) = [c for c in result.judged["expectations"] if not c["met"]]
    assert missed["min"] == 0.0
    assert "max" not in missed
    (failed,) = run_signals(result).failed()
    rho = missed["value"]
    assert failed.words() == f"park: always(target_distance >= 0.5) = {rho:.3g} (min 0)"


def test_a_missed_formula_of_a_run_that_timed_out_is_listed_not_a_traceback(
    tmp_path: Path,
) -> None:
    """A run that ended otherwise than by its checks lists each missed one
    under the phases' table: a formula's bound is a min, rho >= 0."""
    mission = tmp_path / "park.yaml"
    mission.write_text(
        """
version: 1
name: park
robot: {dt: 0.01, initial_state: {x: 0, y: 0, theta: 0}, limits: {v: 1, omega: 2}}
phases:
  - name: park
    regulate: {target: {x: 1, y: 0, theta: 0}}
    until: {settled: {position: 0.02, heading: 0.02}}
    timeout: 0.5
    on_timeout: fail
    expect: {temporal: ["always(target_distance <= 0.5)"]}
"""
    )
    out = str(tmp_path / "run")
    done = subprocess.run(
        [sys.executable, "-m", "wmr_mission", "run", str(mission), "--no-plots", "--out", out],
        capture_output=True,
        text=True,
        check=False,
        env={**os.environ, "WMR_MISSION_NO_JIT": "1"},
    )
    assert "Traceback" not in done.stderr
    assert done.returncode == 1
    summary = json.loads((tmp_path / "run" / "summary.json").read_text())
    assert summary["outcome"] == "timeout"
    (check,) = [c for c in summary["expectations"] if c["metric"].startswith("always")]
    assert check["met"] is False
    assert (
        f"expect park: always(target_distance <= 0.5) >= 0: {check['value']:.4g} (NOT MET)"
        in done.stdout.splitlines()
    )


def test_a_window_past_the_phase_s_end_is_said_in_the_advice(tmp_path: Path) -> None:
    """``eventually`` over a window past its phase's end fails with -inf,
    which summary.json holds as null, as it holds a divergence's: the phase
    names the formula apart (``temporal_past_end``), and its check's advice
    says why, in summary.json and in `run`'s printout."""
    from typer.testing import CliRunner

    from wmr_mission.cli import app

    short = Path(__file__).parent / "data" / "campaigns" / "short.yaml"
    late, held = "eventually[50, 60](speed <= 100)", "eventually[0, 5](speed <= 100)"
    text = short.read_text().replace("expect:\n", f"expect:\n  temporal: ['{late}', '{held}']\n")
    mission = tmp_path / "late.yaml"
    mission.write_text(text)
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["run", str(mission), "--no-plots", "--out", str(out)])
    assert result.exit_code == 1, result.output
    summary = json.loads((out / "summary.json").read_text())
    [park] = summary["phases"]
    assert park["temporal"][late] is None
    assert park["temporal"][held] > 0.0
    assert park["temporal_past_end"] == [late]
    checks = {e["metric"]: e for e in summary["expectations"] if e["metric"] in (late, held)}
    assert not checks[late]["met"]
    assert "lies past the end of phase 'park'" in checks[late]["advice"]
    assert "advice" not in checks[held]
    assert f"try: {late}: a window of it lies past the end of phase 'park'" in result.stdout


def test_a_formula_on_the_path_in_the_runs_last_phase_has_a_value() -> None:
    """A track phase that ends the run has no reference point at the run's
    last sample (the run follows its last command): its formulas on the path
    are judged to its last reference point, as its tracking and its final
    error are, not found not finite there (null, a miss of every such run)."""
    from wmr_mission.api import run_mission
    from wmr_mission.spec.loader import load_mission_text

    text = """\
version: 1
name: last-formula
robot: {limits: {v: 1, omega: 2}}
phases:
  - name: a
    track: {path: {type: line, heading: 0, speed: 0.5}}
    until: {elapsed: 3}
  - name: b
    track: {path: {type: line, heading: 0, speed: 0.5, start: current}}
    until: {elapsed: 3}
    expect:
      temporal: ["always(lag <= 0.3)", "always(cross_track <= 0.1)", "always(speed <= 0.6)"]
"""
    run = run_mission(load_mission_text(text))
    assert run.outcome.value == "success"
    values = run.judged["phases"][1]["temporal"]
    assert all(value is not None and value > 0.1 for value in values.values()), values
