"""The package's version (pyproject.toml says the same), and the installed
versions of the packages a run's manifest records."""

from __future__ import annotations

import functools
import os
import re
import sys

__version__ = "0.1.0"


def installed_version(package: str) -> str | None:
    """The installed version of ``package`` (None: not installed), as
    ``importlib.metadata.version`` gives it: the ``Version`` in the headers
    of the metadata of the first distribution of that name on ``sys.path``,
    found as importlib.metadata finds it, each directory's ``.dist-info``
    and ``.egg-info`` entries in the order the directory lists them; for an
    ``.egg-info`` or a zip on the path, read by ``importlib.metadata``.

    Read so, not by ``importlib.metadata``, whose import (the email parser,
    zipfile, csv) costs 0.014-0.017 s of CPU that a `run` of a cached loop
    spends nowhere else (docs/performance.md, Start-up); and from the headers
    alone, not by parsing the whole file, long description and all."""
    wanted = _normalized(package)
    for entry in sys.path:
        found = _metadata_entries(entry)
        if found is None:  # a zip on the path: importlib.metadata reads it
            return _from_importlib(package)
        name = found.get(wanted)
        if name is None:
            continue
        if not name.lower().endswith(".dist-info"):
            return _from_importlib(package)
        try:
            with open(os.path.join(entry or ".", name, "METADATA"), encoding="utf-8") as file:
                for line in file:
                    if line.startswith("Version:"):
                        return line.removeprefix("Version:").strip()
                    if not line.strip():  # the headers' end
                        break
        except (OSError, UnicodeDecodeError):
            pass
        return _from_importlib(package)  # no version in its headers: as importlib says
    return _from_importlib(package)  # none on the path: another finder may know it


def _normalized(name: str) -> str:
    """A distribution's name as importlib.metadata compares names: runs of
    ``-_.`` as one ``_``, in lower case."""
    return re.sub(r"[-_.]+", "_", name).lower()


@functools.cache
def _metadata_entries(entry: str) -> dict[str, str] | None:
    """The metadata directories (``.dist-info``, ``.egg-info``) in ``entry``
    of ``sys.path`` by their distribution's normalised name, the first of a
    name as the directory lists them; {} where ``entry`` is no directory, None
    where it is a file (a zip, which importlib.metadata reads)."""
    try:
        names = os.listdir(entry or ".")
    except NotADirectoryError:
        return None
    except OSError:  # missing or unreadable: importlib.metadata skips it too
        return {}
    found: dict[str, str] = {}
    for name in names:
        low = name.lower()
        if low.endswith((".dist-info", ".egg-info")):
            found.setdefault(_normalized(low.rpartition(".")[0].partition("-")[0]), name)
    return found


def _from_importlib(package: str) -> str | None:
    from importlib import metadata

    try:
        distribution = metadata.distribution(package)
    except metadata.PackageNotFoundError:
        return None
    text = distribution.read_text("METADATA") or distribution.read_text("PKG-INFO") or ""
    for line in text.partition("\n\n")[0].splitlines():
        if line.startswith("Version:"):
            return line.removeprefix("Version:").strip()
    return distribution.version
