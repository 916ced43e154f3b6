"""Restricted arithmetic expressions of phase-local time ``t``.

Mission text is data: an expression is tokenised and parsed here by a small
recursive-descent parser that knows only numbers, ``t``, ``pi``, ``e``, declared
parameters, ``+ - * / **``, parentheses and a fixed list of math functions. It
never reaches ``eval``, ``exec``, ``compile`` or the import system. The parser
emits a postfix program, so evaluation is a loop over functions applied to a
whole array of times at once and never recurses, however long the expression.
The transcendental functions and ``**`` are wmr_mission.kernels.scalar_math's, which
give the same bits on every CPU; arithmetic and the exact functions are numpy's.
"""

from __future__ import annotations

import difflib
import functools
import math
import re
from collections.abc import Callable, Collection, Mapping
from typing import Final, NamedTuple

import numpy as np
from numpy.typing import ArrayLike

from wmr_mission.basics import FloatArray
from wmr_mission.kernels import scalar_math

__all__ = [
    "FUNCTIONS",
    "MAX_EXPRESSION_LENGTH",
    "MAX_NESTING_DEPTH",
    "Expression",
    "ExpressionError",
    "parse",
]

MAX_EXPRESSION_LENGTH: Final = 1000
"""Longest accepted expression text, in characters."""

MAX_NESTING_DEPTH: Final = 50
"""Deepest accepted nesting of parentheses, calls, signs and powers."""

_Function = Callable[..., FloatArray | float]
_math = scalar_math.function_of

# name -> (function, number of arguments)
FUNCTIONS: Final[dict[str, tuple[_Function, int]]] = {
    "sin": (_math(scalar_math.SIN), 1),
    "cos": (_math(scalar_math.COS), 1),
    "tan": (_math(scalar_math.TAN), 1),
    "asin": (_math(scalar_math.ASIN), 1),
    "acos": (_math(scalar_math.ACOS), 1),
    "atan": (_math(scalar_math.ATAN), 1),
    "atan2": (_math(scalar_math.ATAN2), 2),
    "sinh": (_math(scalar_math.SINH), 1),
    "cosh": (_math(scalar_math.COSH), 1),
    "tanh": (_math(scalar_math.TANH), 1),
    "exp": (_math(scalar_math.EXP), 1),
    "log": (_math(scalar_math.LOG), 1),
    "log10": (_math(scalar_math.LOG10), 1),
    "sqrt": (np.sqrt, 1),
    "abs": (np.abs, 1),
    "min": (np.minimum, 2),
    "max": (np.maximum, 2),
    "floor": (np.floor, 1),
    "ceil": (np.ceil, 1),
    "sign": (np.sign, 1),
    "hypot": (np.hypot, 2),
}

_CONSTANTS: Final = {"pi": math.pi, "e": math.e}
_BINARY: Final[dict[str, _Function]] = {
    "+": np.add,
    "-": np.subtract,
    "*": np.multiply,
    "/": np.divide,
    "**": _math(scalar_math.POWER),
}
_ALLOWED_OPERATORS: Final = "+ - * / **"
_ALLOWED_FUNCTIONS: Final = ", ".join(FUNCTIONS)

# Python words a user might try, with what the language says about them.
_KEYWORD_MESSAGES: Final = {
    "lambda": "lambda expressions are not allowed",
    "for": "comprehensions are not allowed",
    "if": "conditional expressions are not allowed",
    "else": "conditional expressions are not allowed",
    "and": "boolean operators are not allowed",
    "or": "boolean operators are not allowed",
    "not": "boolean operators are not allowed",
    "in": "membership tests are not allowed",
    "is": "comparisons are not allowed",
    "import": "imports are not allowed",
    "yield": "'yield' is not allowed",
    "await": "'await' is not allowed",
}

# Characters with a specific explanation; anything else is "unexpected".
_CHARACTER_MESSAGES: Final = {
    "'": "strings are not allowed",
    '"': "strings are not allowed",
    ".": "attribute access is not allowed",
    "[": "subscripts and lists are not allowed",
    "]": "subscripts and lists are not allowed",
    "{": "sets and dictionaries are not allowed",
    "}": "sets and dictionaries are not allowed",
    "=": "assignments and keyword arguments are not allowed",
    "<": "comparisons are not allowed",
    ">": "comparisons are not allowed",
    "!": "comparisons are not allowed",
    ":": "':' is not allowed (no lambdas, slices or annotations)",
    ";": "only one expression is allowed (no ';')",
    "^": "operator '^' is not allowed; write a power as a**b",
    "%": f"operator '%' is not allowed; allowed operators: {_ALLOWED_OPERATORS}",
    "@": f"operator '@' is not allowed; allowed operators: {_ALLOWED_OPERATORS}",
    "&": f"operator '&' is not allowed; allowed operators: {_ALLOWED_OPERATORS}",
    "|": f"operator '|' is not allowed; allowed operators: {_ALLOWED_OPERATORS}",
    "~": f"operator '~' is not allowed; allowed operators: {_ALLOWED_OPERATORS}",
    "#": "comments are not allowed",
    "\\": "backslashes are not allowed",
}

