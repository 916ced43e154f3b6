from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from wmr_mission.expressions import (
    FUNCTIONS,
    MAX_EXPRESSION_LENGTH,
    MAX_NESTING_DEPTH,
    ExpressionError,
    parse,
)

T = np.linspace(-3.0, 3.0, 61)
PARAMETERS = {"a": 1.5, "b": -0.25}


@pytest.mark.parametrize(
    ("text", "expected"),
    [
        ("2*exp(0.5*t)*cos(0.4*pi*t)", 2 * np.exp(0.5 * T) * np.cos(0.4 * np.pi * T)),
        ("5.5*sin(a*t) + b", 5.5 * np.sin(1.5 * T) - 0.25),
        ("-t**2", -(T**2)),
        ("2**-t", 2.0**-T),
        ("2**3**2 + 0*t", np.full_like(T, 512.0)),
        ("1 - 2 - 3 + t", -4.0 + T),
        ("8 / 4 / 2 * t", T),
        ("+t - -t", 2 * T),
        ("e**t", np.exp(T)),
        ("atan2(t, 1 + t**2)", np.arctan2(T, 1 + T**2)),
        ("hypot(t, a)", np.hypot(T, 1.5)),
        ("min(t, 0) + max(t, 1)", np.minimum(T, 0) + np.maximum(T, 1)),
        ("floor(t) + ceil(t) + sign(t) + abs(t)", np.floor(T) + np.ceil(T) + np.sign(T) + abs(T)),
        ("sinh(t) * cosh(t) / (1 + tanh(t)**2)", np.sinh(T) * np.cosh(T) / (1 + np.tanh(T) ** 2)),
        ("asin(t/4) + acos(t/4) + atan(t)", np.arcsin(T / 4) + np.arccos(T / 4) + np.arctan(T)),
        (
            "log(1 + t**2) + log10(2 + t**2) + sqrt(t**2)",
            np.log1p(T**2) + np.log10(2 + T**2) + abs(T),
        ),
        ("tan(t / 4)", np.tan(T / 4)),
        ("1.5e-1 * .5 + 3. + t", 0.075 + 3.0 + T),
        ("  (\tt\n)  ", T),
    ],
)
def test_evaluates_like_numpy(text: str, expected: np.ndarray) -> None:
    values = parse(text, PARAMETERS).evaluate(T, PARAMETERS)
    assert values.dtype == np.float64
    np.testing.assert_allclose(values, expected, rtol=1e-13, atol=1e-13)


def test_every_function_is_callable_with_its_arity() -> None:
    for name, (function, arity) in FUNCTIONS.items():
        arguments = ", ".join(["0.3*t"] * arity)
        values = parse(f"{name}({arguments})", []).evaluate(T, {})
        with np.errstate(all="ignore"):
            expected = function(*([0.3 * T] * arity))
        np.testing.assert_allclose(values, expected, rtol=1e-13, err_msg=name)


def test_result_has_the_shape_of_t_even_for_constants() -> None:
    times = np.zeros((3, 4))
    assert parse("2*pi", []).evaluate(times, {}).shape == (3, 4)
    assert parse("t + 1", []).evaluate(times, {}).shape == (3, 4)
    assert parse("a", ["a"]).evaluate(np.float64(2.0), {"a": 3.0}).shape == ()


def test_constant_expressions() -> None:
    assert parse("0.4*pi", [], allow_t=False).constant({}) == pytest.approx(0.4 * math.pi)
    assert parse("2*k", ["k"], allow_t=False).constant({"k": 1.25}) == 2.5
    with pytest.raises(ExpressionError, match="must be a constant") as error:
        parse("2*t", [], allow_t=False)
    assert error.value.column == 3
    with pytest.raises(ExpressionError, match="depends on 't'"):
        parse("1 + t", []).constant({})


def test_non_finite_results_are_returned_without_warnings() -> None:
    # warnings are errors in this test suite: any numpy warning would fail here
    times = np.array([0.0, 1.0])
    assert np.isneginf(parse("log(t)", []).evaluate(times, {})[0])
    assert np.isposinf(parse("1/t", []).evaluate(times, {})[0])
    assert np.isnan(parse("sqrt(-1 - t)", []).evaluate(times, {})).all()
    assert math.isinf(parse("exp(1000)", [], allow_t=False).constant({}))


