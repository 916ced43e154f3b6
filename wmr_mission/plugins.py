"""A mission's ``type: python`` entries: their syntax, their import, and what
a plug-in is given when it is made.

``controller: {type: python, entry: "module:callable", params: {...}}`` (and
the same for ``estimator``) names code to run. Mission text is data: the
entry is checked for its syntax alone when a mission is validated; only a
run (and ``validate --check-entries``) imports it, and only through
:func:`load_entry`, which hands the module's name to
``importlib.import_module`` and reads the callable's name with ``getattr``.
Nothing else of the entry reaches the import machinery or the file system
(docs/reliability.md, "The trust boundary").
"""

from __future__ import annotations

import importlib
import os
import re
import traceback
from collections.abc import Callable
from pathlib import Path
from typing import Annotated, Any

from pydantic import AfterValidator, Field

# A dotted module name, a colon, a dotted attribute name: ASCII identifiers.
_NAME = r"[A-Za-z_][A-Za-z0-9_]*"
ENTRY_PATTERN = rf"^{_NAME}(\.{_NAME})*:{_NAME}(\.{_NAME})*$"
_ENTRY = re.compile(ENTRY_PATTERN)


def _entry_syntax(value: str) -> str:
    if not _ENTRY.fullmatch(value):
        raise ValueError(
            f"{value!r} is not an entry: expected 'module:callable', a dotted module "
            "name, a colon and a dotted attribute name (my_package.control:make)"
        )
    return value


Entry = Annotated[
    str,
    AfterValidator(_entry_syntax),
    Field(
        description=(
            "The plug-in: 'module:callable', imported by a run (never by validate, "
            "unless --check-entries); callable(params, setup) returns an object with a "
            "step method (docs/controllers.md)."
        ),
        json_schema_extra={"pattern": ENTRY_PATTERN},
    ),
]

Params = Annotated[
    dict[str, Any],
    Field(description="Handed to the entry's callable as its first argument, as written."),
]


class EntryError(ValueError):
    """An entry that cannot be loaded: what is wrong, for a FILE:LINE:COL message."""


_PACKAGE = str(Path(__file__).resolve().parent) + os.sep


def _raised_at(error: BaseException) -> str:
    """`` (FILE:LINE)`` of the innermost frame outside this package an exception
    was raised in (the plug-in's code), or ''."""
    frames = [
        frame
        for frame in traceback.extract_tb(error.__traceback__)
        if not str(Path(frame.filename).resolve()).startswith(_PACKAGE)
        and "importlib" not in frame.filename
    ]
    return f" ({frames[-1].filename}:{frames[-1].lineno})" if frames else ""


def load_entry(entry: str) -> Callable[..., Any]:
    """The callable an entry names, its module imported; raises :class:`EntryError`."""
    _entry_syntax(entry)
    module_name, _, attributes = entry.partition(":")
    try:
        found: Any = importlib.import_module(module_name)
    except ModuleNotFoundError as error:
        raise EntryError(
            f"cannot import {entry!r}: {error} (is it installed, or on PYTHONPATH?)"
        ) from None
    except (Exception, SystemExit) as error:  # the module's own code failed
        raise EntryError(
            f"cannot import {entry!r}: importing {module_name!r} raised "
            f"{type(error).__name__}: {error}{_raised_at(error)}"
        ) from None
    for part in attributes.split("."):
        if not hasattr(found, part):
            raise EntryError(
                f"cannot load {entry!r}: {getattr(found, '__name__', module_name)!r} has "
                f"no attribute {part!r}"
            )
        found = getattr(found, part)
    if not callable(found):
        raise EntryError(
            f"cannot load {entry!r}: it is not callable ({type(found).__name__} "
            f"{found!r:.40}); callable(params, setup) returns the plug-in"
        )
    return found  # type: ignore[no-any-return]


# What a plug-in's step returns, by the module that reads it (a value that
# cannot be read there is said so, not as the reader's own error).
_RETURNS = {
    "controllers/plugin.py": "a controller plug-in's step returns two numbers (v, omega)",
    "estimators/plugin.py": "an estimator plug-in's step returns three numbers (x, y, theta)",
}


def failure_message(error: BaseException) -> str:
    """A plug-in's exception as a run's message: its type, its own message
    and, for plain Python, where it was raised; an error reading what its step
    returned (``None``, a number alone, a column) with what the step returns."""
    frames = traceback.extract_tb(error.__traceback__)
    # raised reading the value, not calling the step (a wrong signature, no step)
    if frames and ".step(" not in (frames[-1].line or ""):
        innermost = str(Path(frames[-1].filename).resolve())
        for module, returns in _RETURNS.items():
            if innermost == _PACKAGE + module.replace("/", os.sep) and returns not in str(error):
                read = f"{type(error).__name__}: {error}"
                return f"{returns}; what it returned cannot be read: {read}"
    return f"{type(error).__name__}: {error}{_raised_at(error)}"
