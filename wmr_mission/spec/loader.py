"""Read a mission file into a :class:`Mission`, with a position for every problem.

The YAML text is composed (never constructed) with PyYAML's safe loader into a
node tree, and plain data is built from it by hand while a map from each data
path to its line and column is kept. Only plain YAML is accepted: mappings,
sequences, text, numbers, booleans and null; no anchors, aliases or tags.
Every problem of a file is reported at once as ``FILE:LINE:COL: message``.
"""

from __future__ import annotations

import copy
import functools
import math
import os
import re
import stat
import typing
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Annotated, Any, Final, Literal, NamedTuple

import yaml
from pydantic import BaseModel, ValidationError
from pydantic.fields import FieldInfo

from wmr_mission import expressions
from wmr_mission.fields import (
    ABSURD,
    IDENTIFIER,
    LARGEST_SEED,
    Registry,
    did_you_mean,
    type_name,
)
from wmr_mission.geometry.regions import RegionSpec
from wmr_mission.spec.checks import DataPath, Finding, Severity, check
from wmr_mission.spec.models import (
    ACTIONS,
    MISSION_NAME,
    PHASE_NAME,
    Mission,
    Threshold,
)
from wmr_mission.spec.units import unit_of
from wmr_mission.terminal import shown

__all__ = [
    "MAX_FILE_BYTES",
    "Diagnostic",
    "MissionError",
    "Override",
    "OverrideFormError",
    "check_mission",
    "check_mission_bytes",
    "check_mission_data",
    "check_mission_document",
    "check_mission_text",
    "dotted_path",
    "internal_error",
    "load_mission",
    "load_mission_data",
    "load_mission_text",
    "overrides_of",
    "overrides_of_texts",
    "parse_override",
    "read_source",
    "resolved_path",
    "unreadable",
    "validate_mission",
]

MAX_FILE_BYTES: Final = 1_000_000
"""Largest accepted mission file, in bytes."""

MAX_NESTING: Final = 32
"""Deepest accepted nesting of mappings and sequences."""

# More digits than any sane number has; refused before conversion (int() of a
# huge digit string is slow and limited).
_MAX_NUMBER_TEXT: Final = 40


class Diagnostic(NamedTuple):
    """One problem of a mission file, at a 1-based line and column."""

    file: str
    line: int
    column: int
    message: str
    severity: Severity = "error"
    # "schema": reading the file and checking each field; "semantics": the
    # checks across fields, which run once the schema stage found no error.
    stage: Literal["schema", "semantics"] = "schema"

    def __str__(self) -> str:
        # line 0: not from a file's text (a `--set`, a dict), so no position to give
        where = f"{self.file}:{self.line}:{self.column}" if self.line else self.file
        severity = "" if self.severity == "error" else f"{self.severity}: "
        # One line, whatever a file name or the message echoes of the mission.
        return shown(f"{where}: {severity}{self.message}", None)


class MissionError(ValueError):
    """A mission that cannot be used; ``diagnostics`` says why, with positions.

    Raised for files, texts, dicts, overrides and models alike.
    """

    def __init__(self, diagnostics: Sequence[Diagnostic]) -> None:
        self.diagnostics = list(diagnostics)
        super().__init__("\n".join(str(d) for d in self.diagnostics))


# --- YAML to plain data with positions --------------------------------------


class _Refused(yaml.MarkedYAMLError):
    """A YAML feature a mission does not use."""


class _NodeLoader(yaml.SafeLoader):
    """Safe composer that refuses anchors, aliases and deep nesting while composing."""

    def __init__(self, stream: str) -> None:
        super().__init__(stream)
        self._depth = 0

    def compose_node(self, parent: yaml.Node | None, index: Any) -> yaml.Node | None:
        event: Any = self.peek_event()  # type: ignore[no-untyped-call]
        mark: Any = event.start_mark
        if isinstance(event, yaml.AliasEvent):
            raise _Refused(
                problem=f"alias '*{event.anchor}' is not allowed in a mission: write the value out",
                problem_mark=mark,
            )
        if getattr(event, "anchor", None) is not None:
            raise _Refused(
                problem=f"anchor '&{event.anchor}' is not allowed in a mission: "
                "write the value out",
                problem_mark=mark,
            )
        self._depth += 1
        try:
            if self._depth > MAX_NESTING:
                raise _Refused(
                    problem=f"nesting deeper than {MAX_NESTING} levels",
                    problem_mark=mark,
                )
            node: yaml.Node | None = super().compose_node(parent, index)
        finally:
            self._depth -= 1
        tag = getattr(event, "tag", None)
        if node is not None and tag is not None:
            # Any tag written (`!!float 0.01`, `!custom`, `!`) is refused as
            # written, even one naming the type the value would have anyway.
            node.tag = "!!" + tag[len(_TAG) :] if tag.startswith(_TAG) else tag
        return node

    def resolve(self, kind: Any, value: Any, implicit: Any) -> Any:
        if kind is yaml.ScalarNode and implicit[0]:
            return _core_tag(value)
        return super().resolve(kind, value, implicit)  # type: ignore[no-untyped-call]


_TAG = "tag:yaml.org,2002:"
# The YAML 1.2 core schema: a plain scalar is a null, boolean, integer or float
# only when it matches these; anything else is text. (PyYAML resolves YAML 1.1,
# where `yes` is a boolean, `010` octal 8 and `1:30` the number 90.)
_NULL_12: Final = frozenset({"", "~", "null", "Null", "NULL"})
_BOOL_12: Final = {"true": True, "True": True, "TRUE": True}
_BOOL_12.update({"false": False, "False": False, "FALSE": False})
_INT_12 = re.compile(r"[-+]?[0-9]+|0o[0-7]+|0x[0-9a-fA-F]+")
_FLOAT_12 = re.compile(
    r"[-+]?(?:\.[0-9]+|[0-9]+(?:\.[0-9]*)?)(?:[eE][-+]?[0-9]+)?"
    r"|[-+]?\.(?:inf|Inf|INF)|\.(?:nan|NaN|NAN)"
)
# A date or time, which YAML 1.1 reads as a timestamp: refused as ambiguous
# (quoted, it is text in either version).
_TIMESTAMP_11 = re.compile(
    r"[0-9]{4}-[0-9]{1,2}-[0-9]{1,2}(?:(?:[Tt]|[ \t]+)[0-9]{1,2}:[0-9]{2}:[0-9]{2}"
    r"(?:\.[0-9]*)?(?:[ \t]*(?:Z|[-+][0-9]{1,2}(?::[0-9]{2})?))?)?"
)
# What YAML 1.1 would have read from a plain scalar that YAML 1.2 reads as text.
_BOOL_11 = re.compile(r"y|Y|yes|Yes|YES|n|N|no|No|NO|on|On|ON|off|Off|OFF")
_SEXAGESIMAL_11 = re.compile(r"[-+]?[0-9][0-9_]*(?::[0-5]?[0-9])+(?:\.[0-9_]*)?")
_UNDERSCORE_11 = re.compile(r"[-+]?[0-9][0-9_]*(?:\.[0-9_]*)?")


def _core_tag(text: str) -> str:
    """The YAML 1.2 core-schema tag of a plain scalar."""
    if text in _NULL_12:
        return _TAG + "null"
    if text in _BOOL_12:
        return _TAG + "bool"
    if _INT_12.fullmatch(text):
        return _TAG + "int"
    if _FLOAT_12.fullmatch(text):
        return _TAG + "float"
    if _TIMESTAMP_11.fullmatch(text):
        return _TAG + "timestamp"
    return _TAG + "str"


def yaml11_hint(text: str) -> str:
    """How a text value was read, when YAML 1.1 would have read it otherwise ('' if not)."""
    if _BOOL_11.fullmatch(text):
        return (
            f" (read as the text {text!r}: in YAML 1.2, which missions use, "
            "the booleans are true and false)"
        )
    if _SEXAGESIMAL_11.fullmatch(text):
        sign = -1.0 if text.startswith("-") else 1.0
        value = 0.0
        for part in text.lstrip("+-").replace("_", "").split(":"):
            value = value * 60 + float(part)
        return (
            f" (read as the text {text!r}: YAML 1.2 has no base-60 numbers; write {sign * value:g})"
        )
    if "_" in text and _UNDERSCORE_11.fullmatch(text):
        return f" (read as the text {text!r}: write numbers without '_')"
    return ""


def _tag_message(tag: str) -> str:
    written = "!!" + tag[len(_TAG) :] if tag.startswith(_TAG) else tag
    return (
        f"YAML tag {written!r} is not allowed in a mission: only plain mappings, lists, text, "
        "numbers, booleans and null"
    )


