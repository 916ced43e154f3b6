"""The environment on record: manifest.json's ``environment``, the fingerprint a
replay command carries and ``run`` checks, and ``sweep --scheduler``'s check
of the Dask workers before the first run (docs/reliability.md)."""

from __future__ import annotations

import json
import re
import shlex
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest

from wmr_mission.campaign.engine import MixedCluster, check_cluster
from wmr_mission.campaign.sweep import sweep_command
from wmr_mission.output.environment import (
    environment,
    fingerprint,
    libm_digest,
    machine_record,
    own_fingerprint,
    package_versions,
)
from wmr_mission.version import installed_version

DATA = Path(__file__).resolve().parent / "data" / "campaigns"
WARNING = "warning: this environment's fingerprint is"


def _campaign(tmp_path: Path) -> Path:
    path = tmp_path / "c.yaml"
    path.write_text(
        f"""version: 1
name: headings
mission: {DATA / "short.yaml"}
runs: 3
seed: 5
vary:
  robot.initial_state.theta: {{uniform: [-3.0, 3.0]}}
""",
        encoding="utf-8",
    )
    return path


def test_the_fingerprint_digests_what_decides_the_bytes_and_nothing_else() -> None:
    versions = package_versions()
    mine = fingerprint(versions, "glibc 2.36", "94099d6f")
    assert re.fullmatch("[0-9a-f]{8}", mine)
    for name in ("wmr-mission", "numpy", "numba"):
        assert fingerprint({**versions, name: "0.0.1"}, "glibc 2.36", "94099d6f") != mine, name
    assert fingerprint({**versions, "python": "3.99.0"}, "glibc 2.36", "94099d6f") != mine
    assert fingerprint(versions, "glibc 2.35", "94099d6f") != mine
    assert fingerprint(versions, "glibc 2.36", "fd1c5540") != mine
    # Packages that compute none of a run's numbers, and Python's bug-fix releases
    others = {**versions, "scipy": "0", "pydantic": "0", "matplotlib": "0"}
    python = versions["python"]
    assert python is not None
    others["python"] = ".".join(python.split(".")[:2]) + ".99"
    assert fingerprint(others, "glibc 2.36", "94099d6f") == mine


def test_the_manifest_holds_the_environment_and_the_fingerprint_is_its_own() -> None:
    record = environment()
    assert record["fingerprint"] == own_fingerprint()
    assert record["libm"] == libm_digest()
    assert isinstance(record["numpy_simd"], list)
    assert machine_record()["environment"] == record


@pytest.mark.slow
def test_a_replay_carries_the_fingerprint_and_run_warns_in_one_line_elsewhere(
    tmp_path: Path,
) -> None:
    out = tmp_path / "out"
    code = sweep_command(_campaign(tmp_path), out=out, workers=1, scheduler=None, plots=False)
    assert code in (0, 1)
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["environment"]["fingerprint"] == own_fingerprint()
    worst = json.loads((out / "campaign.json").read_text(encoding="utf-8"))["worst"][0]
    words = shlex.split(worst["replay"])
    assert words[-2:] == ["--expect-environment", own_fingerprint()]
    kept = (out / "worst" / str(worst["run"]) / "trajectory.csv").read_bytes()
    for expected, warned in ((own_fingerprint(), False), ("0badf00d", True)):
        replay = tmp_path / expected
        command = [*words[1:-1], expected, "--out", str(replay), "--no-plots"]
        done = subprocess.run(
            [sys.executable, "-m", "wmr_mission", *command], capture_output=True, text=True
        )
        assert done.returncode in (0, 1), done.stderr
        lines = [line for line in done.stderr.splitlines() if WARNING in line]
        if warned:
            assert lines == [
                f"wmr-mission: {WARNING} {own_fingerprint()}, not 0badf00d as where the "
                "command was recorded: the results may differ in the last digits "
                '(manifest.json\'s "versions" and "environment" say what this one is)'
            ]
        else:
            assert lines == []
        # a warning, never another run
        assert (replay / "trajectory.csv").read_bytes() == kept


