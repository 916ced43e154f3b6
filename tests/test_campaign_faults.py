"""Campaigns and the API under faults (docs/reliability.md, "Campaigns").

One section per class of fault: each test provokes the fault itself (a
signal to a subprocess, a write that fails with ENOSPC, a directory removed,
a scheduler that is not one or dies, odd arguments) and checks that nothing
that ran is lost, nothing is half-written or left behind, and the fault is
said in one line with its exit code.
"""

from __future__ import annotations

import contextlib
import csv
import ctypes
import errno
import hashlib
import json
import os
import shlex
import shutil
import signal
import socket
import subprocess
import sys
import threading
import time
from collections.abc import Callable, Iterator
from datetime import datetime
from pathlib import Path
from typing import Any

import pytest
from conftest import the_tests_package
from typer.testing import CliRunner

from wmr_mission import (
    load_mission,
    mission_from_dict,
    mission_from_text,
    run_campaign,
    run_mission,
)
from wmr_mission.campaign import cores, engine, sweep
from wmr_mission.campaign.load import MAX_CAMPAIGN_BYTES, LoadedCampaign, check_campaign, check_file
from wmr_mission.campaign.sweep import sweep_command
from wmr_mission.cli import app
from wmr_mission.commands.run import run_command
from wmr_mission.output.rundir import CLAIM_FILE
from wmr_mission.spec.loader import check_mission_text, parse_override

ROOT = Path(__file__).resolve().parents[1]
SHORT = ROOT / "tests" / "data" / "campaigns" / "short.yaml"


def campaign_file(
    directory: Path,
    runs: int,
    *,
    mission: Path = SHORT,
    vary: str = "robot.initial_state.theta: {uniform: [-3.0, 3.0]}",
    seed: int = 11,
    name: str = "c.yaml",
) -> Path:
    path = directory / name
    path.write_text(
        f"version: 1\nname: headings\nmission: {mission}\nruns: {runs}\nseed: {seed}\n"
        f"vary:\n  {vary}\n",
        encoding="utf-8",
    )
    return path


def rows_of(path: Path) -> list[list[str]]:
    """runs.csv's rows, each checked whole: the header's number of fields and a
    final newline (a file cut inside a row fails here)."""
    text = path.read_text(encoding="utf-8")
    assert text.endswith("\n")
    header, *rows = list(csv.reader(text.splitlines()))
    assert all(len(row) == len(header) for row in rows)
    return rows


def record_of(out: Path) -> dict[str, Any]:
    record: dict[str, Any] = json.loads((out / "campaign.json").read_text(encoding="utf-8"))
    return record


def leftovers(out: Path) -> list[str]:
    """Claims and temporary files: a finished campaign directory holds neither."""
    return sorted(
        str(p.relative_to(out)) for p in out.rglob("*") if p.name == CLAIM_FILE or ".tmp" in p.name
    )


# Said before a sweep's warm-up while the kernel cache holds no ready marker
# (`wmr-mission compile` leaves one): it depends on the cache, not on the test.
COMPILE_NOTICE = "wmr-mission: loading the simulation loop, compiled first"


def one_line(stderr: str) -> str:
    lines = [
        line for line in stderr.splitlines() if line.strip() and not line.startswith(COMPILE_NOTICE)
    ]
    assert len(lines) == 1, stderr
    assert "Traceback" not in stderr
    return lines[0]


# --- 1. signals: SIGTERM as Ctrl-C, no worker outlives the sweep --------------------


def _children(pid: int) -> list[int]:
    found = []
    for task in Path(f"/proc/{pid}/task").iterdir():
        found += [int(p) for p in (task / "children").read_text().split()]
    return found


def _alive(pid: int) -> bool:
    try:
        state = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()[0]
    except FileNotFoundError:
        return False
    return state != "Z"