@dataclass
class Document:
    """Plain data of a mission file and where each piece of it was written."""

    data: Any
    values: dict[DataPath, tuple[int, int, int]] = field(default_factory=dict)
    keys: dict[DataPath, tuple[int, int]] = field(default_factory=dict)
    # A text written over several lines: where each line's part of it starts,
    # in the text and in the file (:func:`_text_lines`).
    lines: dict[DataPath, tuple[tuple[int, int, int], ...]] = field(default_factory=dict)
    # Paths whose value was refused while reading; later errors under them are noise.
    refused: set[DataPath] = field(default_factory=set)
    # Paths set from outside the text, and how the user wrote each (`--set PATH=VALUE`).
    overrides: dict[DataPath, str] = field(default_factory=dict)

    def position(self, path: DataPath, *, at_key: bool = False) -> tuple[int, int]:
        """Line and column of the deepest written part of ``path``; (0, 0) when
        nothing of it was written in a text (a mission built from a dict)."""
        if at_key and path in self.keys:
            return self.keys[path]
        for end in range(len(path), -1, -1):
            found = self.values.get(path[:end])
            if found is not None:
                return found[0], found[1]
        return 0, 0

    def override_of(self, path: DataPath) -> str | None:
        """How the user wrote the override that set ``path`` (or a parent of it),
        or that wrote the key ``path`` on its way (``--set robot.limitz.v=3``
        writes ``robot.limitz``, which the file never had)."""
        for end in range(len(path), 0, -1):
            source = self.overrides.get(path[:end])
            if source is not None:
                return source
        if path not in self.values:
            for written, source in self.overrides.items():
                if written[: len(path)] == path:
                    return source
        return None

    def text_position(self, path: DataPath, column: int) -> tuple[int, int] | None:
        """Line and column in the file of the ``column``-th character (from 1)
        of a text value: of one line, or of several folded as written
        (:func:`_text_lines`); None where the text's characters are not the
        file's (an escape, a folded blank line)."""
        found = self.values.get(path)
        if found is not None and found[2] >= 0:
            return found[0], found[1] + found[2] + column - 1
        at = None
        for start, line, first in self.lines.get(path, ()):
            if start > column - 1:
                break
            at = line, first + column - 1 - start
        return at


def _text_lines(node: yaml.ScalarNode) -> tuple[tuple[int, int, int], ...] | None:
    """Where each line of a text written over several lines (plain, or a
    ``>`` or ``|`` block) starts: its index in the text, its line and column
    in the file (from 1); None unless the text is its lines joined as YAML
    folds them (a space, a line break in a ``|`` block) with nothing else
    changed, so that no position is ever guessed."""
    buffer = getattr(node.start_mark, "buffer", None)
    if not isinstance(buffer, str) or node.style not in (None, ">", "|"):
        return None
    written = buffer[node.start_mark.pointer : node.end_mark.pointer].split("\n")
    first = node.start_mark.line + 1
    parts: list[tuple[str, int, int]] = []  # (part, line, column)
    if node.style is None:  # a plain text: each line's own, its indentation dropped
        parts.append((written[0].rstrip(), first, node.start_mark.column + 1))
        for number, text in enumerate(written[1:], start=first + 1):
            kept = text.lstrip(" ")
            parts.append((kept.rstrip(), number, len(text) - len(kept) + 1))
    else:  # a block: the lines after its `>-` or `|`, the first's indentation dropped
        body = written[1:]
        while body and not body[-1].strip():
            body.pop()
        indent = len(body[0]) - len(body[0].lstrip(" ")) if body else 0
        parts = [(text[indent:], first + 1 + i, indent + 1) for i, text in enumerate(body)]
    joined, found = "", list[tuple[int, int, int]]()
    for part, line, column in parts:
        joined += ("\n" if node.style == "|" else " ") if found else ""
        found.append((len(joined), line, column))
        joined += part
    return tuple(found) if joined == str(node.value).rstrip("\n") else None


def _mark(mark: yaml.Mark | None) -> tuple[int, int]:
    return (mark.line + 1, mark.column + 1) if mark is not None else (1, 1)


class _Builder:
    """Plain data from a node tree, recording positions and reading problems."""

    def __init__(self, document: Document) -> None:
        self.document = document
        self.findings: list[Finding] = []
        self._constructor = yaml.SafeLoader("")

    def refuse(self, path: DataPath, message: str, *, at_key: bool = False) -> None:
        self.document.refused.add(path)
        self.findings.append(Finding(path, message, at_key=at_key))

    def build(self, node: yaml.Node, path: DataPath) -> Any:
        line, column = _mark(node.start_mark)
        one_line = node.start_mark.line == node.end_mark.line
        offset = -1
        if isinstance(node, yaml.ScalarNode) and one_line:
            offset = 1 if node.style in ("'", '"') else 0
            # an escape ("\t", "''") makes the text shorter than the file's
            # characters: a column within the text would land short of its place
            if offset and node.end_mark.column - node.start_mark.column != len(node.value) + 2:
                offset = -1
        self.document.values[path] = (line, column, offset)
        if isinstance(node, yaml.ScalarNode) and not one_line:
            found = _text_lines(node)
            if found is not None:
                self.document.lines[path] = found
        if isinstance(node, yaml.MappingNode):
            return self._mapping(node, path)
        if isinstance(node, yaml.SequenceNode):
            if node.tag != _TAG + "seq":
                self.refuse(path, _tag_message(node.tag))
                return None
            return [self.build(item, (*path, index)) for index, item in enumerate(node.value)]
        return self._scalar(node, path)

    def _mapping(self, node: yaml.MappingNode, path: DataPath) -> dict[str, Any] | None:
        if node.tag != _TAG + "map":
            self.refuse(path, _tag_message(node.tag))
            return None
        result: dict[str, Any] = {}
        for key_node, value_node in node.value:
            if not isinstance(key_node, yaml.ScalarNode):
                self.findings.append(
                    Finding(
                        path,
                        "a key must be a plain word, not a list or mapping",
                        position=_mark(key_node.start_mark),
                    )
                )
                self.document.refused.add(path)
                continue
            if key_node.tag.startswith("!"):  # a tag written on a key
                self.findings.append(
                    Finding(path, _tag_message(key_node.tag), position=_mark(key_node.start_mark))
                )
                self.document.refused.add(path)
                continue
            # The key as written: `on`, `y` or `null` stay words, as in YAML 1.2.
            key = _characters(str(key_node.value))
            if key is None:
                self.findings.append(
                    Finding(path, _LONE_SURROGATE, position=_mark(key_node.start_mark))
                )
                self.document.refused.add(path)
                continue
            key_path = (*path, key)
            if key in result:
                first_line, first_column = self.document.keys[key_path]
                self.findings.append(
                    Finding(
                        key_path,
                        f"duplicate key {key!r} (first written at {first_line}:{first_column}); "
                        "each key may appear once",
                        position=_mark(key_node.start_mark),
                    )
                )
                continue
            self.document.keys[key_path] = _mark(key_node.start_mark)
            result[key] = self.build(value_node, key_path)
        return result

    def _scalar(self, node: yaml.Node, path: DataPath) -> Any:
        tag, text = node.tag, str(node.value)
        if tag == _TAG + "str":
            characters = _characters(text)
            if characters is None:
                self.refuse(path, _LONE_SURROGATE)
            return characters
        if tag == _TAG + "null":
            return None
        if tag == _TAG + "bool":
            if text not in _BOOL_12:
                self.refuse(path, f"{text!r} is not a boolean: write true or false")
                return None
            return _BOOL_12[text]
        if tag in (_TAG + "int", _TAG + "float"):
            return self._number(node, path)
        if tag.startswith(_TAG):
            kind = tag[len(_TAG) :]
            self.refuse(path, f"a {kind} value is not allowed here; quote it if you mean text")
        else:
            self.refuse(path, _tag_message(tag))
        return None

    def _number(self, node: yaml.Node, path: DataPath) -> Any:
        text = str(node.value)
        if len(text) > _MAX_NUMBER_TEXT:
            self.refuse(
                path, f"absurd number {text[:20]}...: at most {_MAX_NUMBER_TEXT} characters"
            )
            return None
        digits = text.lstrip("+-")
        if node.tag == _TAG + "int" and len(digits) > 1 and digits[0] == "0" and digits.isdigit():
            octal = f", or 0o{digits.lstrip('0')} for octal" if max(digits) < "8" else ""
            self.refuse(
                path,
                f"{text!r} has a leading zero, which YAML 1.1 reads as octal and YAML 1.2 as "
                f"{int(text)}: write {int(text)}{octal}",
            )
            return None
        try:
            value = _core_number(text, integer=node.tag == _TAG + "int")
        except (ValueError, OverflowError):
            self.refuse(path, f"{text!r} is not a number")
            return None
        if text.lstrip("+-").lower() in (".nan", ".inf"):
            self.refuse(path, f"{text!r} is not allowed: numbers must be finite")
            return None
        if value == 0 and re.search(r"[1-9]", text.lower().partition("e")[0]):
            self.refuse(path, f"{text!r} is too small for a number: it reads as 0")
            return None
        # Integers up to the largest seed: the fields bound them (a seed to
        # 2^32 - 1, every other number to ABSURD).
        largest = f"{LARGEST_SEED}" if isinstance(value, int) else f"{ABSURD:g}"
        if not abs(value) <= float(largest):  # 1e400 too, which reads as inf
            self.refuse(path, f"absurd number {text}: magnitudes above {largest} are refused")
            return None
        return value