_NUMBER = re.compile(r"(?:[0-9]+\.?[0-9]*|\.[0-9]+)(?:[eE][+-]?[0-9]+)?")
_NAME = re.compile(r"[A-Za-z_][A-Za-z0-9_]*")
_DIGITS = frozenset("0123456789")
_SPACE = frozenset(" \t\r\n")


class ExpressionError(ValueError):
    """A refused expression; ``column`` is 1-based within the expression text."""

    def __init__(self, message: str, column: int) -> None:
        super().__init__(message)
        self.message = message
        self.column = column

    def __str__(self) -> str:
        return f"column {self.column}: {self.message}"


# A postfix instruction: (operation, argument, column of the source token).
#   "number" value | "time" | "parameter" name | "negate" | "binary" op | "call" function
_Instruction = tuple[str, float | str, int]


class Expression(NamedTuple):
    """A parsed expression: its text and the postfix program it compiles to."""

    text: str
    program: tuple[_Instruction, ...]

    @property
    def depends_on_time(self) -> bool:
        """Whether ``t`` appears in the expression."""
        return any(op == "time" for op, _, _ in self.program)

    @property
    def parameter_names(self) -> frozenset[str]:
        """Declared parameters the expression reads."""
        return frozenset(str(arg) for op, arg, _ in self.program if op == "parameter")

    def evaluate(self, t: ArrayLike, parameters: Mapping[str, float]) -> FloatArray:
        """Values at times ``t`` (any shape), float64, same shape as ``t``.

        Non-finite results (``log(0)``, ``1/0``) are returned, not raised: the
        caller decides what a non-finite path point means.
        """
        times = np.asarray(t, dtype=np.float64)
        stack: list[FloatArray | float] = []
        with np.errstate(all="ignore"):
            for op, arg, column in self.program:
                if op == "number":
                    stack.append(float(arg))
                elif op == "time":
                    stack.append(times)
                elif op == "parameter":
                    if arg not in parameters:
                        raise ExpressionError(f"parameter '{arg}' has no value", column)
                    stack.append(float(parameters[str(arg)]))
                elif op == "negate":
                    stack.append(np.negative(stack.pop()))
                elif op == "binary":
                    right = stack.pop()
                    stack.append(_BINARY[str(arg)](stack.pop(), right))
                else:  # "call"
                    function, arity = FUNCTIONS[str(arg)]
                    arguments = stack[len(stack) - arity :]
                    del stack[len(stack) - arity :]
                    stack.append(function(*arguments))
            (result,) = stack
            values = np.empty(times.shape, dtype=np.float64)
            values[...] = result
        return values

    def constant(self, parameters: Mapping[str, float]) -> float:
        """The value of an expression without ``t``."""
        for op, _, column in self.program:
            if op == "time":
                raise ExpressionError(
                    "expected a constant, but the expression depends on 't'", column
                )
        return float(self.evaluate(np.zeros(()), parameters))


class _Token(NamedTuple):
    kind: str  # "number" | "name" | "op" | "end"
    text: str
    start: int  # 0-based index in the text

    @property
    def column(self) -> int:
        return self.start + 1


class _Scanner:
    """Reads tokens one at a time, so the first problem from the left is the one reported."""

    def __init__(self, text: str) -> None:
        self.text = text
        self.index = 0

    def next_token(self) -> _Token:
        text = self.text
        i = self.index
        while i < len(text) and text[i] in _SPACE:
            i += 1
        if i == len(text):
            self.index = i
            return _Token("end", "", i)
        char = text[i]
        if char in _DIGITS or (char == "." and text[i + 1 : i + 2] in _DIGITS):
            match = _NUMBER.match(text, i)
            assert match is not None  # a digit always starts a number
            end = match.end()
            if end < len(text) and (text[end].isalnum() or text[end] in "_.'\""):
                raise ExpressionError(
                    "numbers are plain decimals such as 2, 0.5 or 1e-3 "
                    "(no underscores, hexadecimal, complex or implicit products: write 2*t)",
                    i + 1,
                )
            return self.emit("number", match.group(), i, end)
        if char.isalpha() or char == "_":
            match = _NAME.match(text, i)
            if match is None:  # a non-ASCII letter
                raise ExpressionError(f"unexpected character {char!r}", i + 1)
            return self.emit("name", match.group(), i, match.end())
        if text.startswith("**", i):
            return self.emit("op", "**", i, i + 2)
        if text.startswith("==", i):
            raise ExpressionError("comparisons are not allowed", i + 1)
        if text.startswith("//", i):
            raise ExpressionError(
                f"operator '//' is not allowed; allowed operators: {_ALLOWED_OPERATORS}", i + 1
            )
        if char in "+-*/(),":
            return self.emit("op", char, i, i + 1)
        raise ExpressionError(
            _CHARACTER_MESSAGES.get(char, f"unexpected character {char!r}"), i + 1
        )

    def emit(self, kind: str, text: str, start: int, end: int) -> _Token:
        self.index = end
        return _Token(kind, text, start)

    def opens_call(self) -> bool:
        """Whether the next character after the current token, spaces aside, is '('."""
        rest = self.text[self.index :].lstrip()
        return rest.startswith("(")