def _sweep_with_workers(tmp_path: Path, out: Path) -> tuple[subprocess.Popen[bytes], list[int]]:
    """A two-worker sweep in a subprocess, its workers running: it and its workers."""
    process = subprocess.Popen(
        [sys.executable, "-m", "wmr_mission", "sweep", str(campaign_file(tmp_path, 100_000)),
         "--out", str(out), "--workers", "2", "--no-plots"],
        cwd=tmp_path,
        env=the_tests_package(dict(os.environ)),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )  # fmt: skip
    # long enough for the warm-up to compile the loop cold on a loaded machine
    deadline = time.monotonic() + 300
    runs_csv = out / "runs.csv"
    while not (runs_csv.is_file() and runs_csv.read_bytes().count(b"\n") > 20):
        assert time.monotonic() < deadline
        assert process.poll() is None
        time.sleep(0.05)
    workers = _children(process.pid)
    assert len(workers) == 2
    return process, workers


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_sigterm_stops_a_sweep_like_ctrl_c_and_leaves_no_worker(tmp_path: Path) -> None:
    """SIGTERM to the sweep alone (as `kill PID` sends it): exit 143, every
    finished run in runs.csv and counted by campaign.json, which says why it
    stopped; no claim, no temporary file, no worker left."""
    out = tmp_path / "out"
    process, workers = _sweep_with_workers(tmp_path, out)
    process.send_signal(signal.SIGTERM)
    _, stderr = process.communicate(timeout=60)
    assert process.returncode == 143, stderr
    assert f"interrupted (SIGTERM); the {record_of(out)['runs']} finished runs are kept" in (
        one_line(stderr.decode())
    )
    record = record_of(out)
    rows = rows_of(out / "runs.csv")
    assert record["interrupted"] is True
    assert record["stopped_by"] == "SIGTERM"
    assert 20 <= record["runs"] == len(rows) < 100_000
    assert leftovers(out) == []
    for worker in workers:
        assert not _alive(worker)


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="a parent-death signal")
def test_no_worker_outlives_a_sweep_that_is_killed(tmp_path: Path) -> None:
    """SIGKILL leaves no chance to write anything, but the workers end with
    the sweep instead of waiting forever for tasks."""
    process, workers = _sweep_with_workers(tmp_path, tmp_path / "out")
    process.kill()
    process.communicate(timeout=60)
    deadline = time.monotonic() + 10
    while any(_alive(worker) for worker in workers) and time.monotonic() < deadline:
        time.sleep(0.05)
    assert not any(_alive(worker) for worker in workers)


def test_a_second_signal_stops_waiting_for_the_tasks_under_way() -> None:
    """After the first signal the tasks running are waited for; a second one
    (KeyboardInterrupt) must end that wait, not count as a failed task."""

    class Waiting:
        def result(self) -> None:
            raise KeyboardInterrupt

    with pytest.raises(KeyboardInterrupt):
        engine._ran_to_end(Waiting())


def test_a_signal_before_the_first_run_leaves_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """Stopped while compiling (the warm-up), a sweep has run nothing: it
    removes its directory, so that the same --out can be used again."""

    def stopped(loaded: Any, *_: Any) -> float:
        os.kill(os.getpid(), signal.SIGTERM)
        raise AssertionError("SIGTERM did not stop the warm-up")

    monkeypatch.setattr(sweep, "warm_up", stopped)
    out = tmp_path / "out"
    path = campaign_file(tmp_path, 4)
    assert sweep_command(path, out=out, workers=1, scheduler=None, plots=False) == 143
    assert "interrupted by SIGTERM before the first run" in one_line(capsys.readouterr().err)
    assert not out.exists()


# --- 2. I/O faults after the runs started -------------------------------------------


class _Filling:
    """A text file that takes ``room`` more characters, the last write cut
    where the room ends, then fails with ENOSPC: a disk that fills."""

    def __init__(self, stream: Any, room: int) -> None:
        self.stream, self.room = stream, room

    def write(self, text: str) -> int:
        part = text[: max(self.room, 0)]
        self.stream.write(part)
        self.stream.flush()
        self.room -= len(part)
        if len(part) < len(text):
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        return len(text)

    def __enter__(self) -> _Filling:
        return self

    def __exit__(self, *_: object) -> None:
        self.stream.close()

    def __getattr__(self, name: str) -> Any:
        return getattr(self.stream, name)


@contextlib.contextmanager
def disk_full_after(limit: int, name: str) -> Iterator[None]:
    """Writes into files called ``name`` fail with ENOSPC once ``limit`` bytes
    are in them, the last one cut where the space ends, as a full disk does:
    through file descriptors and through file objects alike."""
    real_write, real_open = os.write, Path.open
    written: dict[int, int] = {}

    def write(fd: int, data: Any) -> int:
        if not os.readlink(f"/proc/self/fd/{fd}").endswith(name):
            return real_write(fd, data)
        room = limit - written.get(fd, 0)
        if room <= 0:
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        count = real_write(fd, bytes(data[:room]))
        written[fd] = written.get(fd, 0) + count
        return count

    def open_(path: Path, mode: str = "r", *args: Any, **kwargs: Any) -> Any:
        stream = real_open(path, mode, *args, **kwargs)
        return _Filling(stream, limit) if path.name == name and "w" in mode else stream

    os.write = write  # type: ignore[assignment]
    Path.open = open_  # type: ignore[method-assign]
    try:
        yield
    finally:
        os.write, Path.open = real_write, real_open  # type: ignore[method-assign]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="reads /proc")