_SURROGATE = re.compile(r"[\ud800-\udfff]")
_LONE_SURROGATE: Final = (
    "a text holds a lone surrogate escape (\\ud800 to \\udfff), half of a character: "
    "write the character itself, a pair of escapes as JSON writes it (\\ud83d\\ude00), "
    "or \\U and its 8 hex digits (\\U0001F600)"
)


def _characters(text: str) -> str | None:
    """``text`` with each pair of surrogate escapes (``"\\ud83d\\ude00"``, as JSON
    writes a character beyond U+FFFF) joined into its character; None when a
    surrogate stands alone, which is no character at all."""
    if _SURROGATE.search(text) is None:
        return text
    try:
        return text.encode("utf-16-le", "surrogatepass").decode("utf-16-le")
    except UnicodeDecodeError:
        return None


def _core_number(text: str, *, integer: bool) -> float:
    """The value of a YAML 1.2 core-schema integer or float."""
    if integer:
        if text.startswith(("0o", "0x")):
            return int(text[2:], 8 if text[1] == "o" else 16)
        return int(text, 10)
    special = {".inf": math.inf, ".nan": math.nan}.get(text.lstrip("+-").lower())
    if special is not None:
        return -special if text.startswith("-") else special
    return float(text)


def _syntax_finding(error: yaml.YAMLError, text: str) -> tuple[int, int, str]:
    if isinstance(error, yaml.MarkedYAMLError):
        mark = error.problem_mark or error.context_mark
        line, column = _mark(mark)
        parts = [error.context, error.problem]
        message = "; ".join(p for p in parts if p)
        if error.context_mark is not None and error.problem_mark is not None:
            opened = _mark(error.context_mark)
            if opened != (line, column):
                message += f" (the construct started at {opened[0]}:{opened[1]})"
        if not isinstance(error, _Refused):
            message = f"YAML syntax error: {message}"
            line, column, message = _syntax_advice(error, text, (line, column), message)
        return line, column, message
    if isinstance(error, yaml.reader.ReaderError):
        before = text[: error.position]
        line = before.count("\n") + 1
        column = error.position - (before.rfind("\n") + 1) + 1
        return line, column, f"character {error.character!r} is not allowed in YAML text"
    return 1, 1, f"YAML error: {error}"


def _spaces(count: int) -> str:
    return "1 space" if count == 1 else f"{count} spaces"


def _indents_above(lines: list[str], line: int) -> list[int]:
    """The indentations a line may take after the lines above it: those of the
    keys and items that enclose the last of them (an item's content too), from
    the innermost out."""
    indents: list[int] = []
    for text in reversed(lines[: line - 1]):
        content = text.lstrip(" ")
        if not content or content.startswith("#"):
            continue
        depth = len(text) - len(content)
        if indents and depth >= indents[-1]:
            continue
        if content.startswith("- ") and not content[2:].lstrip().startswith("#"):
            indents.append(depth + 2 + len(content[2:]) - len(content[2:].lstrip(" ")))
        indents.append(depth)
        if depth == 0:
            break
    return sorted(set(indents), reverse=True)


_CLOSERS: Final = {
    "while parsing a flow mapping": ("{", "}"),
    "while parsing a flow sequence": ("[", "]"),
}


def _syntax_advice(
    error: yaml.MarkedYAMLError, text: str, at: tuple[int, int], message: str
) -> tuple[int, int, str]:
    """The reader's message with what to write instead, for the mistakes of
    hand-written YAML it words in its own terms (a tab, a line indented to no
    block, a text or a bracket left open); one left open is placed where it was
    opened, which the reader only finds open at the file's end."""
    line, column = at
    problem, context = error.problem or "", error.context or ""
    lines = text.splitlines()
    opened = _mark(error.context_mark)
    ended = problem.endswith("'<stream end>'") or problem == "found unexpected end of stream"
    if "'\\t'" in problem:
        said = "write spaces instead of the tab (YAML indents with spaces)"
    elif problem == "expected <block end>, but found '-'":
        said = (
            f"a list item ('-') where the mapping started at {opened[0]}:{opened[1]} takes a "
            "key: indent the item as the other items of its list"
        )
    elif problem.startswith("expected <block end>, but found '<block"):
        indents = [str(n) for n in _indents_above(lines, line)]
        above = f" ({', '.join(indents[:-1])} or {indents[-1]} spaces)" if indents[1:] else ""
        above = f" ({indents[0]} spaces)" if len(indents) == 1 else above
        said = (
            f"line {line} is indented {_spaces(column - 1)}, as no key or item above it "
            f"is{above}: YAML nests by indentation, so indent it as those it belongs with"
        )
    elif problem == "mapping values are not allowed here":
        said = _continued(lines, line, column) or (
            # `description: at 0.5 m/s: it cannot` - the second ': ' starts a mapping
            "a text holding ': ' must be quoted, e.g. key: \"at 0.5 m/s: it cannot\", "
            "or written as a block (key: >-, then the text on indented lines)"
        )
    elif context == "while scanning a quoted scalar" and ended:
        quote = lines[opened[0] - 1][opened[1] - 1 : opened[1]]
        said = f"the text opened by this quote ({quote}) is never closed: end it with {quote}"
        return opened[0], opened[1], f"YAML syntax error: {said}"
    elif context in _CLOSERS:
        start, end = _CLOSERS[context]
        if ended:
            said = f"this '{start}' is never closed: close it with '{end}'"
            return opened[0], opened[1], f"YAML syntax error: {said}"
        said = (
            f"close the '{start}' opened at {opened[0]}:{opened[1]} with '{end}' before this, "
            "or separate its entries with ','"
        )
    else:
        return line, column, message
    return line, column, f"{message}; {said}"


def _continued(lines: list[str], line: int, column: int) -> str | None:
    """Where a key (its ': ' the first of its line) is indented more than the
    line before it, which holds a key and its value: the reader took the line
    for more of that value, and the key for a mapping inside a text."""
    own = lines[line - 1] if line <= len(lines) else ""
    before = [(n, t) for n, t in enumerate(lines[: line - 1], 1) if t.strip()]
    before = [(n, t) for n, t in before if not t.lstrip().startswith("#")]
    if not before or ": " in own[: column - 1]:
        return None
    number, previous = before[-1]
    depth = len(previous) - len(previous.lstrip(" "))
    _, colon, value = previous.strip().partition(": ")
    if len(own) - len(own.lstrip(" ")) <= depth or not colon or value.startswith(("#", "|", ">")):
        return None
    return (
        f"line {line} is indented more than line {number} ({_spaces(depth)}) and was read as "
        f"more of its value {value!r}: indent it {_spaces(depth)} to make it a key beside it "
        "(or, if the ': ' is part of that text, quote the text)"
    )


def _compose(text: str) -> yaml.Node | None:
    """The node tree of one YAML document; raises ``yaml.YAMLError``."""
    loader = _NodeLoader(text)  # the reader refuses unprintable characters here
    try:
        node: yaml.Node | None = loader.get_single_node()
    finally:
        loader.dispose()
    return node


def read_document(text: str) -> tuple[Document | None, list[Finding]]:
    """Compose ``text``; on a syntax error return its position instead of a document."""
    try:
        node = _compose(text)
    except yaml.YAMLError as error:
        line, column, message = _syntax_finding(error, text)
        return None, [Finding((), message, position=(line, column))]
    if node is None:
        return None, [Finding((), "the file is empty: expected a mission mapping")]
    document = Document(data=None)
    builder = _Builder(document)
    document.data = builder.build(node, ())
    findings = builder.findings
    if document.data is None and not findings:  # `null`, `~`, `---` alone: no mission either
        return None, [Finding((), "the file holds only null: expected a mission mapping")]
    if document.data is not None and not isinstance(document.data, dict):
        under = "; a list of phases goes under phases:" if isinstance(document.data, list) else ""
        said = f"the file holds {_kind(document.data)}: a mission is a mapping of keys"
        findings.append(Finding((), f"{said} (version, name, robot, ..., phases){under}"))
    return document, findings


