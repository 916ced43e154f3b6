"""Temporal `expect` formulas: their grammar, the signals they name, and the
check of the field that holds them (wmr_mission.spec.models.Formula).

A formula is one line of text, parsed here by a small recursive-descent parser
(mission text is data: no eval, no exec), so that a mistake is reported at
its column inside the formula (docs/mission-format.md, "Temporal expectations"):

    formula  := either
    either   := both ("or" both)*
    both     := until ("and" until)*
    until    := unary ("until" window? unary)?
    unary    := ("always" | "eventually") window? unary | "(" formula ")" | atom
    atom     := SIGNAL ("<=" | ">=") NUMBER
    window   := "[" instant "," instant "]"
    instant  := NUMBER | "entry" | "settle" | "end"

Windows are in seconds from the time the operator is read at (the phase's
start for the outermost one); none is ``[0, end]``. The judge evaluates a
formula (wmr_mission.verdicts.temporal).
"""

from __future__ import annotations

import difflib
import functools
import math
import re
from dataclasses import dataclass
from typing import Final, Literal, NamedTuple

from pydantic_core import PydanticCustomError

from wmr_mission.fields import MAX_FORMULA_LENGTH
from wmr_mission.spec.units import unit_of

__all__ = [
    "INSTANTS",
    "MAX_FORMULA_LENGTH",
    "SIGNALS",
    "Always",
    "Atom",
    "Both",
    "Either",
    "Eventually",
    "FormulaError",
    "Node",
    "Signal",
    "Until",
    "Window",
    "atoms_of",
    "checked_formula",
    "parse_formula",
    "signals_of",
]

MAX_NESTING_DEPTH: Final = 50


class Signal(NamedTuple):
    """A signal a formula may name, per sample of a phase (NaN where a phase
    does not measure it; wmr_mission.verdicts.temporal): its unit, what it is,
    where it is measured (on track phases, on phases with zones, on phases with
    a target, regulate and hold, or on every phase) and the panel of the
    verdicts figure it is drawn on (wmr_mission.verdicts.signals)."""

    unit: str
    meaning: str
    measured_on: Literal["track", "zones", "target", "every"]
    panel: str


SIGNALS: Final[dict[str, Signal]] = {
    "cross_track": Signal(
        "m",
        "distance of the true position from its place on the path (track)",
        "track",
        "cross_track",
    ),
    "lag": Signal(
        "m",
        "arc length from its place on the path to its reference point, > 0 behind",
        "track",
        "along_track",
    ),
    "zone_depth": Signal(
        "m", "depth beyond the edge of the phase's zones, > 0 beyond (zones)", "zones", "zones"
    ),
    "clearance": Signal(
        "m", "distance of the body from the zones' forbidden side (zones)", "zones", "zones"
    ),
    "target_distance": Signal(
        "m", "distance of the true position from the target (regulate)", "target", "goal"
    ),
    "heading_error": Signal(
        "rad", "|heading - the target's heading|, wrapped (regulate)", "target", "goal"
    ),
    "speed": Signal("m/s", "|v|", "every", "saturation"),
    "turn_rate": Signal("rad/s", "|omega|", "every", "saturation"),
}
# Named instants of a window: the track entry's end, the phase's settle_time,
# and the end of the phase (the trace ends there).
INSTANTS: Final = ("entry", "settle", "end")
Instant = float | Literal["entry", "settle", "end"]


class FormulaError(ValueError):
    """A refused formula; ``column`` is 1-based within the formula's text."""

    def __init__(self, message: str, column: int) -> None:
        super().__init__(message)
        self.message = message
        self.column = column


class Window(NamedTuple):
    """``[start, stop]`` in seconds, or named instants."""

    start: Instant = 0.0
    stop: Instant = "end"


# A formula's nodes are dataclasses, not NamedTuples (as the signals, windows and
# tokens are): a NamedTuple equals any tuple of the same fields, and `a and b`
# must not equal `a or b`.
@dataclass(frozen=True)
class Atom:
    """``signal <= bound`` (``above``: ``signal >= bound``)."""

    signal: str
    bound: float
    above: bool = False


@dataclass(frozen=True)
class Both:
    left: Node
    right: Node


@dataclass(frozen=True)
class Either:
    left: Node
    right: Node


@dataclass(frozen=True)
class Always:
    window: Window
    body: Node


@dataclass(frozen=True)
class Eventually:
    window: Window
    body: Node


