"""Files written so that none is ever half-written under its final name: each
is written to a temporary file beside it, synced, and renamed over it."""

from __future__ import annotations

import json
import math
import os
import secrets
from collections.abc import Iterator, Mapping
from contextlib import contextmanager
from enum import Enum
from pathlib import Path
from typing import Any

import numpy as np


@contextmanager
def atomic_path(final: Path) -> Iterator[Path]:
    """Yield a temporary path beside ``final``; on success sync it and rename it to ``final``.

    The temporary name keeps ``final``'s suffix so writers that pick a format
    from the file name (images) still do. On failure the temporary file is removed.
    """
    try:
        tmp = _new_temporary(final)
    except OSError as error:
        raise OSError(error.errno, error.strerror, str(final)) from error
    try:
        yield tmp
        with tmp.open("rb+") as written:
            written.flush()
            os.fsync(written.fileno())
        os.replace(tmp, final)
    except BaseException as error:
        tmp.unlink(missing_ok=True)
        if isinstance(error, OSError) and error.filename != str(final):
            # Name the file the user knows, not the temporary one.
            raise OSError(error.errno, error.strerror, str(final)) from error
        raise
    _sync_directory(final.parent)


def _new_temporary(final: Path) -> Path:
    # Not tempfile.mkstemp: its files are private (0600); run files get the usual umask.
    for _ in range(100):
        tmp = final.with_name(f".{final.stem}.{secrets.token_hex(4)}.tmp{final.suffix}")
        try:
            os.close(os.open(tmp, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o666))
        except FileExistsError:
            continue
        return tmp
    raise FileExistsError(f"{final.parent}: cannot create a temporary file")


def _sync_directory(directory: Path) -> None:
    # Makes the rename itself durable; not every platform can open a directory.
    try:
        fd = os.open(directory, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def write_bytes_atomic(path: Path, data: bytes) -> Path:
    with atomic_path(path) as tmp:
        tmp.write_bytes(data)
    return path


# --- JSON -----------------------------------------------------------------


def jsonable(value: Any) -> Any:
    """Plain JSON data: tuples as lists, numpy scalars as numbers, NaN and infinities as null."""
    if isinstance(value, Mapping):
        return {str(k): jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    if isinstance(value, np.ndarray):
        return [jsonable(v) for v in value.tolist()]
    if isinstance(value, Enum):
        return jsonable(value.value)
    if isinstance(value, bool | str) or value is None:
        return value
    if isinstance(value, np.bool_):
        return bool(value)
    if isinstance(value, int | np.integer):
        return int(value)
    if isinstance(value, float | np.floating):
        number = float(value)
        return number if math.isfinite(number) else None
    if isinstance(value, os.PathLike):
        return os.fspath(value)
    raise TypeError(f"cannot write {type(value).__name__} to JSON")


def json_text(value: Any) -> str:
    return json.dumps(jsonable(value), indent=2, allow_nan=False, ensure_ascii=False) + "\n"


def write_json(path: Path, value: Any) -> Path:
    """``json_text(value)`` into ``path``, streamed: the summary of thousands of
    phases is never held as one text."""
    # A file name that is not UTF-8 holds surrogates: written as JSON escapes
    # (\udcff), which read back to the same name.
    with (
        atomic_path(path) as tmp,
        tmp.open("w", encoding="utf-8", errors="backslashreplace", newline="") as out,
    ):
        json.dump(jsonable(value), out, indent=2, allow_nan=False, ensure_ascii=False)
        out.write("\n")
    return path