# --- pydantic errors to messages ---------------------------------------------


def dotted_path(path: DataPath) -> str:
    """A data path as the text that names it: ``phases[1].timeout``."""
    text = ""
    for part in path:
        name = shown(str(part))
        text += f"[{part}]" if isinstance(part, int) else (f".{name}" if text else name)
    return text or "the mission"


_CONSTRAINT_KEYS: Final = ("stay_inside", "stay_outside")
_FOOTPRINT_KEYS: Final = ("radius", "polygon")


def _is_tag(part: str | int, current: Any, previous: str | int | None) -> bool:
    """Whether a location part is a union tag rather than a key of ``current``.

    Tags are the ``type`` of a region, path or estimator, the action key of
    a phase or constraint (which follows the list index), and the key of a
    footprint (``radius`` or ``polygon``).
    """
    if not isinstance(current, dict):
        return False
    if current.get("type") == part:
        return True
    if previous == "footprint":
        return part in _FOOTPRINT_KEYS
    return isinstance(previous, int) and part in (*ACTIONS, "repeat", *_CONSTRAINT_KEYS)


def written_path(loc: tuple[str | int, ...], data: Any) -> DataPath:
    """The data path written in the file for a pydantic error location.

    Parts that are union tags or not in the data (a missing key, a union
    member's name) are skipped.
    """
    path: list[str | int] = []
    current = data
    previous: str | int | None = None
    for part in loc:
        if _is_tag(part, current, previous):
            previous = part
            continue
        previous = part
        written = (isinstance(current, dict) and part in current) or (
            isinstance(current, list) and isinstance(part, int) and 0 <= part < len(current)
        )
        if written:
            path.append(part)
            current = current[part]
    return tuple(path)


def _registry(tp: Any) -> Registry[Any] | None:
    """The registry an annotation is filled by (wmr_mission.fields.Registry), if any."""
    if typing.get_origin(tp) is typing.Annotated:
        found = [m for m in typing.get_args(tp)[1:] if isinstance(m, Registry)]
        return found[0] if found else None
    return None


def _field_type(info: FieldInfo) -> Any:
    """A field's type with the registry that fills it, if any."""
    registry = next((m for m in info.metadata if isinstance(m, Registry)), None)
    return info.annotation if registry is None else Annotated[info.annotation, registry]


def _model_class(tp: Any, value: Any) -> Any:
    """Strip Annotated/unions down to the member the value selects."""
    while True:
        origin = typing.get_origin(tp)
        registry = _registry(tp)
        if registry is not None:
            return registry.settings_for(value)
        if origin is typing.Annotated:
            tp = typing.get_args(tp)[0]
            continue
        if origin in (typing.Union, _UnionType):
            members = [a for a in typing.get_args(tp) if a is not type(None)]
            models = [m for m in (_model_class(a, value) for a in members) if _is_model(m)]
            chosen = [m for m in models if _selects(m, value)]
            if chosen:
                return chosen[0]
            others = [a for a in members if not _is_model(_model_class(a, value))]
            return others[0] if others else None
        return tp


_UnionType = type(int | str)


def _is_model(tp: Any) -> bool:
    return isinstance(tp, type) and issubclass(tp, BaseModel)


def _selects(model: type[BaseModel], value: Any) -> bool:
    if not isinstance(value, dict):
        return False
    type_field = model.model_fields.get("type")
    if type_field is not None:
        return value.get("type", type_field.default) in typing.get_args(type_field.annotation)
    keys = [k for k in (*ACTIONS, "repeat", *_CONSTRAINT_KEYS) if k in model.model_fields]
    return not keys or any(k in value for k in keys)


def _alternatives(
    path: DataPath, data: Any, root: type[BaseModel], owner: type[BaseModel] | None, key: str
) -> tuple[str, str] | None:
    """The two keys, as written, of a mapping at ``path`` that has the keys of
    two members of a union told apart by their key, not by a ``type`` (a
    footprint's ``radius`` and ``polygon``, a constraint's ``stay_inside`` and
    ``stay_outside``): ``key``, refused by ``owner``, and the one that chose
    ``owner``; None where ``key`` is not another member's."""
    kind, value = _type_at(path, data, root)
    if owner is None or not isinstance(value, dict) or "type" in owner.model_fields:
        return None
    rivals = [m for m in _members(kind) if m is not owner and "type" not in m.model_fields]
    rival = next((m for m in rivals if key in m.model_fields), None)
    if rival is None:
        return None
    mine = next((k for k in value if k in owner.model_fields and k not in rival.model_fields), None)
    if mine is None:
        return None
    written = list(value)
    first, second = sorted((mine, key), key=lambda k: written.index(k) if k in written else -1)
    return str(first), str(second)


def _members(tp: Any) -> list[type[BaseModel]]:
    """The models of a union type (of a union in a union, an optional one), [] for another type."""
    origin = typing.get_origin(tp)
    if origin is typing.Annotated:
        return _members(typing.get_args(tp)[0])
    if origin in (typing.Union, _UnionType):
        found: list[type[BaseModel]] = []
        for member in typing.get_args(tp):
            while typing.get_origin(member) is typing.Annotated:
                member = typing.get_args(member)[0]
            found += [member] if _is_model(member) else _members(member)
        return found
    return []


def _type_at(path: DataPath, data: Any, root: type[BaseModel] = Mission) -> tuple[Any, Any]:
    """The type that reads the value at ``path``, its unions not resolved, and
    the value ((None, None) when unknown)."""
    tp: Any = root
    value = data
    for part in path:
        tp = _model_class(tp, value)
        if _is_model(tp):
            info = tp.model_fields.get(part)
            if info is None:
                return None, None
            tp = _field_type(info)
        else:
            origin, args = typing.get_origin(tp), typing.get_args(tp)
            if origin is list or (origin is tuple and len(args) == 2 and args[1] is Ellipsis):
                tp = args[0]
            elif origin is tuple and isinstance(part, int) and part < len(args):
                tp = args[part]
            elif origin is dict:
                tp = args[1]
            else:
                return None, None
        try:
            value = value[part]
        except (KeyError, IndexError, TypeError):
            return None, None
    return tp, value


def _model_at(path: DataPath, data: Any, root: type[BaseModel] = Mission) -> type[BaseModel] | None:
    """The model class that reads the mapping at ``path`` (None when unknown)."""
    tp, value = _type_at(path, data, root)
    if tp is None:
        return None
    tp = _model_class(tp, value)
    return tp if _is_model(tp) else None


_PATTERNS: Final = {
    MISSION_NAME: "lower-case letters, digits, '-' or '_', starting with a letter or digit, "
    "at most 64 characters",
    PHASE_NAME: "letters, digits, '-' or '_', starting with a letter or digit, at most 64 "
    "characters",
    IDENTIFIER: "an identifier: letters, digits and '_', not starting with a digit",
}


def _kind(value: Any) -> str:
    """What a value is, in a message: a list, a text, a number."""
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return f"the text {shown(repr(value), 40)}"
    return f"the value {_shown(value)}"


def _shown(value: Any) -> str:
    """A value as the mission wrote it: YAML's words for a boolean and null."""
    if isinstance(value, bool) or value is None:
        return {True: "true", False: "false", None: "null"}[value]
    return shown(repr(value), 40)


def translate(error: Any, document: Document, root: type[BaseModel] = Mission) -> Finding:
    """A pydantic error of a ``root`` model (a mission, a campaign) as a positioned finding."""
    finding = _written_unit(error, document, root) or _translate_error(error, document, root)
    value = error.get("input")
    hint = yaml11_hint(value) if isinstance(value, str) else ""
    if isinstance(value, str) and not hint and error["type"] in _NUMBER_ERRORS:
        hint = _quoted_hint(value) or _expression_hint(value, document.data)
    elif isinstance(value, str) and not hint and error["type"] == "literal_error":
        # `version: "1"`: the number accepted, in quotes
        expected = str((error.get("ctx") or {}).get("expected", ""))
        if value.strip() in re.findall(r"(?<!')\b\d+\b(?!')", expected):
            hint = _quoted_hint(value)
    return finding._replace(message=finding.message + hint) if hint else finding