def test_missing_parameter_value_is_an_expression_error() -> None:
    with pytest.raises(ExpressionError, match="parameter 'k' has no value"):
        parse("k*t", ["k"]).evaluate(T, {})


def test_depends_on_time_and_parameter_names() -> None:
    expression = parse("a*sin(t) + b", ["a", "b", "c"])
    assert expression.depends_on_time
    assert expression.parameter_names == {"a", "b"}
    assert not parse("a + 1", ["a"]).depends_on_time


FORBIDDEN = [
    # (text, 1-based column, message fragment)
    ("__import__('os').system('touch x')", 1, "function '__import__' is not allowed"),
    ("().__class__", 1, "empty parentheses"),
    ("(1).__class__", 4, "attribute access is not allowed"),
    ("t.real", 2, "attribute access is not allowed"),
    ("x[0]", 1, "unknown name 'x'; allowed: t, pi, e, parameters a, b"),
    ("a[0]", 2, "subscripts"),
    ("lambda: 1", 1, "lambda expressions are not allowed"),
    ('"a"', 1, "strings are not allowed"),
    ("t + 'a'", 5, "strings are not allowed"),
    ("[t for t in a]", 1, "subscripts and lists are not allowed"),
    ("sin(t for t in a)", 7, "comprehensions are not allowed"),
    ("{1: 2}", 1, "sets and dictionaries"),
    ("system(1)", 1, "function 'system' is not allowed; allowed functions: sin, cos"),
    ("foo + 1", 1, "unknown name 'foo'; allowed: t, pi, e, parameters a, b"),
    ("sin(t, 1)", 1, "function 'sin' takes 1 argument, got 2"),
    ("atan2(t)", 1, "function 'atan2' takes 2 arguments, got 1"),
    ("max(t, b=1)", 9, "keyword arguments"),
    ("sin", 1, "'sin' is a function"),
    ("t(2)", 1, "'t' is not a function"),
    ("1_000", 1, "numbers are plain decimals"),
    ("1j", 1, "numbers are plain decimals"),
    ("0x10", 1, "numbers are plain decimals"),
    ("2t", 1, "implicit products"),
    ("1e999", 1, "too large"),
    ("9" * 400, 1, "too large"),
    ("t if t else 1", 3, "conditional expressions are not allowed"),
    ("t and 1", 3, "boolean operators are not allowed"),
    ("t == 1", 3, "comparisons are not allowed"),
    ("t < 1", 3, "comparisons are not allowed"),
    ("t % 2", 3, "operator '%' is not allowed"),
    ("t // 2", 3, "operator '//' is not allowed"),
    ("t ^ 2", 3, "write a power as a**b"),
    ("(1, 2)", 3, "no tuples"),
    ("t; 1", 2, "only one expression"),
    ("", 1, "empty expression"),
    ("1 +", 4, "unexpected end of expression"),
    ("(t", 1, "unclosed '('"),
    ("t t", 3, "unexpected 't': expected an operator"),
    ("sni(t)", 1, "did you mean 'sin'?"),
    ("π*t", 1, "unexpected character"),
    ("t²", 2, "unexpected character"),
]


@pytest.mark.parametrize(("text", "column", "message"), FORBIDDEN)
def test_forbidden_constructs_are_refused_with_their_column(
    text: str, column: int, message: str
) -> None:
    with pytest.raises(ExpressionError) as error:
        parse(text, ["a", "b"])
    assert message in error.value.message
    assert error.value.column == column
    assert str(error.value) == f"column {column}: {error.value.message}"


