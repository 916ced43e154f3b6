"""What besides the mission and the seed decides a run's bytes, and a short
fingerprint of it (manifest.json's ``environment``; docs/reliability.md).

The simulation takes its values from IEEE arithmetic and the C library's
scalar math functions (wmr_mission.kernels.scalar_math), never from numpy's SIMD
loops or from BLAS: numpy's SIMD level, numba's target CPU and OpenBLAS's
kernels change no byte (tests/test_same_bytes.py). They are recorded all the
same, to tell machines apart. What does change bytes:

* the versions of Python, wmr-mission, numpy and numba;
* the C library's math functions: its version, and the variant it picks for
  the CPU. glibc has two for sin, cos, exp, log, pow, atan2 ...: one with
  fused multiply-adds for CPUs with FMA and AVX2 (x86-64-v3 and up), one
  without, and they differ in the last bit on about one argument in a
  thousand. The variant is not inferred from the CPU here but measured:
  ``libm`` digests the values of a few arguments on which the two differ.

The fingerprint digests those alone: two environments with the same
fingerprint give the same bytes.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import platform
import re
import struct
import sys
from collections.abc import Mapping
from typing import Any, Final

from wmr_mission.version import __version__, installed_version

__all__ = [
    "FINGERPRINT_FORM",
    "differences",
    "environment",
    "fingerprint",
    "libm_digest",
    "machine_record",
    "own_fingerprint",
]

# Arguments on which glibc 2.36's FMA and SSE2 variants of each function
# differ in the last bit (found by evaluating both on two million random ones).
_PROBES: tuple[tuple[str, tuple[float, ...]], ...] = (
    ("sin", (-6.786959824497463, 6.5365065911344225)),
    ("cos", (-1.395645124137502, -8.552839200583865)),
    ("tan", (-3.087008284133292, 4.675385788626558)),
    ("atan", (-0.09170093743439756, 0.8213554589832088)),
    ("exp", (3.491415052329831, -9.771660350267869)),
    ("log", (1.1016656974821508, 1.2488428841053731)),
    ("pow", (10.141825552587923, 5.833124111806811, 25.56439406808359, 0.47846789749192986)),
    ("atan2", (0.5168409343290676, -0.26126336837766284, -1.8308672637517898, 0.33005178701582505)),
)

# The versions that decide the numbers of a run (manifest.json's "versions"
# lists more: scipy, pydantic and matplotlib compute none of them).
_DECIDING = ("python", "wmr-mission", "numpy", "numba")


@functools.cache
def libm_digest() -> str:
    """8 hex digits of the C library's values at the probe arguments."""
    digest = hashlib.sha256()
    for name, arguments in _PROBES:
        function = getattr(math, name)
        if name in ("pow", "atan2"):
            values = [function(*arguments[i : i + 2]) for i in range(0, len(arguments), 2)]
        else:
            values = [function(x) for x in arguments]
        digest.update(struct.pack(f"<{len(values)}d", *values))
    return digest.hexdigest()[:8]


def _libc() -> str:
    name, version = platform.libc_ver()
    return f"{name} {version}".strip() or platform.system()


def numpy_simd() -> list[str]:
    """The SIMD levels numpy dispatches to on this machine (beyond its baseline),
    after NPY_DISABLE_CPU_FEATURES."""
    import importlib

    try:
        umath = importlib.import_module("numpy._core._multiarray_umath")
    except ImportError:  # numpy 1.x
        umath = importlib.import_module("numpy.core._multiarray_umath")
    features = umath.__cpu_features__
    return [str(name) for name in umath.__cpu_dispatch__ if features.get(name)]


def numba_cpu(compiled: bool | None = None) -> str | None:
    """The CPU numba compiles the loop for, when this process runs it compiled
    (``compiled``: whether a run's loop ran so, if known)."""
    jit = sys.modules.get("wmr_mission.kernels.jit")
    if jit is None or not jit.loaded() or compiled is False:
        return None
    from llvmlite import binding
    from numba.core import config

    return str(getattr(config, "CPU_NAME", None) or binding.get_host_cpu_name())


# What :func:`fingerprint` gives: 8 lowercase hex digits.
FINGERPRINT_FORM: Final = re.compile(r"[0-9a-f]{8}")


def fingerprint(versions: Mapping[str, str | None], libc: str, libm: str) -> str:
    """8 hex digits of what decides the bytes: the deciding versions (Python's
    to its minor version), the C library and its math functions' digest."""
    deciding = {name: versions.get(name) for name in _DECIDING}
    python = deciding["python"]
    if python is not None:
        deciding["python"] = ".".join(python.split(".")[:2])
    text = json.dumps({"versions": deciding, "libc": libc, "libm": libm}, sort_keys=True)
    return hashlib.sha256(text.encode()).hexdigest()[:8]


@functools.cache
def own_fingerprint() -> str:
    """This process's fingerprint."""

    return fingerprint(package_versions(), _libc(), libm_digest())


def environment(compiled: bool | None = None) -> dict[str, Any]:
    """manifest.json's ``environment``: the fingerprint and the C library's part
    of it, with numpy's SIMD levels and numba's target CPU beside them (the
    versions are manifest.json's ``versions``); ``compiled``: whether the
    run it describes ran its loop compiled, if known (:func:`numba_cpu`)."""
    return {
        "fingerprint": own_fingerprint(),
        "libc": _libc(),
        "libm": libm_digest(),
        "numpy_simd": numpy_simd(),
        "numba_cpu": numba_cpu(compiled),
    }


def machine_record() -> dict[str, Any]:
    """This process's ``versions`` and ``environment``: what a Dask worker
    reports before a campaign runs on it."""

    return {"versions": package_versions(), "environment": environment()}


def differences(mine: Mapping[str, Any], theirs: Mapping[str, Any]) -> list[str]:
    """What differs, of what decides the bytes, between two records of
    :func:`machine_record`, each as ``name: mine != theirs``; empty when their
    fingerprints agree."""
    if mine["environment"]["fingerprint"] == theirs["environment"]["fingerprint"]:
        return []
    found = [
        f"{name}: {mine['versions'].get(name)} != {theirs['versions'].get(name)}"
        for name in _DECIDING
        if mine["versions"].get(name) != theirs["versions"].get(name)
    ]
    found += [
        f"{name}: {mine['environment'][name]} != {theirs['environment'][name]}"
        for name in ("libc", "libm")
        if mine["environment"][name] != theirs["environment"][name]
    ]
    return found


# Packages whose versions decide the numbers of a run.
_VERSIONED_PACKAGES = ("numpy", "scipy", "pydantic", "numba", "matplotlib")


def package_versions() -> dict[str, str | None]:
    """Versions of Python and of the packages that decide a run's numbers (null: not installed)."""
    return dict(_package_versions())


@functools.cache
def _package_versions() -> dict[str, str | None]:
    # Read once per process: a campaign's worst runs, forked from the process
    # that wrote its manifest, read none.
    versions: dict[str, str | None] = {
        "python": platform.python_version(),
        "wmr-mission": __version__,
    }
    for package in _VERSIONED_PACKAGES:
        versions[package] = installed_version(package)
    return versions