def _expression_hint(text: str, data: Any) -> str:
    """A parameter or a constant expression where a field takes a plain number
    (`dt: r`, `dt: 2*r`): such a field reads neither (those marked scalar do),
    and its value is what to write."""
    declared = data.get("parameters") if isinstance(data, dict) else None
    parameters = {
        str(name): float(value)
        for name, value in (declared.items() if isinstance(declared, dict) else ())
        if isinstance(value, int | float) and not isinstance(value, bool)
    }
    try:
        value = expressions.parse(text, parameters, allow_t=False).constant(parameters)
    except (expressions.ExpressionError, ArithmeticError):
        return ""
    if not math.isfinite(value):
        return ""
    what = f"{text.strip()!r} is a parameter" if text.strip() in parameters else "an expression"
    return f" ({what}, which this field does not read: write {value:g})"


def _quoted_hint(text: str) -> str:
    """A number written in quotes (`dt: "0.01"`) is a text where a number is
    expected: said so, with the number to write; `nan` and `inf` are texts too,
    and no number a mission takes."""
    try:
        number = float(text)
    except ValueError:
        return ""
    if text.strip() != text:
        return ""
    if not math.isfinite(number):  # `nan`, `inf`: YAML 1.2 writes them .nan, .inf
        return f" (read as the text {text!r}: numbers must be finite)"
    return f" (a text, in quotes: write {text} without them)"


_WITH_UNIT: Final = re.compile(r"\s*([+-]?(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)\s*(\S.*?)\s*")
# The errors of a field that takes a number (or a formula of constants).
_NUMBER_ERRORS: Final = ("float_type", "int_type", "float_parsing", "int_parsing", "expression")


def _field_units(path: DataPath, data: Any, root: type[BaseModel]) -> tuple[str, list[str]]:
    """The field whose unit the value at ``path`` is in, and the units its
    description names (``[m]``); ("", []) when unknown."""
    for end in range(len(path), 0, -1):
        key = path[end - 1]
        if not isinstance(key, str):
            continue  # an item of a list is in the list's unit
        owner = _model_at(path[: end - 1], data, root)
        info = None if owner is None else owner.model_fields.get(key)
        if info is None:
            return "", []
        if owner is Threshold:
            continue  # a bound's max is in the unit of the metric it bounds
        found = re.findall(r"\[([^\]]+)\]", info.description or "")
        return key, list(dict.fromkeys(u for u in found if unit_of(u) is not None))
    return "", []


def _written_unit(error: Any, document: Document, root: type[BaseModel]) -> Finding | None:
    """A number written with a unit (`1 cm`) where a number is expected: said so,
    with the field's unit and, where the unit converts to it, the number to write."""
    value = error.get("input")
    if error["type"] not in _NUMBER_ERRORS or not isinstance(value, str):
        return None
    # a long text is no number with its unit (and would cost the pattern its square)
    match = _WITH_UNIT.fullmatch(value) if len(value) <= _MAX_NUMBER_TEXT else None
    written = None if match is None else unit_of(match.group(2))
    if match is None or written is None:
        return None
    number, unit = match.groups()
    parameters = document.data.get("parameters") if isinstance(document.data, dict) else None
    if isinstance(parameters, dict) and unit in parameters:
        return None  # `2 h`, h a parameter: a product written without its `*`
    path = written_path(error["loc"], document.data)
    where = dotted_path(path)
    name, units = _field_units(path, document.data, root)
    kind, size = written
    # the size of the field's unit that measures what the written one does
    sizes = [found[1] for found in map(unit_of, units) if found is not None and found[0] == kind]
    if not units and not kind:
        sizes = [1.0]  # `5 %` where a plain number (a probability, a fraction) is expected
    converted = float(number) * size / sizes[0] if sizes else math.nan
    if math.isfinite(converted):
        write = f"write {converted:.6g} for {number} {unit}"
    else:
        write = "write the number alone"
    field = f"{name} is in {' or '.join(units)}; " if units else ""
    return Finding(path, f"{where}: units are not written: {field}{write}")


def _belongs_under(owner: type[BaseModel], key: str) -> str | None:
    """The field of ``owner`` whose model (or one of its alternatives) has a
    field ``key``: where a key written one level too high belongs. A list of
    such models is named as one: `constraints: [{stay_outside: ...}]`."""
    for name, info in owner.model_fields.items():
        kind: Any = info.annotation
        origin, args = typing.get_origin(kind), typing.get_args(kind)
        listed = origin in (list, tuple) and bool(args)
        item = args[0] if listed else kind
        models: list[type[BaseModel]] = [item] if _is_model(item) else _members(item)
        if any(key in m.model_fields for m in models):
            return f"{name}: [{{{key}: ...}}]" if listed else name
    return None


def _translate_error(error: Any, document: Document, root: type[BaseModel]) -> Finding:
    kind: str = error["type"]
    loc: tuple[str | int, ...] = error["loc"]
    data = document.data
    path = written_path(loc, data)
    where = dotted_path(path)
    context = error.get("ctx") or {}
    value = error.get("input")

    if kind == "extra_forbidden":
        key = str(loc[-1])
        owner = _model_at(path[:-1], data, root)
        allowed = list(owner.model_fields) if owner is not None else []
        parent = dotted_path(path[:-1])
        if key in ACTIONS and owner is not None and any(a in owner.model_fields for a in ACTIONS):
            return Finding(
                path,
                f"a phase has exactly one action (track, regulate or hold), but {parent} "
                f"also has {key!r}",
                at_key=True,
            )
        both = _alternatives(path[:-1], data, root, owner, key)
        if both is not None:
            return Finding(
                (*path[:-1], both[1]),
                f"{parent}: {both[0]!r} and {both[1]!r} are alternatives: "
                "give one or the other, not both",
                at_key=True,
            )
        if not allowed:
            return Finding(
                path,
                f"unknown field {shown(repr(key))} in {parent}: it takes no fields",
                at_key=True,
            )
        hint = did_you_mean(key, allowed)
        if not hint and owner is not None:
            under = _belongs_under(owner, key)
            if under is not None and ":" in under:  # `stay_outside:` beside `constraints:`
                hint = f"; it belongs in a list item: {under}"
            elif under is not None:  # `limits:` written beside `robot:`, not in it
                hint = f"; it belongs in {under!r} ({under}.{key})"
        above = _model_at(path[:-2], data, root) if len(path) > 1 else None
        if not hint and above is not None and key in above.model_fields:
            # `timeout:` written in `until:`, not beside it
            hint = f"; it belongs beside {path[-2]!r} ({dotted_path((*path[:-2], key))})"
        hint = hint or f"; expected one of: {', '.join(allowed)}"
        return Finding(path, f"unknown field {shown(repr(key))}{hint}", at_key=True)
    if kind == "missing":
        if isinstance(loc[-1], int):
            return Finding(path, f"{where}: too few items (item {loc[-1]} is missing)")
        return Finding(path, f"missing field {loc[-1]!r} in {where}")
    if kind in ("too_short", "too_long"):
        bound = context.get("min_length" if kind == "too_short" else "max_length")
        least = "at least" if kind == "too_short" else "at most"
        items = "item" if bound == 1 else "items"
        got = context.get("actual_length")
        if got is None and isinstance(value, (dict, list, str)):  # pydantic stops counting
            got = len(value)
        count = "" if got is None else f", got {got}"
        return Finding(path, f"{where}: expected {least} {bound} {items}{count}")
    if kind == "phase_action":
        keys = list(value) if isinstance(value, dict) else []
        in_repeat = "repeat" in path
        if in_repeat and "repeat" in keys:
            return Finding(
                (*path, "repeat"),
                f"{where}: a repeat cannot hold another repeat (repeats do not nest); "
                "write the inner phases out, or repeat the outer group more times",
                at_key=True,
            )
        actions = ACTIONS if in_repeat else (*ACTIONS, "repeat")
        hints = [did_you_mean(str(k), actions) for k in keys]
        hint = next((h for h in hints if h), "")
        return Finding(
            path,
            f"{where}: a phase needs exactly one action key: "
            f"{', '.join(actions[:-1])} or {actions[-1]}{hint}",
        )
    if kind == "constraint_kind":
        keys = [str(k) for k in value] if isinstance(value, dict) else []
        close = [(k, did_you_mean(k, _CONSTRAINT_KEYS)) for k in keys]
        misspelt = next(((k, hint) for k, hint in close if hint), None)
        if misspelt is not None:
            return Finding(
                (*path, misspelt[0]),
                f"unknown constraint {misspelt[0]!r}{misspelt[1]} "
                "(a constraint is {stay_inside: REGION} or {stay_outside: REGION})",
                at_key=True,
            )
        return Finding(
            path, f"{where}: a constraint is {{stay_inside: REGION}} or {{stay_outside: REGION}}"
        )
    if kind in ("union_tag_invalid", "union_tag_not_found"):
        tags = _type_tags(path, data, root)
        if kind == "union_tag_not_found":
            near_type = [
                k for k in (value if isinstance(value, dict) else {}) if did_you_mean(k, ["type"])
            ]
            if near_type:  # `typ: ellipse`
                return Finding(
                    (*path, near_type[0]),
                    f"unknown field {near_type[0]!r}; did you mean 'type'? "
                    f"(one of: {', '.join(tags)})",
                    at_key=True,
                )
            return Finding(path, f"{where}: missing field 'type' (one of: {', '.join(tags)})")
        tag = str(context.get("tag", ""))
        type_path = (*path, "type") if (*path, "type") in document.values else path
        hint = did_you_mean(tag, tags)
        return Finding(
            type_path, f"unknown type {tag!r}{hint} (expected one of: {', '.join(tags)})"
        )
    if kind == "expression":
        column = context.get("column")
        message = f"{where}: {error['msg']}"
        # point at the offending character inside the expression
        position = document.text_position(path, column) if isinstance(column, int) else None
        return Finding(path, message, position=position)
    if kind == "string_pattern_mismatch":
        described = _PATTERNS.get(str(context.get("pattern")), f"match {context.get('pattern')}")
        # a mapping's key (a region's name): point at the key, not its value
        return Finding(
            path, f"{where}: expected {described}, got {_shown(value)}", at_key=loc[-1] == "[key]"
        )
    registry = _section_registry(path[:-1], data, root) if path[-1:] == ("type",) else None
    if kind == "literal_error" and registry is not None:
        # The one type registered (the controller's): refused as a union refuses.
        names = list(registry.names())
        hint = did_you_mean(str(value), names) if isinstance(value, str) else ""
        return Finding(
            path, f"unknown type {_shown(value)}{hint} (expected one of: {', '.join(names)})"
        )
    if kind == "literal_error":
        expected = str(context.get("expected", ""))
        choices = re.findall(r"'([^']*)'", expected)
        hint = did_you_mean(str(value), choices) if isinstance(value, str) else ""
        # A mapping's key (`output_error_bounds: {thta: ...}`): point at the key.
        at_key = loc[-1] == "[key]"
        return Finding(
            path, f"{where}: expected {expected}, got {_shown(value)}{hint}", at_key=at_key
        )
    message = str(error["msg"])
    message = re.sub(r"^Input should be", "should be", message)
    message = re.sub(r"^Value error, ", "", message)
    # pydantic's words for YAML's: a mapping of the section's fields, a list
    message = re.sub(r"a valid dictionary( or instance of \w+)?", "a mapping", message)
    message = re.sub(r"a valid (tuple|list)", "a list", message)
    message = re.sub(r"a valid string", "text", message)
    if kind.endswith(("_type", "_parsing")) or kind in (
        "greater_than",
        "greater_than_equal",
        "less_than",
        "less_than_equal",
        "too_short",
        "too_long",
        "finite_number",
    ):
        got = (
            "a mapping"
            if isinstance(value, dict)
            else "a list"
            if isinstance(value, list)
            else _shown(value)
        )
        message = f"{message}, got {got}"
        bound = isinstance(value, dict) and len(value) == 1 and set(value) <= {"min", "max"}
        if bound and kind == "scalar_type" and isinstance(path[-1], str):
            # `clearance_min: {min: 0.1}`, as other bounds are written: this one is a number
            (bound,) = value.values()
            message += f" ({{{next(iter(value))}: ...}}): write the number alone, "
            message += f"{path[-1]}: {_shown(bound)}"
    return Finding(path, f"{where}: {message}")