def test_a_full_disk_while_writing_rows_keeps_every_complete_row(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    path = campaign_file(tmp_path, 400)
    with disk_full_after(25_000, "runs.csv"):  # tasks of 100 runs, 10 kB
        code = sweep_command(path, out=out, workers=1, scheduler=None, plots=True)
    assert code == 2
    stderr = capsys.readouterr().err
    line = one_line(stderr)
    assert f"{out / 'runs.csv'}: cannot write: No space left on device" in line
    rows = rows_of(out / "runs.csv")  # never cut inside a row
    record = record_of(out)
    assert 0 < record["runs"] == len(rows) < 400
    assert f"the campaign stopped after {len(rows)} runs" in line
    assert record["interrupted"] is True
    assert "No space left on device" in record["stopped_by"]
    assert [int(row[0]) for row in rows] == list(range(len(rows)))
    assert leftovers(out) == []
    assert not (out / "trajectories.png").exists()  # nothing more is written to a full disk


@pytest.mark.parametrize("stage", ["figures", "worst", "campaign.json"])
@pytest.mark.usefixtures("campaign_figures_only")
def test_a_full_disk_after_the_runs_is_one_line_and_keeps_the_runs(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    stage: str,
) -> None:
    out = tmp_path / "out"

    def full(*args: Any, **kwargs: Any) -> Any:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(out / f"{stage}.tmp"))

    if stage == "figures":
        monkeypatch.setattr(sweep, "_draw", full)
    elif stage == "worst":
        monkeypatch.setattr(sweep, "_write_run_dir", full)
    else:
        real = sweep.write_bytes_atomic

        def campaign_json_full(path: Path, data: bytes) -> Path:
            if path.name == "campaign.json":
                full()
            return real(path, data)

        monkeypatch.setattr(sweep, "write_bytes_atomic", campaign_json_full)
    code = sweep_command(campaign_file(tmp_path, 6), out=out, workers=1, scheduler=None, plots=True)
    assert code == 2
    line = one_line(capsys.readouterr().err)
    assert f"{out / stage}.tmp: cannot write: No space left on device" in line
    assert len(rows_of(out / "runs.csv")) == 6
    if stage == "campaign.json":
        assert "runs.csv holds the 6 runs done" in line
    else:
        assert record_of(out)["runs"] == 6
        assert f"runs.csv and campaign.json are in {out}" in line
    assert leftovers(out) == []


@pytest.mark.usefixtures("campaign_figures_only")
def test_a_disk_full_among_the_worst_runs_names_each_one_and_leaves_no_empty_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """The disk fills after the first worst run: each run not written is named,
    with the figures, and its directory, made before the disk refused its first
    file, is removed; view links the one written and no other."""
    from wmr_mission.review.view import campaign_meta

    out = tmp_path / "out"
    real = sweep.write_run
    calls: list[Path] = []

    def full_after_the_first(result: Any, directory: Path, **kwargs: Any) -> Any:
        calls.append(Path(directory))
        if len(calls) == 1:
            return real(result, directory, **kwargs)
        Path(directory).mkdir(parents=True)
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), str(directory / "trajectory.csv"))

    monkeypatch.setattr(sweep, "write_run", full_after_the_first)
    code = sweep_command(campaign_file(tmp_path, 6), out=out, workers=1, scheduler=None, plots=True)
    assert code == 2
    line = one_line(capsys.readouterr().err)
    worst = [str(entry["run"]) for entry in record_of(out)["worst"]]
    assert len(calls) == 2
    assert len(worst) > 2
    assert (
        f"{calls[1] / 'trajectory.csv'}: cannot write: No space left on device; not written: "
        f"{', '.join(f'worst/{run}' for run in worst[1:])}, the figures; "
        f"runs.csv and campaign.json are in {out}"
    ) == line
    assert sorted(p.name for p in (out / "worst").iterdir()) == [worst[0]]
    assert not list(out.glob("*.png"))
    assert list(campaign_meta(out, out / "report.html")["worst_links"]) == [worst[0]]
    assert leftovers(out) == []


