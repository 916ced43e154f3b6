"""Text from outside (a mission's keys and values, file names, ``--set`` values,
a campaign's values) as a terminal shows it: seen, never obeyed, and short.

A mission is untrusted data: ``validate`` echoing its key ``k\\x1b]0;TITLE\\x07``
raw would retitle the terminal of whoever checks it (and a CI log viewer renders
the same codes). :func:`shown` is the one escape, used by every message that
echoes such text and by the command line's own output streams.
"""

from __future__ import annotations

import re
from typing import Final

__all__ = ["ECHO_LIMIT", "shown"]

# Characters a terminal acts on rather than shows: the C0 and C1 controls and
# DEL, the line and paragraph separators, the bidirectional marks and overrides
# (which reorder what is shown).
_ACTED_ON: Final = re.compile(
    "[\x00-\x1f\x7f-\x9f\u2028\u2029\u200e\u200f\u202a-\u202e\u2066-\u2069]"
)
# Characters of a value a message echoes: the rest is cut, its length said.
ECHO_LIMIT: Final = 80


def _escape(match: re.Match[str]) -> str:
    code = ord(match.group())
    return f"\\x{code:02x}" if code < 0x100 else f"\\u{code:04x}"


def shown(text: str, limit: int | None = ECHO_LIMIT, *, keep: str = "") -> str:
    """``text`` with every character a terminal acts on written as its escape
    (``\\x1b``, ``\\u202e``), except those in ``keep``; beyond ``limit``
    characters (None: no limit) cut, ending ``... (130,000 characters)``."""
    cut = ""
    if limit is not None and len(text) > limit:
        text, cut = text[:limit], f"... ({len(text):,} characters)"
    escaped = _ACTED_ON.sub(
        (lambda match: match.group() if match.group() in keep else _escape(match))
        if keep
        else _escape,
        text,
    )
    return escaped + cut