def _section_registry(path: DataPath, data: Any, root: type[BaseModel]) -> Registry[Any] | None:
    """The registry whose variants the section at ``path`` is written in, if any."""
    if not path:
        return None
    owner = _model_at(path[:-1], data, root)
    info = None if owner is None else owner.model_fields.get(str(path[-1]))
    return None if info is None else _registry(_field_type(info))


def _type_tags(path: DataPath, data: Any, root: type[BaseModel]) -> list[str]:
    """The ``type`` values accepted by the union at ``path``: a registry's
    (a path, the estimator, the controller), else a region's."""
    registry = _section_registry(path, data, root)
    if registry is not None:
        return list(registry.names())
    return [type_name(m) for m in typing.get_args(typing.get_args(RegionSpec)[0])]


_SUGGESTION = re.compile(r"^unknown field '[^']*'; did you mean '([^']*)'\?$")
_MISSING = re.compile(r"^missing field '([^']*)' in ")


_AUTO: Final = "literal['auto']"


def _threshold_errors(errors: list[Any]) -> list[Any]:
    """An `expect` threshold is {max: N}, 'auto' or null, and pydantic refuses a
    value once by each: a mapping chose {max: N}, whose errors alone are said
    (not that it is no 'auto'); any other value gets one error naming the three
    forms (not that it is no mapping)."""
    kept = []
    for error in errors:
        loc = tuple(error["loc"])
        threshold = [e for e in errors if tuple(e["loc"][: len(loc)]) == (*loc[:-1], "Threshold")]
        if error["type"] == "literal_error" and loc[-1:] == (_AUTO,) and threshold:
            if isinstance(error["input"], dict):
                continue
            error = {**error, "ctx": {"expected": "{max: NUMBER}, 'auto' or null"}}
        elif (
            error["type"] == "model_type"
            and loc[-1:] == ("Threshold",)
            and any(tuple(e["loc"]) == (*loc[:-1], _AUTO) for e in errors)
        ):
            continue
        kept.append(error)
    return kept


def _threshold_written(error: Any, finding: Finding, data: Any) -> Finding:
    """A number where a threshold {max: N} is expected: the threshold to write."""
    value = error.get("input")
    if isinstance(value, bool) or not isinstance(value, int | float):
        return finding
    tp, _ = _type_at(written_path(error["loc"], data), data)
    if tp is not Threshold and Threshold not in _members(tp):
        return finding
    return finding._replace(message=f"{finding.message}: write {{max: {value:g}}}")


def _without_fields_of_unknown_types(findings: list[Finding]) -> list[Finding]:
    """Drop "unknown field" in a section whose type is unknown: its fields are
    another type's."""
    unknown = {f.path[:-1] for f in findings if f.message.startswith("unknown type")}
    return [
        f
        for f in findings
        if not (f.message.startswith("unknown field") and f.path[:-1] in unknown)
    ]


def _without_implied_missing(findings: list[Finding]) -> list[Finding]:
    """Drop "missing field X" where an unknown key next to it is a misspelt X."""
    suggested = set()
    for finding in findings:
        match = _SUGGESTION.match(finding.message)
        if match:
            suggested.add((finding.path[:-1], match.group(1)))
    kept = []
    for finding in findings:
        match = _MISSING.match(finding.message)
        if match and (finding.path, match.group(1)) in suggested:
            continue
        kept.append(finding)
    return kept


def _under(path: DataPath, refused: set[DataPath]) -> bool:
    return any(path[: len(r)] == r for r in refused)


def validation_context(data: dict[str, Any]) -> dict[str, Any]:
    """Declared parameters and region names, for expressions and region references."""
    parameters: dict[str, float] = {}
    raw = data.get("parameters")
    if isinstance(raw, dict):
        for name, value in raw.items():
            if isinstance(value, int | float) and not isinstance(value, bool):
                parameters[name] = float(value)
    regions = data.get("regions")
    names = [name for name in regions if isinstance(name, str)] if isinstance(regions, dict) else []
    return {"parameters": parameters, "regions": names}


# --- entry points ------------------------------------------------------------


def diagnostic(filename: str, document: Document | None, finding: Finding) -> Diagnostic:
    source = document.override_of(finding.path) if document is not None else None
    if source is not None:
        filename, line, column = source, 0, 0
    elif finding.position is not None:
        line, column = finding.position
    elif document is None:
        line, column = 1, 1
    else:
        line, column = document.position(finding.path, at_key=finding.at_key)
    message = finding.message
    where = dotted_path(finding.path)
    if line == 0 and finding.path and not message.startswith(where):
        message = f"{where}: {message}"  # no position to point at: name the field
    return Diagnostic(filename, line, column, message, finding.severity)


def check_mission_text(
    text: str,
    filename: str = "<text>",
    overrides: Sequence[Override] = (),
    read: tuple[Document | None, list[Finding]] | None = None,
) -> tuple[Mission | None, list[Diagnostic]]:
    """Every problem of a mission text (errors and warnings), and the mission if it has none.

    ``read``: what :func:`read_document` made of ``text`` already (`validate`
    reads a file once to tell a mission from a campaign), not read again."""
    try:
        return _check(text, filename, overrides, read)
    except Exception as error:  # last resort: bad input must never show a traceback
        return None, [internal_error(filename, error)]