@dataclass(frozen=True)
class Until:
    """``left until[window] right``."""

    window: Window
    left: Node
    right: Node


Node = Atom | Both | Either | Always | Eventually | Until

_KEYWORDS: Final = frozenset({"always", "eventually", "until", "and", "or"})
_TOKEN = re.compile(
    r"\s*(?:(?P<number>[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<op><=|>=|[()\[\],])|(?P<other>\S))"
)
# `cross_track <= 5 cm`: a bound written with a unit (`0.5 m/s`, `2 km / h`, `5cm`)
_BOUND_WITH_UNIT: Final = re.compile(
    r"(?P<signal>[A-Za-z_]\w*)\s*(?:<=|>=)\s*"
    r"(?P<number>[+-]?(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?)"
    r"[ \t]*(?P<unit>[^\s()\[\],]+(?:[ \t]*/[ \t]*[^\s()\[\],]+)?)"
)
_NEGATION: Final = "there is no negation: compare the other way ('>=' for not '<=')"
_HINTS: Final = {
    "<": "write '<=' (a bound is met at equality)",
    ">": "write '>=' (a bound is met at equality)",
    "=": "compare with '<=' or '>='",
    "!": _NEGATION,
    "&": "write 'and'",
    "|": "write 'or'",
}


class _Token(NamedTuple):
    kind: str  # "number" | "name" | "op" | "end"
    text: str
    column: int


def _tokens(text: str) -> list[_Token]:
    found: list[_Token] = []
    index = 0
    while True:
        match = _TOKEN.match(text, index)
        if match is None:  # only spaces are left
            return [*found, _Token("end", "", len(text) + 1)]
        kind = match.lastgroup or "other"
        column = match.start(kind) + 1
        word = match.group(kind)
        if kind == "other":
            hint = _HINTS.get(word, "expected a signal, a number, an operator or a bracket")
            raise FormulaError(f"unexpected {word!r}: {hint}", column)
        found.append(_Token(kind, word, column))
        index = match.end()