@pytest.mark.usefixtures("campaign_figures_only")
def test_an_out_replaced_by_a_file_at_the_end_is_one_line(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """--out made a file while the runs ran (or made read-only): campaign.json
    cannot be written there, nor the claim removed; the one line says the
    first, never a traceback of the second."""
    out = tmp_path / "out"
    real = sweep.write_bytes_atomic

    def replaced_first(path: Path, data: bytes) -> Path:
        if path.name == "campaign.json" and out.is_dir():
            shutil.rmtree(out)
            out.write_text("x")
        return real(path, data)

    monkeypatch.setattr(sweep, "write_bytes_atomic", replaced_first)
    code = sweep_command(campaign_file(tmp_path, 6), out=out, workers=1, scheduler=None, plots=True)
    assert code == 2
    line = one_line(capsys.readouterr().err)
    assert "cannot write: Not a directory" in line
    assert out.read_text() == "x"


@pytest.mark.usefixtures("campaign_figures_only")
def test_a_fault_in_drawing_is_one_line_and_keeps_the_runs(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    def broken(*args: Any, **kwargs: Any) -> Any:
        raise ValueError("a figure that cannot be drawn")

    monkeypatch.setattr(sweep, "_draw", broken)
    out = tmp_path / "out"
    code = sweep_command(campaign_file(tmp_path, 6), out=out, workers=1, scheduler=None, plots=True)
    assert code == 1
    line = one_line(capsys.readouterr().err)
    assert "cannot write the worst runs or the figures (ValueError: a figure that" in line
    assert record_of(out)["runs"] == len(rows_of(out / "runs.csv")) == 6


def test_an_out_removed_during_the_sweep_is_written_again_with_every_run(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    real = engine.run_rows
    removed = []

    def removing(loaded: Any, start: int, stop: int, *rest: Any) -> Any:
        if start > 0 and not removed:  # after the first task's rows were written
            shutil.rmtree(out)
            removed.append(start)
        return real(loaded, start, stop, *rest)

    monkeypatch.setattr(engine, "run_rows", removing)
    monkeypatch.setattr(engine, "TASK_SECONDS", 0.0)  # one run per task
    path = campaign_file(tmp_path, 8)
    assert sweep_command(path, out=out, workers=1, scheduler=None, plots=False) == 0
    assert removed
    assert f"{out}: removed during the sweep; written again, with its 8 runs" in one_line(
        capsys.readouterr().err
    )
    assert [int(row[0]) for row in rows_of(out / "runs.csv")] == list(range(8))
    assert record_of(out)["runs"] == 8
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["resolved_campaign"]["runs"] == 8
    assert len(list((out / "worst").iterdir())) == 5
    assert leftovers(out) == []


# --- 3. the mission is read once ----------------------------------------------------


MISSION = """version: 1
name: short-park
robot:
  dt: 0.02
  initial_state: {x: -1, y: 0.5, theta: 0.5}
estimator:
  type: constrained-observer
phases:
  - name: park
    regulate: {target: {x: 0, y: 0, theta: 0}}
    until: {elapsed: 2}
"""


@pytest.mark.parametrize("change", ["delete", "edit"])
def test_the_worst_runs_run_and_record_the_mission_as_read(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, change: str
) -> None:
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    real = engine.run_rows

    def changing(loaded: Any, start: int, stop: int, *rest: Any) -> Any:
        if change == "delete":
            mission.unlink(missing_ok=True)
        else:
            mission.write_text(MISSION.replace("x: 0, y: 0", "x: 5, y: 5"), encoding="utf-8")
        return real(loaded, start, stop, *rest)

    monkeypatch.setattr(engine, "run_rows", changing)
    out = tmp_path / "out"
    path = campaign_file(tmp_path, 6, mission=mission)
    assert sweep_command(path, out=out, workers=1, scheduler=None, plots=False) == 0
    read = hashlib.sha256(MISSION.encode()).hexdigest()
    assert json.loads((out / "manifest.json").read_text())["mission_sha256"] == read
    worst = sorted((out / "worst").iterdir())
    assert len(worst) == 5
    for directory in worst:
        manifest = json.loads((directory / "manifest.json").read_text())
        assert manifest["mission_sha256"] == read
        target = manifest["resolved_mission"]["phases"][0]["regulate"]["target"]
        assert (target["x"], target["y"]) == (0, 0)


# --- 4. a --scheduler where no Dask scheduler answers, or one that dies --------------


@contextlib.contextmanager
def server(reply: bytes | None) -> Iterator[int]:
    """A TCP server on a free port that accepts, reads and answers ``reply``
    (None: never answers)."""
    listening = socket.socket()
    listening.bind(("127.0.0.1", 0))
    listening.listen(8)
    held = []

    def serve() -> None:
        with contextlib.suppress(OSError):
            while True:
                connection, _ = listening.accept()
                held.append(connection)
                if reply is not None:
                    connection.recv(65536)
                    connection.sendall(reply)
                    connection.close()

    threading.Thread(target=serve, daemon=True).start()
    try:
        yield listening.getsockname()[1]
    finally:
        listening.close()
        for connection in held:
            connection.close()


HTTP_REPLY = b"HTTP/1.1 400 Bad Request\r\nContent-Length: 0\r\nConnection: close\r\n\r\n"


@pytest.mark.parametrize(
    ("kind", "said"),
    [
        ("silent", "no answer within 1 s"),
        ("http", "it answers, but not as a Dask scheduler"),
        ("tls", "tls:// needs certificates in dask's configuration"),
    ],
)
def test_a_scheduler_that_is_not_one_is_refused_at_once_and_leaves_nothing(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    kind: str,
    said: str,
) -> None:
    monkeypatch.setattr(engine, "_CONNECT_SECONDS", 1)
    out = tmp_path / "out"
    path = campaign_file(tmp_path, 4)
    with server(None if kind == "silent" else HTTP_REPLY) as port:
        scheme = "tls" if kind == "tls" else "tcp"
        address = f"{scheme}://127.0.0.1:{port}"
        code = sweep_command(path, out=out, workers=1, scheduler=address, plots=False)
    assert code == 2
    line = one_line(capsys.readouterr().err)
    assert line.startswith(f"{path}: cannot use the Dask scheduler {address}: {said}")
    assert not out.exists()
    # Nothing claimed, nothing written: the retry into the same --out runs.
    assert sweep_command(path, out=out, workers=1, scheduler=None, plots=False) == 0
    with (
        pytest.raises(engine.SchedulerUnavailable, match="no answer within 1 s"),
        server(None) as port,
    ):
        run_campaign(path, out=tmp_path / "api", scheduler=f"tcp://127.0.0.1:{port}")
    assert not (tmp_path / "api").exists()


@contextlib.contextmanager
def one_worker_cluster() -> Iterator[Any]:
    """A Dask cluster in this process: a scheduler and one worker of one thread."""
    import dask
    import distributed  # in the test extra

    with (
        # the cluster's own shutdown, its scheduler gone, retries for this long
        dask.config.set({"distributed.comm.timeouts.connect": "1s"}),
        distributed.LocalCluster(
            n_workers=1, threads_per_worker=1, dashboard_address=None, processes=False
        ) as cluster,
    ):
        yield cluster


def once_rows_are_written(out: Path, rows: int, then: Callable[[], object]) -> None:
    """``then()`` in a thread of its own, once ``out``'s runs.csv holds more than ``rows`` rows."""

    def wait() -> None:
        runs_csv = out / "runs.csv"
        while not (runs_csv.is_file() and runs_csv.read_bytes().count(b"\n") > rows):
            time.sleep(0.05)
        then()

    threading.Thread(target=wait, daemon=True).start()


@pytest.mark.slow
def test_a_scheduler_lost_during_the_runs_is_one_line(
    tmp_path: Path, capfd: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    path = campaign_file(tmp_path, 100_000)
    with one_worker_cluster() as cluster:
        once_rows_are_written(out, 20, lambda: cluster.sync(cluster.scheduler.close))
        address = cluster.scheduler_address
        code = sweep_command(path, out=out, workers=None, scheduler=address, plots=False)
    assert code == 1
    line = one_line(capfd.readouterr().err)
    assert f"interrupted (lost the Dask scheduler {address})" in line
    record = record_of(out)
    assert record["stopped_by"] == f"lost the Dask scheduler {address}"
    assert 20 <= record["runs"] == len(rows_of(out / "runs.csv")) < 100_000


def test_a_scheduler_left_without_workers_stops_the_sweep_in_one_line(
    tmp_path: Path, capfd: pytest.CaptureFixture[str], monkeypatch: pytest.MonkeyPatch
) -> None:
    """Its only worker killed, the scheduler has none: Dask would wait for one
    forever; the sweep stops after engine.WORKERLESS_SECONDS (2 s here), its
    finished runs kept, exit 1, as for a lost scheduler."""
    monkeypatch.setattr(engine, "WORKERLESS_SECONDS", 2.0)
    out = tmp_path / "out"
    path = campaign_file(tmp_path, 100_000)
    with one_worker_cluster() as cluster:

        def stop_the_worker() -> None:
            for worker in list(cluster.workers.values()):
                cluster.sync(worker.close)

        once_rows_are_written(out, 20, stop_the_worker)
        address = cluster.scheduler_address
        code = sweep_command(path, out=out, workers=None, scheduler=address, plots=False)
    assert code == 1
    said = f"the Dask scheduler {address} has had no worker for 2 s"
    assert f"interrupted ({said})" in one_line(capfd.readouterr().err)
    record = record_of(out)
    assert record["stopped_by"] == said
    assert 20 <= record["runs"] == len(rows_of(out / "runs.csv")) < 100_000


# --- 5. characters beyond the Basic Multilingual Plane -------------------------------


def test_a_character_beyond_the_bmp_in_a_varied_value_replays(tmp_path: Path) -> None:
    """JSON writes 😀 as the escapes \\ud83d\\ude00: the replay's --set reads them back."""
    out = tmp_path / "out"
    path = campaign_file(tmp_path, 4, vary='description: {choice: ["smile 😀", "plain 𝜃"]}')
    result = run_campaign(path, out=out, workers=1)
    assert result.summary["outcomes"] == {"success": 4}
    for worst in result.summary["worst"]:
        words = shlex.split(worst["replay"])
        replay = tmp_path / f"replay-{worst['run']}"
        invoked = CliRunner().invoke(app, [*words[1:], "--out", str(replay), "--no-plots"])
        assert invoked.exit_code == 0, invoked.output
        drawn = result.rows[worst["run"]]["description"]
        manifest = json.loads((replay / "manifest.json").read_text(encoding="utf-8"))
        assert manifest["resolved_mission"]["description"] == drawn
        kept = out / "worst" / str(worst["run"]) / "trajectory.csv"
        assert (replay / "trajectory.csv").read_bytes() == kept.read_bytes()


def test_surrogate_pairs_read_as_their_character_and_a_lone_one_is_refused() -> None:
    assert parse_override('description="\\ud83d\\ude00 \\U0001F600"').value == "😀 😀"
    text = 'version: 1\nname: m\ndescription: "a \\udc00 b"\nphases: []\n'
    _, diagnostics = check_mission_text(text, "m.yaml")
    assert any(
        str(d).startswith("m.yaml:3:14: a text holds a lone surrogate escape") for d in diagnostics
    )


# --- 6. seeds in 0 .. 2^32 - 1 -------------------------------------------------------


def test_seeds_up_to_2_to_the_32_minus_1_are_taken_as_by_seed(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    out = tmp_path / "run"
    largest = 2**32 - 1
    code = run_command(
        mission,
        out=out,
        seed=None,
        plots=False,
        animate=False,
        overrides=[f"sensors.seed={largest}"],
    )
    assert code == 0, capsys.readouterr().err
    assert json.loads((out / "summary.json").read_text())["seed"] == largest
    code = run_command(
        mission,
        out=tmp_path / "beyond",
        seed=None,
        plots=False,
        animate=False,
        overrides=[f"sensors.seed={largest + 1}"],
    )
    assert code == 1
    assert f"magnitudes above {largest} are refused" in capsys.readouterr().err
    loaded, diagnostics = check_campaign(campaign_file(tmp_path, 2, seed=4_000_000_000))
    assert loaded is not None, diagnostics
    assert loaded.campaign.seed == 4_000_000_000


# --- 7. bad arguments never reach the internals ---------------------------------------


@pytest.mark.parametrize(
    ("override", "said"),
    [
        ("robot.dt=1e-320", "is implausibly small: expected at least 1e-09"),
        (
            "regions.wall={type: half-plane, normal: [1e-200, 0], offset: 1}",
            "regions.wall.normal: a half-plane normal of length 1e-200 is implausibly short",
        ),
    ],
)
def test_tiny_numbers_are_refused_not_internal_errors(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], override: str, said: str
) -> None:
    mission = tmp_path / "m.yaml"
    mission.write_text(MISSION, encoding="utf-8")
    code = run_command(
        mission, out=tmp_path / "r", seed=None, plots=False, animate=False, overrides=[override]
    )
    assert code == 1
    line = one_line(capsys.readouterr().err)
    assert line.startswith(f"--set {override}: {override.split('=')[0]}")
    assert said in line


# A pool left by a fault while a worker it forked a moment ago has not set
# itself up yet (engine._start_worker, slowed here): the worker still has this
# process's handler of SIGTERM, which raises.
POOL_LEFT_AT_ONCE = """
import time

from wmr_mission.campaign import engine
from wmr_mission.stopping import STOP_SIGNALS, StopSignals

set_up = engine._start_worker


def slow_to_set_up(parent):
    time.sleep(1.0)
    set_up(parent)


engine._start_worker = slow_to_set_up
with StopSignals(STOP_SIGNALS):
    try:
        with engine.local_pool(2) as pool:
            pool.submit(time.sleep, 0)
            raise RuntimeError("a fault")
    except RuntimeError:
        print("left")
"""


def test_a_pool_left_at_once_stops_its_workers_without_a_traceback() -> None:
    """`wmr-mission compile` whose variant failed at once printed a worker's
    traceback now and then: the pool stopped its workers with SIGTERM, and a
    worker not yet set up handled it as its parent does (a stop, raised).
    SIGKILL stops them as they are."""
    done = subprocess.run(
        [sys.executable, "-c", POOL_LEFT_AT_ONCE], env=the_tests_package(dict(os.environ)),
        cwd=ROOT / "tests", capture_output=True, text=True, timeout=60, check=False,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    assert done.stdout == "left\n"
    assert "Traceback" not in done.stderr
    assert done.stderr == ""


def test_more_workers_than_cores_are_capped_with_a_notice(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(engine, "default_workers", lambda: 2)
    pools = []
    real = engine.local_pool

    def counted(workers: int, **options: Any) -> Any:
        pools.append(workers)
        return real(workers, **options)

    monkeypatch.setattr(engine, "local_pool", counted)
    out = tmp_path / "out"
    code = sweep_command(
        campaign_file(tmp_path, 8), out=out, workers=10_000, scheduler=None, plots=False
    )
    assert code == 0
    assert "--workers 10000: 2 workers, one per core" in capsys.readouterr().err
    assert pools == [2]
    assert record_of(out)["workers"] == 2


def test_a_sweep_in_a_container_of_one_cpu_runs_one_worker(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    # a container of one CPU's time (cgroup v2, as tests/test_cores.py lays it out)
    root = tmp_path / "root"
    for name, text in {
        "proc/self/cgroup": "0::/",
        "proc/self/mountinfo": "30 23 0:27 / /sys/fs/cgroup rw - cgroup2 cgroup2 rw",
        "sys/fs/cgroup/cpu.max": "100000 100000",
    }.items():
        (root / name).parent.mkdir(parents=True, exist_ok=True)
        (root / name).write_text(text + "\n", encoding="ascii")
    monkeypatch.setattr(cores, "ROOT", root)
    out = tmp_path / "out"
    code = sweep_command(
        campaign_file(tmp_path, 4), out=out, workers=2, scheduler=None, plots=False
    )
    assert code == 0
    if len(os.sched_getaffinity(0)) > 1:  # else one worker for the affinity alone
        assert "--workers 2: 1 worker, one per core this sweep may use" in capsys.readouterr().err
    assert record_of(out)["workers"] == 1  # the runs in the sweep's own process


@pytest.mark.parametrize(
    ("call", "error", "said"),
    [
        (lambda p: run_campaign(p, workers=-1), ValueError, "workers is a positive integer"),
        (lambda p: run_campaign(p, workers=0), ValueError, "workers is a positive integer"),
        (lambda p: run_campaign(p, workers="2"), TypeError, "workers is a positive integer"),
        (lambda p: run_campaign(p, workers=True), TypeError, "workers is a positive integer"),
        (lambda p: run_campaign(p, scheduler=8786), TypeError, "scheduler is an address"),
        (lambda p: load_mission(SHORT, overrides={1: 2}), TypeError, "a path is a text"),
        (lambda p: load_mission(SHORT, overrides=[("robot.dt", 1)]), TypeError, "a mapping"),
        (lambda p: mission_from_text(None), TypeError, "takes the YAML text as a str"),
        (lambda p: mission_from_text(b"version: 1"), TypeError, "decode it"),
        (lambda p: mission_from_dict([1]), TypeError, "takes a mapping"),
        (lambda p: run_mission(load_mission(SHORT), seed=-1), ValueError, "seed is an integer"),
        (lambda p: run_mission(load_mission(SHORT), seed=2**32), ValueError, "seed is an"),
        (lambda p: run_mission(load_mission(SHORT), seed="1"), TypeError, "seed is an integer"),
    ],
)
def test_api_arguments_of_the_wrong_kind_raise_a_clear_error(
    tmp_path: Path, call: Any, error: type[Exception], said: str
) -> None:
    with pytest.raises(error, match=said):
        call(campaign_file(tmp_path, 2))
    assert not list(tmp_path.glob("runs*"))


# --- 8. campaign checks ----------------------------------------------------------------


def test_one_field_varied_under_two_paths_is_refused(tmp_path: Path) -> None:
    vary = (
        "phases[0].timeout: {uniform: [10, 20]}\n"
        "  phases.park.timeout: {uniform: [5, 30]}\n"
        "  phases.0.timeout: {choice: [12]}"
    )
    path = campaign_file(tmp_path, 2, vary=vary)
    loaded, diagnostics = check_campaign(path)
    assert loaded is None
    assert [str(d) for d in diagnostics] == [
        f"{path}:8:3: vary 'phases.park.timeout' is the same field as 'phases[0].timeout'; "
        "vary it once",
        f"{path}:9:3: vary 'phases.0.timeout' is the same field as 'phases[0].timeout'; "
        "vary it once",
    ]


def test_a_campaign_too_large_to_read_quickly_is_refused_at_once(tmp_path: Path) -> None:
    values = ", ".join(["0.01"] * 10_000)
    vary = "\n  ".join(f"sensors.noise_std.{s}: {{choice: [{values}]}}" for s in "xy") + "\n"
    path = campaign_file(tmp_path, 2, vary=vary * 8)
    assert MAX_CAMPAIGN_BYTES < 900_000 < path.stat().st_size < 1_000_000  # a mission's limit
    expected = f"{path}:1:1: campaign file too large: more than {MAX_CAMPAIGN_BYTES} bytes"
    for diagnostics in (check_campaign(path)[1], check_file(path)):
        assert [str(d)[: len(expected)] for d in diagnostics] == [expected]


def test_a_value_repeated_in_a_choice_is_checked_once(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Each value of a choice is checked against the mission, once: 10 000
    copies of two values cost two checks (two across fields, here, the field
    being one the sampling checks never read)."""
    checked: list[Any] = []
    real = LoadedCampaign.mission_across_fields

    def counted(self: LoadedCampaign, overrides: Any) -> Any:
        checked.append(overrides[0].value)
        return real(self, overrides)

    monkeypatch.setattr(LoadedCampaign, "mission_across_fields", counted)
    values = ", ".join(["0.01", "0.02"] * 5_000)
    path = campaign_file(tmp_path, 2, vary=f"sensors.noise_std.x: {{choice: [{values}]}}")
    loaded, diagnostics = check_campaign(path)
    assert loaded is not None, diagnostics
    assert checked == [0.01, 0.02]


# --- 9. housekeeping ----------------------------------------------------------------------


def test_two_default_out_sweeps_in_one_second_get_their_own_directories(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)

    class Frozen(datetime):
        @classmethod
        def now(cls, tz: Any = None) -> Frozen:
            return cls(2026, 1, 2, 3, 4, 5)

    monkeypatch.setattr(sweep, "datetime", Frozen)
    path = campaign_file(tmp_path, 2)
    for _ in range(2):
        assert sweep_command(path, out=None, workers=1, scheduler=None, plots=False) == 0
    directories = sorted(p.name for p in (tmp_path / "runs").iterdir())
    assert directories == ["headings-20260102-030405", "headings-20260102-030405-2"]
    for name in directories:
        assert record_of(tmp_path / "runs" / name)["runs"] == 2
        assert leftovers(tmp_path / "runs" / name) == []


# --- 10. bench stops on Ctrl-C -------------------------------------------------------------


@pytest.mark.parametrize(("number", "code"), [(signal.SIGINT, 130), (signal.SIGTERM, 143)])
def test_bench_stops_on_a_signal(tmp_path: Path, number: int, code: int) -> None:
    mission = tmp_path / "long.yaml"
    mission.write_text(MISSION.replace("elapsed: 2", "elapsed: 600"), encoding="utf-8")
    process = subprocess.Popen(
        [sys.executable, "-m", "wmr_mission", "bench", str(mission), "--repeat", "100"],
        cwd=tmp_path,
        env=the_tests_package(dict(os.environ)),
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert process.stderr is not None
    assert process.stderr.readline().startswith(b"timing ")  # the timed runs start
    time.sleep(0.5)
    process.send_signal(number)
    stdout, stderr = process.communicate(timeout=60)
    assert process.returncode == code, stderr
    name = "Ctrl-C" if number == signal.SIGINT else "SIGTERM"
    assert f"interrupted by {name}; nothing timed" in one_line(stderr.decode())
    assert stdout == b""


def _stop_inside_a_callback_from_c() -> None:
    """SIGINT raised inside a ctypes callback, as numba's compiler calls
    llvmlite's: Python cannot propagate it and reports it as unraisable."""
    ctypes.CFUNCTYPE(None)(lambda: os.kill(os.getpid(), signal.SIGINT))()


def test_a_stop_raised_inside_a_callback_from_c_is_owed_and_not_reported(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """Seen with a cold kernel cache under load: a stop during a compile
    printed "Exception ignored on calling ctypes callback function ...
    KeyboardInterrupt" and its traceback above the command's one line (what
    Python prints is sys.unraisablehook's: here a hook that records)."""
    from wmr_mission.stopping import STOP_SIGNALS, StopSignals, stop_owed

    reported: list[Any] = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)
    with StopSignals(STOP_SIGNALS) as stop:
        _stop_inside_a_callback_from_c()
        assert stop_owed()
        assert reported == []
        # anything else raised there is reported as before
        ctypes.CFUNCTYPE(None)(lambda: 1 / 0)()
    assert [type(r.exc_value) for r in reported] == [ZeroDivisionError]
    assert sys.unraisablehook == reported.append  # put back as it was
    assert stop.name == "Ctrl-C"


def test_sweep_and_falsify_take_a_stop_their_warm_up_could_not_raise(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    """A stop that came inside numba's compiler during the warm-up was owed
    but not raised: each stops before its first run, as a stop raised there does."""
    from wmr_mission.campaign import sweep
    from wmr_mission.campaign.falsify import command

    def stopped_while_compiling(real: Any) -> Any:
        def warm_up(*args: Any, **kwargs: Any) -> Any:
            _stop_inside_a_callback_from_c()
            return real(*args, **kwargs)

        return warm_up

    reported: list[Any] = []
    monkeypatch.setattr(sys, "unraisablehook", reported.append)
    monkeypatch.setattr(sweep, "warm_up", stopped_while_compiling(sweep.warm_up))
    monkeypatch.setattr(command, "_warm_up", stopped_while_compiling(command._warm_up))
    campaign = campaign_file(tmp_path, 4)
    code = sweep.sweep_command(
        campaign, out=tmp_path / "sweep", workers=1, scheduler=None, plots=False
    )
    assert code == 130
    code = command.falsify_command(
        campaign, budget=4, method="random", seed=0, objective=None, first=False,
        workers=1, scheduler=None, out=tmp_path / "falsify", plots=False,
    )  # fmt: skip
    assert code == 130
    assert reported == []
    err = capsys.readouterr().err
    assert err.count("interrupted by Ctrl-C before the first run; nothing was written") == 2
    assert not (tmp_path / "sweep").exists()
    assert not (tmp_path / "falsify").exists()


# --- 11. positions of characters that are no characters --------------------------------


def test_a_lone_surrogate_in_a_top_level_key_is_reported_at_its_line() -> None:
    text = 'version: 1\nname: m\n"\\ud800x": 1\nphases: []\n'
    _, diagnostics = check_mission_text(text, "m.yaml")
    assert [str(d)[:57] for d in diagnostics if "surrogate" in d.message] == [
        "m.yaml:3:1: a text holds a lone surrogate escape (\\ud800 "
    ]