def internal_error(filename: str, error: Exception, line: int = 1, column: int = 1) -> Diagnostic:
    """The last resort of a check: bad input must never show a traceback."""
    message = f"internal error while checking ({type(error).__name__}: {error}); please report it"
    return Diagnostic(filename, line, column, message)


def _check(
    text: str,
    filename: str,
    overrides: Sequence[Override] = (),
    read: tuple[Document | None, list[Finding]] | None = None,
) -> tuple[Mission | None, list[Diagnostic]]:
    if len(text) > MAX_FILE_BYTES:
        return None, [
            Diagnostic(filename, 1, 1, f"file too large: more than {MAX_FILE_BYTES} bytes")
        ]
    document, findings = read if read is not None else read_document(text)
    if document is None:
        return None, [diagnostic(filename, None, f) for f in findings]
    return _check_document(document, findings, filename, overrides)


def _check_document(
    document: Document, findings: list[Finding], filename: str, overrides: Sequence[Override]
) -> tuple[Mission | None, list[Diagnostic]]:
    """Apply the overrides, then validate the data and run the checks across fields."""
    for override in overrides:
        problem = apply_override(document, override)
        if problem is not None:
            return None, [Diagnostic(override.source, 0, 0, problem)]
    mission: Mission | None = None
    if isinstance(document.data, dict):
        try:
            mission = Mission.model_validate(
                document.data, context=validation_context(document.data)
            )
        except ValidationError as error:
            translated = []
            for item in _threshold_errors(error.errors(include_url=False)):
                path = written_path(item["loc"], document.data)
                if not _under(path, document.refused):
                    finding = translate(item, document)
                    translated.append(_threshold_written(item, finding, document.data))
            findings.extend(_without_fields_of_unknown_types(_without_implied_missing(translated)))
    unique = {diagnostic(filename, document, f) for f in findings}
    if mission is not None and not findings:
        unique |= {
            diagnostic(filename, document, f)._replace(stage="semantics") for f in check(mission)
        }
    diagnostics = sorted(
        unique,
        key=lambda d: (d.line, d.column, d.message),
    )
    if any(d.severity == "error" for d in diagnostics):
        mission = None
    return mission, diagnostics


def check_mission_document(
    document: Document, filename: str, overrides: Sequence[Override] = ()
) -> tuple[Mission | None, list[Diagnostic]]:
    """As :func:`check_mission_text` for a text read once with :func:`read_document`
    (without problems): a campaign checks thousands of overrides of one mission
    without reading its YAML again. The document is left as it was."""
    fresh = Document(
        data=copy.deepcopy(document.data),
        values=dict(document.values),
        keys=dict(document.keys),
        lines=dict(document.lines),
        refused=set(document.refused),
        overrides=dict(document.overrides),
    )
    try:
        return _check_document(fresh, [], filename, overrides)
    except Exception as error:  # last resort, as for a text
        return None, [internal_error(filename, error)]


# How a file that cannot be read at all (a device, a directory, a read error)
# is said: an I/O fault (exit 2), where a file read but refused is invalid (exit 1).
CANNOT_READ: Final = "cannot read the file"


def unreadable(diagnostics: Sequence[Diagnostic]) -> bool:
    """Whether ``diagnostics`` (of :func:`read_source`) say the file could not be read."""
    return any(d.message.startswith(CANNOT_READ) for d in diagnostics)


def read_source(path: str | Path) -> tuple[bytes | None, list[Diagnostic]]:
    """The bytes of a mission file, read once: a run hashes and runs these very bytes.

    Regular files and pipes (``<(...)``) only; a pipe is opened without waiting
    for a writer, so a FIFO nobody writes to reads as empty instead of hanging.
    """
    filename = str(path)
    try:
        info = os.stat(path)
        if not (stat.S_ISREG(info.st_mode) or stat.S_ISFIFO(info.st_mode)):
            kind = "a directory" if stat.S_ISDIR(info.st_mode) else "a device or socket"
            message = f"{CANNOT_READ}: it is {kind}, not a regular file"
            return None, [Diagnostic(filename, 1, 1, message)]
        if info.st_size > MAX_FILE_BYTES:
            return None, [
                Diagnostic(filename, 1, 1, f"file too large: more than {MAX_FILE_BYTES} bytes")
            ]
        descriptor = os.open(path, os.O_RDONLY | os.O_NONBLOCK)
        os.set_blocking(descriptor, True)
        with os.fdopen(descriptor, "rb") as stream:
            raw = stream.read(MAX_FILE_BYTES + 1)
    except OSError as error:
        return None, [Diagnostic(filename, 1, 1, f"{CANNOT_READ}: {error.strerror or error}")]
    if len(raw) > MAX_FILE_BYTES:
        return None, [
            Diagnostic(filename, 1, 1, f"file too large: more than {MAX_FILE_BYTES} bytes")
        ]
    return raw, []


def check_mission_bytes(
    raw: bytes, filename: str, overrides: Sequence[Override] = ()
) -> tuple[Mission | None, list[Diagnostic]]:
    """Every problem of a mission file's bytes, and the mission if it has none."""
    text, diagnostics = decode_source(raw, filename)
    if text is None:
        return None, diagnostics
    return check_mission_text(text, filename, overrides)


def decode_source(raw: bytes, filename: str) -> tuple[str | None, list[Diagnostic]]:
    """The text of a file's bytes, or where they stop being UTF-8."""
    try:
        return raw.decode("utf-8"), []
    except UnicodeDecodeError as error:
        before = raw[: error.start]
        line = before.count(b"\n") + 1
        column = len(before) - (before.rfind(b"\n") + 1) + 1
        return None, [Diagnostic(filename, line, column, "the file is not UTF-8 text")]


def check_mission(
    path: str | Path, overrides: Sequence[Override] = ()
) -> tuple[Mission | None, list[Diagnostic]]:
    """Every problem of a mission file (errors and warnings), and the mission if it has none."""
    raw, diagnostics = read_source(path)
    if raw is None:
        return None, diagnostics
    return check_mission_bytes(raw, str(path), overrides)


def check_mission_data(
    data: Any, source: str = "<dict>", overrides: Sequence[Override] = ()
) -> tuple[Mission | None, list[Diagnostic]]:
    """As :func:`check_mission_text`, for plain data (a dict as ``yaml.safe_load`` gives)."""
    try:
        plain = _plain(data)
    except TypeError as error:
        return None, [Diagnostic(source, 0, 0, str(error))]
    findings = []
    if not isinstance(plain, dict):
        findings.append(
            Finding((), "a mission is a mapping of keys (version, name, robot, ..., phases)")
        )
    try:
        return _check_document(Document(data=plain), findings, source, overrides)
    except Exception as error:  # last resort, as for texts
        return None, [internal_error(source, error, 0, 0)]


def _plain(value: Any) -> Any:
    """A deep copy as YAML would give it: dicts with text keys, lists, scalars."""
    if isinstance(value, dict):
        for key in value:
            if not isinstance(key, str):
                raise TypeError(f"a key must be text, got {key!r}")
        return {key: _plain(item) for key, item in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(item) for item in value]
    if hasattr(value, "tolist") and hasattr(value, "dtype"):  # numpy arrays and scalars
        return _plain(value.tolist())
    return value


def _raise_errors(mission: Mission | None, diagnostics: list[Diagnostic]) -> Mission:
    if mission is None:
        raise MissionError([d for d in diagnostics if d.severity == "error"])
    return mission


def load_mission_text(
    text: str, filename: str = "<text>", overrides: Sequence[Override] = ()
) -> Mission:
    """The mission of ``text``; raises :class:`MissionError` with every error."""
    return _raise_errors(*check_mission_text(text, filename, overrides))


def load_mission(path: str | Path, overrides: Sequence[Override] = ()) -> Mission:
    """The mission of a file; raises :class:`MissionError` with every error."""
    return _raise_errors(*check_mission(path, overrides))


def load_mission_data(
    data: Any, source: str = "<dict>", overrides: Sequence[Override] = ()
) -> Mission:
    """The mission of plain data; raises :class:`MissionError` with every error."""
    return _raise_errors(*check_mission_data(data, source, overrides))


def validate_mission(mission: Mission) -> Mission:
    """``mission`` checked as a file would be; raises :class:`MissionError`.

    A model built with ``model_copy(update=...)`` or ``model_validate`` skips
    the checks across fields (and ``model_copy`` every check): this runs them.
    """
    data = mission.model_dump(mode="json", warnings=False)
    return load_mission_data(data, source=f"mission {mission.name!r}")