class _Parser:
    def __init__(self, text: str) -> None:
        self.tokens = _tokens(text)
        self.index = 0
        self.depth = 0

    @property
    def token(self) -> _Token:
        return self.tokens[self.index]

    def advance(self) -> _Token:
        token = self.token
        self.index += 1
        return token

    def at(self, text: str) -> bool:
        return self.token.kind in ("op", "name") and self.token.text == text

    def expect(self, text: str, what: str) -> _Token:
        if not self.at(text):
            raise self.unexpected(what)
        return self.advance()

    def unexpected(self, what: str) -> FormulaError:
        token = self.token
        if token.kind == "end":
            return FormulaError(f"the formula ends early: expected {what}", token.column)
        return FormulaError(f"unexpected {token.text!r}: expected {what}", token.column)

    def parse(self) -> Node:
        if self.token.kind == "end":
            raise FormulaError("empty formula: expected e.g. always(cross_track <= 0.1)", 1)
        node = self.either()
        if self.token.kind != "end":
            raise self.unexpected("'and', 'or', 'until' or the end of the formula")
        return node

    def either(self) -> Node:
        node = self.both()
        while self.at("or"):
            self.advance()
            node = Either(node, self.both())
        return node

    def both(self) -> Node:
        node = self.until()
        while self.at("and"):
            self.advance()
            node = Both(node, self.until())
        return node

    def until(self) -> Node:
        node = self.unary()
        if self.at("until"):
            self.advance()
            window = self.window()
            node = Until(window, node, self.unary())
            if self.at("until"):
                raise FormulaError(
                    "'until' does not chain: put one side in parentheses", self.token.column
                )
        return node

    def unary(self) -> Node:
        token = self.token
        self.depth += 1
        if self.depth > MAX_NESTING_DEPTH:
            raise FormulaError(
                f"the formula is nested too deeply (at most {MAX_NESTING_DEPTH} levels)",
                token.column,
            )
        node: Node
        if token.kind == "name" and token.text in ("always", "eventually"):
            self.advance()
            window = self.window()
            body = self.unary()
            node = Always(window, body) if token.text == "always" else Eventually(window, body)
        elif self.at("("):
            self.advance()
            node = self.either()
            if self.token.kind == "end":
                raise FormulaError("unclosed '(': expected ')'", token.column)
            self.expect(")", "')'")
        else:
            node = self.atom()
        self.depth -= 1
        return node

    def atom(self) -> Atom:
        token = self.token
        if token.kind != "name" or token.text in _KEYWORDS:
            raise self.unexpected("a signal, 'always', 'eventually' or '('")
        if token.text == "not":
            raise FormulaError(_NEGATION, token.column)
        if token.text not in SIGNALS:
            # a misspelt operator reads as a signal here: suggest either
            close = difflib.get_close_matches(token.text, [*SIGNALS, "always", "eventually"], n=1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise FormulaError(
                f"unknown signal {token.text!r}; {hint}signals: {', '.join(SIGNALS)}",
                token.column,
            )
        self.advance()
        if not (self.at("<=") or self.at(">=")):
            raise self.unexpected(f"'<=' or '>=' after {token.text}")
        above = self.advance().text == ">="
        return Atom(token.text, self.number("a number to compare with"), above)

    def number(self, what: str) -> float:
        token = self.token
        if token.kind != "number":
            raise self.unexpected(what)
        value = float(token.text)
        if not math.isfinite(value):
            raise FormulaError("the number is too large for a float", token.column)
        self.advance()
        return value

    def window(self) -> Window:
        if not self.at("["):
            return Window()
        opening = self.advance()
        start = self.instant()
        self.expect(",", "',' between the window's start and end")
        stop_token = self.token
        stop = self.instant()
        self.expect("]", "']' closing the window")
        if start == "end":
            raise FormulaError("a window cannot start at 'end'", opening.column + 1)
        if isinstance(start, float) and isinstance(stop, float) and stop < start:
            raise FormulaError(
                f"the window ends ({stop:g} s) before it starts ({start:g} s)", stop_token.column
            )
        return Window(start, stop)

    def instant(self) -> Instant:
        token = self.token
        if token.kind == "name":
            if token.text not in INSTANTS:
                raise self.unexpected(f"a time in seconds or one of {', '.join(INSTANTS)}")
            self.advance()
            return token.text  # type: ignore[return-value]  # one of INSTANTS
        value = self.number(f"a time in seconds or one of {', '.join(INSTANTS)}")
        if value < 0:
            raise FormulaError("a window's time is 0 or more seconds", token.column)
        return value


def parse_formula(text: str) -> Node:
    """The formula of ``text``, or :class:`FormulaError` at its first mistake."""
    if len(text) > MAX_FORMULA_LENGTH:
        raise FormulaError(
            f"the formula is too long ({len(text)} characters; at most {MAX_FORMULA_LENGTH})", 1
        )
    return _parsed(text)


@functools.lru_cache(maxsize=256)
def _parsed(text: str) -> Node:  # a campaign reads the same few formulas for each run
    _refuse_units(text)
    return _Parser(text).parse()


def _refuse_units(text: str) -> None:
    """A bound written with a unit (`cross_track <= 5 cm`), refused at the unit
    as a field's is, with the number to write in the signal's unit."""
    for match in _BOUND_WITH_UNIT.finditer(text):
        written, signal = unit_of(match["unit"]), SIGNALS.get(match["signal"])
        if written is None or signal is None:
            continue
        own, number = unit_of(signal.unit), match["number"]
        write = f"write the number alone, in {signal.unit}"
        if own is not None and own[0] == written[0]:
            write = f"write {float(number) * written[1] / own[1]:.6g} for {number} {match['unit']}"
        raise FormulaError(
            f"units are not written: {match['signal']} is in {signal.unit}; {write}",
            match.start("unit") + 1,
        )


def atoms_of(node: Node) -> list[Atom]:
    """The comparisons a formula makes, in the order written."""
    if isinstance(node, Atom):
        return [node]
    if isinstance(node, Always | Eventually):
        return atoms_of(node.body)
    return [*atoms_of(node.left), *atoms_of(node.right)]


def signals_of(node: Node) -> set[str]:
    """The signals a formula names."""
    if isinstance(node, Atom):
        return {node.signal}
    if isinstance(node, Always | Eventually):
        return signals_of(node.body)
    return signals_of(node.left) | signals_of(node.right)


def checked_formula(text: str) -> str:
    """``text`` if it parses, else the mistake at its column as pydantic
    reports a field's (the `temporal` field, wmr_mission.spec.models.Formula)."""
    try:
        parse_formula(text)
    except FormulaError as error:
        raise PydanticCustomError(
            "expression",
            "invalid formula: {message}",
            {"message": error.message, "column": error.column},
        ) from None
    return text