class _Cluster:
    """A Dask client as check_cluster sees it: the workers' machine records."""

    def __init__(self, records: dict[str, Any]) -> None:
        self.records = records

    def run(self, function: Any) -> dict[str, Any]:
        assert function is machine_record
        return self.records


def _other(libm: str = "0badf00d", numpy: str | None = None) -> dict[str, Any]:
    record = json.loads(json.dumps(machine_record()))
    versions = record["versions"]
    if numpy is not None:
        versions["numpy"] = numpy
    record["environment"]["libm"] = libm
    record["environment"]["fingerprint"] = fingerprint(
        versions, record["environment"]["libc"], libm
    )
    return record


def test_the_workers_are_checked_against_this_machine(capsys: pytest.CaptureFixture[str]) -> None:
    same = machine_record()
    check_cluster(_Cluster({"tcp://a:1": same, "tcp://b:2": same}), allow_mixed_cluster=False)
    mixed = {"tcp://a:1": same, "tcp://b:2": _other(numpy="1.0.0")}
    with pytest.raises(MixedCluster) as refused:
        check_cluster(_Cluster(mixed), allow_mixed_cluster=False)
    message = str(refused.value)
    assert message.startswith("1 of 2 Dask workers differ from this machine: tcp://b:2: ")
    assert f"numpy: {same['versions']['numpy']} != 1.0.0" in message
    assert f"libm: {same['environment']['libm']} != 0badf00d" in message
    assert "--allow-mixed-cluster" in message
    assert capsys.readouterr().err == ""
    check_cluster(_Cluster(mixed), allow_mixed_cluster=True)
    (line,) = capsys.readouterr().err.splitlines()
    assert line.startswith("wmr-mission: warning: 1 of 2 Dask workers differ from this machine")
    # numpy's SIMD level and numba's CPU are on record, but change no byte
    simd = json.loads(json.dumps(same))
    simd["environment"]["numpy_simd"], simd["environment"]["numba_cpu"] = [], "x86-64-v2"
    check_cluster(_Cluster({"tcp://a:1": simd}), allow_mixed_cluster=False)


@pytest.mark.slow
def test_sweep_refuses_a_cluster_whose_worker_has_another_c_library(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    import distributed  # in the test extra

    campaign = _campaign(tmp_path)
    with (
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, processes=True, dashboard_address=None
        ) as cluster,
        distributed.Client(cluster) as client,
    ):
        # The worker process as on a CPU whose C library gives other last bits.
        client.run(
            exec,
            "import wmr_mission.output.environment as e\n"
            "e.libm_digest = lambda: '0badf00d'\n"
            "e.own_fingerprint.cache_clear()\n",
        )
        address = cluster.scheduler_address
        code = sweep_command(
            campaign, out=tmp_path / "refused", workers=1, scheduler=address, plots=False
        )
        assert code == 2
        err = capsys.readouterr().err
        assert f"libm: {libm_digest()} != 0badf00d" in err
        assert "pass --allow-mixed-cluster" in err
        assert not (tmp_path / "refused" / "campaign.json").exists()
        code = sweep_command(
            campaign,
            out=tmp_path / "allowed",
            workers=1,
            scheduler=address,
            plots=False,
            allow_mixed_cluster=True,
        )
        assert code in (0, 1)
        assert "warning: 1 of 1 Dask workers differ" in capsys.readouterr().err
        assert json.loads((tmp_path / "allowed" / "campaign.json").read_text())["runs"] == 3


def test_a_version_read_from_the_metadatas_headers_is_importlibs() -> None:
    """Read from the headers alone, the version is the one importlib.metadata
    parses from the whole file; None for a package not installed."""
    from importlib import metadata

    for package in (
        "numpy",
        "scipy",
        "pydantic",
        "numba",
        "matplotlib",
        "PyYAML",
        "typer",
        "wmr-mission",
        "pydantic_core",
    ):
        assert installed_version(package) == metadata.version(package), package
    assert installed_version("wmr-mission-no-such-package") is None