class _Parser:
    """Recursive descent over Python's precedence for the allowed operators.

    expression := term (("+" | "-") term)*
    term       := factor (("*" | "/") factor)*
    factor     := ("+" | "-") factor | power
    power      := primary ("**" factor)?
    primary    := number | name | function "(" arguments ")" | "(" expression ")"
    """

    def __init__(self, text: str, parameters: Collection[str], allow_t: bool) -> None:
        self.scanner = _Scanner(text)
        self.token = self.scanner.next_token()
        self.depth = 0
        self.parameters = frozenset(parameters)
        self.allow_t = allow_t
        self.program: list[_Instruction] = []
        # Unknown names and functions: parsing goes on, so that every one is reported.
        self.undefined: list[tuple[ExpressionError, str]] = []

    # -- helpers -------------------------------------------------------
    def advance(self) -> _Token:
        token = self.token
        self.token = self.scanner.next_token()
        return token

    def at(self, *ops: str) -> bool:
        return self.token.kind == "op" and self.token.text in ops

    def enter(self, token: _Token) -> None:
        self.depth += 1
        if self.depth > MAX_NESTING_DEPTH:
            raise ExpressionError(
                f"expression is nested too deeply (at most {MAX_NESTING_DEPTH} levels)",
                token.column,
            )

    def allowed_names(self) -> str:
        names = ["t", "pi", "e"] if self.allow_t else ["pi", "e"]
        allowed = ", ".join(names)
        if self.parameters:
            allowed += ", parameters " + ", ".join(sorted(self.parameters))
        return allowed

    # -- grammar -------------------------------------------------------
    def parse(self) -> tuple[_Instruction, ...]:
        if self.token.kind == "end":
            raise ExpressionError("empty expression", 1)
        try:
            self.expression()
            if self.token.kind != "end":
                raise self.unexpected("an operator")
        except ExpressionError as error:
            if self.undefined and self.undefined[0][0].column < error.column:
                raise self.undefined_error() from None
            raise
        if self.undefined:
            raise self.undefined_error()
        return tuple(self.program)

    def undefined_error(self) -> ExpressionError:
        """The first unknown name in full, and every other one after it."""
        (first, _), *others = self.undefined
        if not others:
            return first
        also = ", ".join(f"{short} at character {error.column}" for error, short in others)
        return ExpressionError(f"{first.message}; also {also}", first.column)

    def unknown(self, message: str, short: str, token: _Token) -> None:
        self.undefined.append((ExpressionError(message, token.column), short))
        self.program.append(("number", 0.0, token.column))  # stands in while parsing goes on

    def expression(self) -> None:
        self.term()
        while self.at("+", "-"):
            operator = self.advance()
            self.term()
            self.program.append(("binary", operator.text, operator.column))

    def term(self) -> None:
        self.factor()
        while self.at("*", "/"):
            operator = self.advance()
            self.factor()
            self.program.append(("binary", operator.text, operator.column))

    def factor(self) -> None:
        if self.at("+", "-"):
            sign = self.advance()
            self.enter(sign)
            self.factor()
            self.depth -= 1
            if sign.text == "-":
                self.program.append(("negate", "", sign.column))
            return
        self.power()

    def power(self) -> None:
        self.primary()
        if self.at("**"):
            operator = self.advance()
            self.enter(operator)
            self.factor()  # right-associative, and 2**-1 is allowed as in Python
            self.depth -= 1
            self.program.append(("binary", "**", operator.column))

    def primary(self) -> None:
        token = self.token
        if token.kind == "number":
            self.advance()
            value = float(token.text)
            if not math.isfinite(value):
                raise ExpressionError("number is too large for a float", token.column)
            self.program.append(("number", value, token.column))
        elif token.kind == "name":
            if self.scanner.opens_call():
                self.call(token)
            else:
                self.name(token)
        elif self.at("("):
            self.advance()
            self.enter(token)
            if self.at(")"):
                raise ExpressionError("empty parentheses: expected an expression", token.column)
            self.expression()
            self.expect_closing(token)
            self.depth -= 1
        else:
            raise self.unexpected("a number, a name or '('")

    def name(self, token: _Token) -> None:
        # Judged before the next token is read, so `x[0]` reports the unknown `x` first.
        name = token.text
        if name in _KEYWORD_MESSAGES:
            raise ExpressionError(_KEYWORD_MESSAGES[name], token.column)
        if name in FUNCTIONS:
            raise ExpressionError(
                f"'{name}' is a function: call it with parentheses, as in {name}(t)", token.column
            )
        if name == "t":
            if not self.allow_t:
                raise ExpressionError(
                    "'t' is not allowed here: this value must be a constant", token.column
                )
            self.program.append(("time", "", token.column))
        elif name in self.parameters:
            self.program.append(("parameter", name, token.column))
        elif name in _CONSTANTS:
            self.program.append(("number", _CONSTANTS[name], token.column))
        else:
            short = self.unknown_name(name)
            self.unknown(f"{short}; allowed: {self.allowed_names()}", short, token)
        self.advance()

    def unknown_name(self, name: str) -> str:
        candidates = [*self.parameters, *_CONSTANTS, *(["t"] if self.allow_t else [])]
        close = difflib.get_close_matches(name, candidates, n=1)
        hint = f" (did you mean '{close[0]}'?)" if close else ""
        return f"unknown name '{name}'{hint}"

    def call(self, token: _Token) -> None:
        name = token.text
        if name not in FUNCTIONS:
            if name in self.parameters or name in _CONSTANTS or name == "t":
                raise ExpressionError(
                    f"'{name}' is not a function; write a product as {name}*(...)", token.column
                )
            close = difflib.get_close_matches(name, list(FUNCTIONS), n=1)
            hint = f" (did you mean '{close[0]}'?)" if close else ""
            short = f"function '{name}' is not allowed{hint}"
            self.unknown(f"{short}; allowed functions: {_ALLOWED_FUNCTIONS}", short, token)
        arity = FUNCTIONS[name][1] if name in FUNCTIONS else -1
        self.advance()
        opening = self.advance()
        self.enter(token)
        count = 0
        if not self.at(")"):
            while True:
                self.expression()
                count += 1
                if not self.at(","):
                    break
                self.advance()
        self.expect_closing(opening)
        self.depth -= 1
        if arity < 0:
            return  # unknown: already recorded; its arguments were read for more problems
        if count != arity:
            plural = "argument" if arity == 1 else "arguments"
            raise ExpressionError(
                f"function '{name}' takes {arity} {plural}, got {count}", token.column
            )
        self.program.append(("call", name, token.column))

    def expect_closing(self, opening: _Token) -> None:
        if self.at(")"):
            self.advance()
            return
        if self.token.kind == "end":
            raise ExpressionError("unclosed '(': expected ')'", opening.column)
        if self.at(","):
            raise ExpressionError(
                "',' is only allowed between the arguments of a function (no tuples)",
                self.token.column,
            )
        raise self.unexpected("')'")

    def unexpected(self, expected: str) -> ExpressionError:
        token = self.token
        if token.kind == "end":
            return ExpressionError(
                f"unexpected end of expression: expected {expected}", token.column
            )
        if token.kind == "name" and token.text in _KEYWORD_MESSAGES:
            return ExpressionError(_KEYWORD_MESSAGES[token.text], token.column)
        if token.text == ",":
            return ExpressionError(
                "',' is only allowed between the arguments of a function (no tuples)", token.column
            )
        return ExpressionError(f"unexpected '{token.text}': expected {expected}", token.column)


def parse(text: str, parameters: Collection[str], *, allow_t: bool = True) -> Expression:
    """Parse ``text`` into an :class:`Expression` or raise :class:`ExpressionError`.

    ``parameters`` are the declared parameter names the text may use; with
    ``allow_t=False`` the expression must be a constant (a Scalar field).
    """
    if not isinstance(text, str):
        raise ExpressionError(f"expected an expression as text, got {type(text).__name__}", 1)
    if len(text) > MAX_EXPRESSION_LENGTH:  # before any scanning: a huge text is refused at once
        raise ExpressionError(
            f"expression is too long ({len(text)} characters; at most {MAX_EXPRESSION_LENGTH})", 1
        )
    return _parsed(text, frozenset(parameters), allow_t)


@functools.lru_cache(maxsize=256)
def _parsed(text: str, parameters: frozenset[str], allow_t: bool) -> Expression:
    # A campaign parses the same few texts for each of its runs; an Expression is immutable.
    return Expression(text=text, program=_Parser(text, parameters, allow_t).parse())
