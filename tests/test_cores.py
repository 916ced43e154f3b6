"""The cores a sweep, a falsification and `wmr-mission compile` use by
default: the CPUs the process may run on, at most its control group's CPU
quota (a container's ``--cpus``), read from the kernel's files as cgroups v1
and v2 lay them out; here under a made-up root."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from wmr_mission.campaign import cores

V2_MOUNT = "30 23 0:27 / /sys/fs/cgroup rw,nosuid - cgroup2 cgroup2 rw,nsdelegate"
V1_MOUNTS = (
    "31 23 0:28 / /sys/fs/cgroup rw,relatime - tmpfs tmpfs rw,mode=755\n"
    "32 31 0:29 / /sys/fs/cgroup/cpu rw,relatime - cgroup cgroup rw,cpu\n"
    "33 31 0:30 / /sys/fs/cgroup/cpuacct rw,relatime - cgroup cgroup rw,cpuacct\n"
    "34 31 0:31 / /sys/fs/cgroup/memory rw,relatime - cgroup cgroup rw,memory"
)


def _root(tmp_path: Path, groups: str, mounts: str, files: dict[str, str]) -> Path:
    """A made-up ``/``: /proc/self/cgroup, /proc/self/mountinfo and ``files``."""
    for name, text in {
        "proc/self/cgroup": groups,
        "proc/self/mountinfo": mounts,
        **files,
    }.items():
        path = tmp_path / name
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text + "\n", encoding="ascii")
    return tmp_path


def test_a_v2_quota_is_read_from_the_group_and_every_group_above_it(tmp_path: Path) -> None:
    files = {
        "sys/fs/cgroup/cpu.max": "max 100000",  # the root group
        "sys/fs/cgroup/kubepods/cpu.max": "300000 100000",  # 3 CPUs for the pods
        "sys/fs/cgroup/kubepods/pod7/cpu.max": "max 100000",  # the pod's own: none
        "sys/fs/cgroup/kubepods/pod7/web/cpu.max": "150000 100000",  # 1.5 CPUs
    }
    root = _root(tmp_path, "0::/kubepods/pod7/web", V2_MOUNT, files)
    assert cores.cpu_quota(root) == 1.5
    assert cores.usable_cores(root) == min(2, len(os.sched_getaffinity(0)))
    # a group above with less than the group's own: the least holds
    (root / "sys/fs/cgroup/kubepods/cpu.max").write_text("50000 100000\n", encoding="ascii")
    assert cores.cpu_quota(root) == 0.5
    assert cores.usable_cores(root) == 1  # half a CPU: one core, busy half of the time


def test_a_container_s_own_group_mounted_as_the_root(tmp_path: Path) -> None:
    """Docker with a cgroup namespace: the process sees itself at ``/``."""
    root = _root(tmp_path, "0::/", V2_MOUNT, {"sys/fs/cgroup/cpu.max": "100000 100000"})
    assert cores.cpu_quota(root) == 1.0
    assert cores.usable_cores(root) == 1


def test_a_v1_quota_where_cpu_is_mounted_alone(tmp_path: Path) -> None:
    groups = "9:name=systemd:/\n4:memory:/\n3:cpuacct:/\n1:cpu:/batch"
    files = {
        "sys/fs/cgroup/cpu/cpu.cfs_quota_us": "-1",
        "sys/fs/cgroup/cpu/cpu.cfs_period_us": "100000",
        "sys/fs/cgroup/cpu/batch/cpu.cfs_quota_us": "100000",
        "sys/fs/cgroup/cpu/batch/cpu.cfs_period_us": "100000",
    }
    root = _root(tmp_path, groups, V1_MOUNTS, files)
    assert cores.cpu_quota(root) == 1.0
    assert cores.usable_cores(root) == 1


def test_a_v1_container_whose_mount_shows_its_own_group(tmp_path: Path) -> None:
    """Docker without a cgroup namespace: /proc/self/cgroup names the group in
    the host's hierarchy; the mount holds that group alone, as its root."""
    mounts = "40 35 0:29 /docker/abc /sys/fs/cgroup/cpu,cpuacct ro - cgroup cgroup rw,cpu,cpuacct"
    files = {
        "sys/fs/cgroup/cpu,cpuacct/cpu.cfs_quota_us": "200000",
        "sys/fs/cgroup/cpu,cpuacct/cpu.cfs_period_us": "100000",
    }
    root = _root(tmp_path, "5:cpu,cpuacct:/docker/abc", mounts, files)
    assert cores.cpu_quota(root) == 2.0


@pytest.mark.parametrize(
    ("groups", "mounts", "files"),
    [
        ("0::/", V2_MOUNT, {"sys/fs/cgroup/cpu.max": "max 100000"}),  # no quota
        ("0::/", V2_MOUNT, {}),  # the root group: no cpu.max at all
        ("1:cpu:/", V1_MOUNTS, {"sys/fs/cgroup/cpu/cpu.cfs_quota_us": "-1"}),
        ("0::/", V2_MOUNT, {"sys/fs/cgroup/cpu.max": "a lot"}),  # not the kernel's
        ("0::/", "no mounts here", {"sys/fs/cgroup/cpu.max": "100000 100000"}),
        ("", V2_MOUNT, {"sys/fs/cgroup/cpu.max": "100000 100000"}),  # no group
    ],
)
def test_no_quota_leaves_every_cpu_the_process_may_run_on(
    tmp_path: Path, groups: str, mounts: str, files: dict[str, str]
) -> None:
    root = _root(tmp_path, groups, mounts, files)
    assert cores.cpu_quota(root) is None
    assert cores.usable_cores(root) == len(os.sched_getaffinity(0))


def test_without_the_kernel_s_files_there_is_no_quota(tmp_path: Path) -> None:
    assert cores.cpu_quota(tmp_path) is None  # not Linux, or /proc not mounted
    assert cores.usable_cores(tmp_path) == len(os.sched_getaffinity(0))