def _distribution(directory: Path, name: str, headers: str, kind: str = "dist-info") -> None:
    info = directory / f"{name}.{kind}"
    info.mkdir(parents=True)
    metadata = "METADATA" if kind == "dist-info" else "PKG-INFO"
    (info / metadata).write_text(f"Metadata-Version: 2.1\n{headers}\n\nVersion: 9 (not a header)\n")


def test_a_version_is_found_on_the_path_as_importlib_finds_it(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Names compared as importlib.metadata compares them, the first directory
    of the path that has the distribution, an egg's metadata and a zip on the
    path read by importlib.metadata; each the version importlib.metadata
    gives."""
    from importlib import metadata

    first, second = tmp_path / "first", tmp_path / "second"
    _distribution(first, "Zope.Interface-5.1", "Version: 5.1")
    _distribution(second, "zope_interface-6.0", "Version: 6.0")  # behind the first: not taken
    _distribution(second, "only_here-1.0", "Name: only-here\nVersion: 1.0.post0")
    _distribution(second, "old_style-0.3", "Version: 0.3", kind="egg-info")
    monkeypatch.setattr(sys, "path", [str(tmp_path / "missing"), str(first), str(second)])
    for package in ("zope.interface", "Zope-Interface", "only-here", "ONLY_HERE", "old-style"):
        assert installed_version(package) == metadata.version(package), package
    assert installed_version("zope.interface") == "5.1"
    assert installed_version("only-here") == "1.0.post0"
    assert installed_version("old-style") == "0.3"
    with pytest.raises(metadata.PackageNotFoundError):
        metadata.version("no-such-package")
    assert installed_version("no-such-package") is None


def test_a_replay_carries_the_mission_s_digest_and_run_warns_when_the_file_changed(
    tmp_path: Path,
) -> None:
    """A replay line ran an edited mission without a word: the campaign's
    numbers did not come back, and nothing said why. It carries the start of
    the mission file's sha256, and `run` says in one line when the file's
    differs (still a run: the user may mean the edit)."""
    import hashlib

    from typer.testing import CliRunner

    from wmr_mission.campaign.load import MISSION_DIGITS, replay_line
    from wmr_mission.cli import app

    mission = tmp_path / "short.yaml"
    mission.write_bytes((DATA / "short.yaml").read_bytes())
    digest = hashlib.sha256(mission.read_bytes()).hexdigest()
    line = replay_line(str(mission), [], {}, 5, own_fingerprint(), digest)
    words = shlex.split(line)
    at = words.index("--expect-mission")
    assert words[at + 1] == digest[:MISSION_DIGITS]
    assert words[-2:] == ["--expect-environment", own_fingerprint()]

    def replayed(out: str) -> list[str]:
        done = CliRunner().invoke(app, [*words[1:], "--out", str(tmp_path / out), "--no-plots"])
        assert done.exit_code in (0, 1), done.output
        return [s for s in done.stderr.splitlines() if "not the file the command" in s]

    assert replayed("same") == []
    mission.write_text(mission.read_text(encoding="utf-8") + "# edited\n", encoding="utf-8")
    [warning] = replayed("edited")
    now = hashlib.sha256(mission.read_bytes()).hexdigest()
    assert warning == (
        f"wmr-mission: warning: {mission} is not the file the command was recorded with "
        f"(its sha256 begins {now[:MISSION_DIGITS]}, not {digest[:MISSION_DIGITS]}): "
        "this run does not replay the recorded one"
    )
    refused = CliRunner().invoke(app, ["run", str(mission), "--expect-mission", "xyz"])
    assert refused.exit_code == 2
    assert refused.stderr.startswith("--expect-mission xyz: not the start of a sha256")