def test_refusal_executes_nothing(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    for text in ("__import__('os').system('touch x')", "open('x', 'w')", "exec('1')"):
        with pytest.raises(ExpressionError):
            parse(text, [])
    assert list(tmp_path.iterdir()) == []


def test_a_huge_expression_is_refused_by_its_length_alone() -> None:
    huge = "(" * (10 * 1024 * 1024)  # a scan would report the nesting instead
    with pytest.raises(ExpressionError, match="too long") as error:
        parse(huge, [])
    assert error.value.column == 1
    assert str(MAX_EXPRESSION_LENGTH) in error.value.message
    at_limit = "+".join(["t"] * 500) + " "
    assert len(at_limit) == MAX_EXPRESSION_LENGTH
    parse(at_limit, [])


# the column of the level too many: the '(' , the sign, the function name, the '**'
@pytest.mark.parametrize(("opening", "offset"), [("(", 1), ("-", 1), ("sin(", 1), ("2**", 2)])
def test_nesting_depth_is_bounded(opening: str, offset: int) -> None:
    closing = ")" if opening.endswith("(") else ""
    deepest = opening * MAX_NESTING_DEPTH + "t" + closing * MAX_NESTING_DEPTH
    parse(deepest, [])
    too_deep = opening * (MAX_NESTING_DEPTH + 1) + "t" + closing * (MAX_NESTING_DEPTH + 1)
    with pytest.raises(ExpressionError, match="nested too deeply") as error:
        parse(too_deep, [])
    assert error.value.column == MAX_NESTING_DEPTH * len(opening) + offset


def test_long_flat_sums_evaluate_without_recursion() -> None:
    text = "+".join(["t"] * 500)
    assert len(text) <= MAX_EXPRESSION_LENGTH
    np.testing.assert_allclose(parse(text, []).evaluate(T, {}), 500 * T)


@settings(max_examples=300, deadline=None)
@given(
    st.text(alphabet=st.sampled_from(list("t()+-*/.,e0123456789 sincoqrp_[]'\"=a")), max_size=40)
)
def test_any_text_parses_or_raises_an_expression_error(text: str) -> None:
    column = 0
    try:
        expression = parse(text, ["a"])
    except ExpressionError as error:
        column = error.column
    else:
        assert expression.evaluate(T, {"a": 0.5}).shape == T.shape
        column = 1
    assert 1 <= column <= len(text) + 1


def _expressions() -> st.SearchStrategy[str]:
    leaves = st.one_of(
        st.just("t"),
        st.just("a"),
        st.floats(min_value=0.0, max_value=10.0, allow_nan=False).map(lambda v: f"{v!r}"),
    )

    def extend(children: st.SearchStrategy[str]) -> st.SearchStrategy[str]:
        binary = st.tuples(children, st.sampled_from(["+", "-", "*"]), children).map(
            lambda p: f"({p[0]} {p[1]} {p[2]})"
        )
        unary = children.map(lambda c: f"-{c}")
        call = st.tuples(st.sampled_from(["sin", "cos", "atan"]), children).map(
            lambda p: f"{p[0]}({p[1]})"
        )
        return st.one_of(binary, unary, call)

    return st.recursive(leaves, extend, max_leaves=12)


@settings(max_examples=200, deadline=None)
@given(_expressions(), st.floats(min_value=-5, max_value=5))
def test_agrees_with_python_arithmetic(text: str, time: float) -> None:
    # a reference evaluation of the same fully parenthesised text with Python floats
    reference = _reference(text, time, 0.5)
    value = float(parse(text, ["a"]).evaluate(np.array(time), {"a": 0.5}))
    assert value == pytest.approx(reference, rel=1e-12, abs=1e-12)


def _reference(text: str, time: float, a: float) -> float:
    """Evaluate the generator's fully parenthesised subset by hand."""
    text = text.strip()
    if text.startswith("-"):
        return -_reference(text[1:], time, a)
    for name, function in (("sin", math.sin), ("cos", math.cos), ("atan", math.atan)):
        if text.startswith(name + "("):
            return function(_reference(text[len(name) + 1 : -1], time, a))
    if text.startswith("("):
        inner = text[1:-1]
        depth = 0
        for i, char in enumerate(inner):
            depth += {"(": 1, ")": -1}.get(char, 0)
            if depth == 0 and char == " " and inner[i + 1] in "+-*" and inner[i + 2] == " ":
                left = _reference(inner[:i], time, a)
                right = _reference(inner[i + 3 :], time, a)
                operator = inner[i + 1]
                if operator == "+":
                    return left + right
                return left - right if operator == "-" else left * right
        raise AssertionError(text)
    if text == "t":
        return time
    if text == "a":
        return a
    return float(text)
