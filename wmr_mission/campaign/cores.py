"""How many cores this process may use: the CPUs it may run on (its affinity),
and at most its control group's CPU quota, rounded up.

A container started with ``--cpus 2`` (Docker, Kubernetes' CPU limit) on a
host of 32 cores runs on all 32 for ``os.cpu_count()`` and
``os.sched_getaffinity``, but gets two cores' worth of time: 32 worker
processes would then take 16 times the memory of two and wait for the CPU in
turn. The quota is the kernel's, read from its files (cgroups v1 and v2):
the process's own group and every group above it, the least.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

__all__ = ["cpu_quota", "usable_cores"]

ROOT = Path("/")


def usable_cores(root: Path | None = None) -> int:
    """The CPUs this process may run on, at most its CPU quota rounded up (1.5
    CPUs: 2 cores, each busy three quarters of the time); at least 1."""
    on = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count() or 1
    quota = cpu_quota(root)
    return max(1, min(on, math.ceil(quota))) if quota is not None else max(1, on)


def cpu_quota(root: Path | None = None) -> float | None:
    """The least CPU quota, in CPUs, of this process's control group and the
    groups above it, under ``root`` (:data:`ROOT` unless given: another for
    tests); None where there is none, or where the files are not Linux's or
    cannot be read."""
    root = ROOT if root is None else root
    try:
        groups = (root / "proc/self/cgroup").read_text(encoding="ascii").splitlines()
        mounts = (root / "proc/self/mountinfo").read_text(encoding="ascii").splitlines()
    except (OSError, UnicodeDecodeError):
        return None
    quotas = []
    for mount_root, mount_point, version in _cpu_mounts(mounts):
        path = _group_of(groups, version)
        if path is None:
            continue
        # The group's path is the hierarchy's; the mount shows the hierarchy
        # from its own root down (a container's mount: its group alone).
        inside = Path(path).relative_to(mount_root) if _under(path, mount_root) else Path()
        directory = root / mount_point.lstrip("/") / inside
        mounted = root / mount_point.lstrip("/")
        while True:
            found = _quota_in(directory, version)
            if found is not None:
                quotas.append(found)
            if directory == mounted:
                break
            directory = directory.parent
    return min(quotas) if quotas else None


def _cpu_mounts(mounts: list[str]) -> list[tuple[str, str, int]]:
    """(the hierarchy's path mounted, the mount point, 1 or 2) of each
    mount of the cpu controller in /proc/self/mountinfo."""
    found = []
    for line in mounts:
        fields = line.split()
        if "-" not in fields:
            continue
        separator = fields.index("-")
        if len(fields) < separator + 4 or separator < 5:
            continue
        kind, options = fields[separator + 1], fields[separator + 3].split(",")
        mount_root, mount_point = fields[3], _unescaped(fields[4])
        if kind == "cgroup2":
            found.append((mount_root, mount_point, 2))
        elif kind == "cgroup" and "cpu" in options:
            found.append((mount_root, mount_point, 1))
    return found


def _unescaped(field: str) -> str:
    """A path of mountinfo, whose spaces, tabs, newlines and backslashes are
    written in octal (``\\040``)."""
    for code, character in (("\\040", " "), ("\\011", "\t"), ("\\012", "\n"), ("\\134", "\\")):
        field = field.replace(code, character)
    return field


def _group_of(groups: list[str], version: int) -> str | None:
    """This process's group in the hierarchy of ``version`` (/proc/self/cgroup:
    ``0::PATH`` for v2, ``N:cpu,cpuacct:PATH`` for v1's cpu controller)."""
    for line in groups:
        parts = line.split(":", 2)
        if len(parts) != 3:
            continue
        hierarchy, controllers, path = parts
        if version == 2 and hierarchy == "0" and controllers == "":
            return path
        if version == 1 and "cpu" in controllers.split(","):
            return path
    return None


def _under(path: str, mount_root: str) -> bool:
    return mount_root == "/" or path == mount_root or path.startswith(mount_root.rstrip("/") + "/")


def _quota_in(directory: Path, version: int) -> float | None:
    """The group's own CPU quota in ``directory``, in CPUs; None without one."""
    try:
        if version == 2:  # cpu.max: "QUOTA PERIOD" in microseconds, or "max PERIOD"
            quota, period = (directory / "cpu.max").read_text(encoding="ascii").split()
            if quota == "max":
                return None
            return _ratio(int(quota), int(period))
        quota_us = int((directory / "cpu.cfs_quota_us").read_text(encoding="ascii"))
        period_us = int((directory / "cpu.cfs_period_us").read_text(encoding="ascii"))
    except (OSError, UnicodeDecodeError, ValueError):  # none here, or not the kernel's
        return None
    return _ratio(quota_us, period_us)  # -1: no quota


def _ratio(quota: int, period: int) -> float | None:
    return quota / period if quota > 0 and period > 0 else None
