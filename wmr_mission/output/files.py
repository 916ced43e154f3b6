"""Files written so that none is ever half-written under its final name: each
is written to a temporary file beside it, synced, and renamed over it; and a
CSV file of rows appended as they come (:class:`RowsFile`), never cut inside
a row."""

from __future__ import annotations

import csv
import io
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


class RowsFile:
    """A CSV file whose rows are appended as they are known (a campaign's
    ``runs.csv``, a search's ``evaluations.csv``: nothing lost to a stop). A
    piece that cannot be written whole (a full disk) is cut back to its last
    complete row, so that the file never ends inside a row; :attr:`kept` says
    how many of the piece's rows it holds. It stays open to the end: a file
    removed meanwhile (with its directory) is written again from it
    (:meth:`finish`)."""

    def __init__(self, path: Path, header: list[str]) -> None:
        self.path = path
        self.size = 0
        self.kept = 0
        self._fd = os.open(path, os.O_RDWR | os.O_CREAT | os.O_TRUNC, 0o666)
        try:
            self.append([header])
        except BaseException:
            os.close(self._fd)
            raise

    def append(self, lines: list[list[str]]) -> None:
        """Write ``lines`` as rows; raises OSError (naming the file) when not
        all of them could be, the complete ones kept."""
        ends: list[int] = []  # where each row ends, in bytes from the piece's start
        pieces: list[bytes] = []
        for line in lines:
            text = io.StringIO()
            csv.writer(text, lineterminator="\n").writerow(line)
            # A file name that is not UTF-8 (in a reason) is written escaped.
            pieces.append(text.getvalue().encode("utf-8", "backslashreplace"))
            ends.append((ends[-1] if ends else 0) + len(pieces[-1]))
        data = memoryview(b"".join(pieces))
        written = 0
        try:
            while written < len(data):
                written += os.write(self._fd, data[written:])
        except OSError as error:
            self.kept = sum(end <= written for end in ends)
            self.size += ends[self.kept - 1] if self.kept else 0
            os.ftruncate(self._fd, self.size)  # back to the last complete row
            os.lseek(self._fd, self.size, os.SEEK_SET)
            raise OSError(error.errno, error.strerror, str(self.path)) from error
        self.kept = len(lines)
        self.size += written

    def finish(self) -> bool:
        """Sync the file (OSError naming it when that fails); when it was removed
        meanwhile, write it again (and its directory); return whether it was."""
        try:
            os.fsync(self._fd)
        except OSError as error:
            raise OSError(error.errno, error.strerror, str(self.path)) from error
        if os.fstat(self._fd).st_nlink > 0:
            return False
        self.path.parent.mkdir(parents=True, exist_ok=True)
        with atomic_path(self.path) as tmp, tmp.open("wb") as out:
            offset = 0
            while offset < self.size:
                piece = os.pread(self._fd, 1 << 20, offset)
                out.write(piece)
                offset += len(piece)
        return True

    def close(self) -> None:
        os.close(self._fd)


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