# --- overrides: `--set PATH=VALUE` -------------------------------------------


class Override(NamedTuple):
    """One field set from outside the mission text.

    ``path`` is a data path such as ``("robot", "dt")`` or ``("phases", 1,
    "timeout")``; ``source`` is how the user wrote it, and names it in every
    message about that field (``--set robot.dt=-1``).
    """

    path: DataPath
    value: Any
    source: str

    @classmethod
    def at(cls, dotted: str, value: Any, source: str | None = None) -> Override:
        """An override at a dotted path (``robot.initial_state.theta``, ``phases[1].timeout``)."""
        path = parse_path(dotted)
        return cls(path, value, source if source is not None else shown(f"{dotted}={value!r}"))


_PATH_PART = re.compile(r"^([A-Za-z0-9_-]+)((?:\[\d+\])*)$")


@functools.lru_cache(maxsize=256)  # a campaign sets the same paths in each of its runs
def parse_path(dotted: str) -> DataPath:
    """``a.b[2].c`` or ``a.b.2.c`` as a data path; raises ValueError when malformed."""
    path: list[str | int] = []
    for part in dotted.split("."):
        match = _PATH_PART.match(part)
        if match is None:
            raise ValueError(
                f"{_shown(dotted)} is not a field path: expected names joined by '.', "
                "e.g. robot.initial_state.theta or phases[1].timeout"
            )
        name, indices = match.groups()
        path.append(int(name) if name.isdigit() else name)
        path.extend(int(i) for i in re.findall(r"\d+", indices))
    return tuple(path)


def document_kind(text: str) -> str | None:
    """``"mission"`` or ``"campaign"``: what a YAML text holds by its keys (a
    campaign names its ``mission``; a mission has ``phases``); None if neither."""
    document, _ = read_document(text)
    data = document.data if document is not None else None
    if not isinstance(data, dict):
        return None
    if "mission" in data and "phases" not in data:
        return "campaign"
    if "phases" in data and "mission" not in data:
        return "mission"
    return None


class OverrideFormError(MissionError):
    """A ``--set`` that is not PATH=VALUE with PATH a field path: a mistake of
    the command line (a usage error, exit 2), where one whose VALUE makes the
    mission invalid is the mission's (exit 1)."""


def parse_override(text: str) -> Override:
    """``PATH=VALUE`` as given to ``--set``; VALUE is read as a YAML value.

    Raises :class:`MissionError` naming ``--set TEXT`` when it is malformed,
    :class:`OverrideFormError` when it is not PATH=VALUE at all.
    """
    source = f"--set {shown(text)}"
    dotted, equals, value_text = text.partition("=")
    if not equals:
        raise OverrideFormError(
            [Diagnostic(source, 0, 0, "expected PATH=VALUE, e.g. robot.dt=0.02")]
        )
    try:
        path = parse_path(dotted.strip())
    except ValueError as error:
        raise OverrideFormError([Diagnostic(source, 0, 0, str(error))]) from None
    document, findings = read_value(value_text)
    if findings:
        message = "; ".join(f.message for f in findings)
        raise MissionError([Diagnostic(source, 0, 0, f"VALUE is not a YAML value: {message}")])
    return Override(path, document, source)


def overrides_of(overrides: Mapping[str, Any] | None) -> list[Override]:
    """``{"robot.dt": 0.02}`` (the Python API's ``overrides``) as overrides; a
    malformed path raises MissionError, anything but a mapping of texts TypeError."""
    if overrides is None:
        return []
    if not isinstance(overrides, Mapping):
        raise TypeError(
            "overrides is a mapping of dotted paths to values, e.g. {'robot.dt': 0.02}, "
            f"got {type(overrides).__name__}"
        )
    parsed = []
    for dotted, value in overrides.items():
        if not isinstance(dotted, str):
            raise TypeError(
                f"overrides: a path is a text such as 'robot.dt' or 'phases[1].timeout', "
                f"got {dotted!r}"
            )
        source = f"overrides[{dotted!r}]"
        try:  # a numpy value as the YAML it stands for: a campaign writes it as JSON
            parsed.append(Override(parse_path(dotted), _plain(value), source))
        except ValueError as error:
            raise MissionError([Diagnostic(source, 0, 0, str(error))]) from None
    return parsed


def overrides_of_texts(texts: Sequence[str]) -> tuple[list[Override], list[Diagnostic], int]:
    """Each ``--set PATH=VALUE`` text as an override, what is wrong with the
    malformed ones, and the exit code they give: 2 when one is not PATH=VALUE
    (a usage error), else 1 (0: none is malformed)."""
    parsed, problems, code = [], [], 0
    for text in texts:
        try:
            parsed.append(parse_override(text))
        except MissionError as error:
            problems += error.diagnostics
            code = max(code, 2 if isinstance(error, OverrideFormError) else 1)
    return parsed, problems, code


def read_value(text: str) -> tuple[Any, list[Finding]]:
    """One YAML value (``0.5``, ``[1, 1, 2]``, ``{x: 1}``, ``text``), read as in a file."""
    if not text.strip():
        return None, []  # `--set description=` sets null, as `description:` would
    try:
        node = _compose(text)
    except yaml.YAMLError as error:
        _, _, message = _syntax_finding(error, text)
        return None, [Finding((), message)]
    if node is None:
        return None, []
    builder = _Builder(Document(data=None))
    value = builder.build(node, ())
    return value, builder.findings


def _in_a_repeat(items: list[Any], name: str | int, resolved: list[str | int]) -> str:
    """Where the phase ``name``, not one of ``items``, is in a repeat among
    them: the path that names it ('' if none)."""
    for item in items:
        repeat = item.get("repeat") if isinstance(item, dict) else None
        inner = repeat.get("phases") if isinstance(repeat, dict) else None
        if isinstance(inner, list) and any(
            isinstance(p, dict) and p.get("name") == name for p in inner
        ):
            where = _where([*resolved, str(item.get("name")), "repeat", "phases", name])
            return f"; {name!r} is a phase of repeat {item.get('name')!r}: {where}"
    return ""


def apply_override(document: Document, override: Override) -> str | None:
    """Set the override's value in the document's data; a message when the path cannot hold it."""
    current = document.data
    path = override.path
    resolved: list[str | int] = []
    for depth, part in enumerate(path):
        last = depth == len(path) - 1
        if isinstance(current, list):
            index = _list_index(current, part)
            if index is None:
                names = [i["name"] for i in current if isinstance(i, dict) and "name" in i]
                hint = did_you_mean(part, map(str, names)) if isinstance(part, str) else ""
                hint = hint or _in_a_repeat(current, part, resolved)
                return (
                    f"{_where(resolved)} has {len(current)} items (0 to {len(current) - 1}), "
                    f"no item {part!r}{hint}"
                )
            resolved.append(index)
            if last:
                current[index] = override.value
            else:
                current = current[index]
            continue
        if not isinstance(current, dict):
            return (
                f"{_where(resolved)} is a {type(current).__name__}, not a mapping: "
                f"it has no field {part!r}"
            )
        key = str(part)
        resolved.append(key)
        if last:
            current[key] = override.value
        else:
            if current.get(key) is None:
                current[key] = {}  # a section the file leaves to its defaults
            current = current[key]
    written = tuple(resolved)
    for positions in (document.values, document.keys, document.lines):
        for known in [p for p in positions if p[: len(written)] == written]:
            del positions[known]
    document.overrides[written] = override.source
    return None


def resolved_path(data: Any, path: DataPath) -> DataPath:
    """``path`` as :func:`apply_override` lands it in ``data``: a list item by its index
    (``phases.go`` is ``phases[0]`` when the first phase is named go), a mapping's
    key as text; past the data, the sections it would create, by name."""
    resolved: list[str | int] = []
    current = data
    for part in path:
        if isinstance(current, list):
            index = _list_index(current, part)
            resolved.append(part if index is None else index)
            current = None if index is None else current[index]
        else:
            resolved.append(str(part))
            current = current.get(str(part)) if isinstance(current, dict) else None
    return tuple(resolved)


def _where(resolved: list[str | int]) -> str:
    return dotted_path(tuple(resolved)) if resolved else "the mission"


def _list_index(items: list[Any], part: str | int) -> int | None:
    """An item by index, or (for phases) by name."""
    if isinstance(part, int):
        return part if 0 <= part < len(items) else None
    for index, item in enumerate(items):
        if isinstance(item, dict) and item.get("name") == part:
            return index
    return None
