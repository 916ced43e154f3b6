"""Reliability under faults, signals and odd input (docs/reliability.md).

One section per class of failure: each test provokes the fault itself (a
signal sent to a subprocess, a write that raises ENOSPC, runs racing from
threads, a closed pipe, ...) and checks that nothing simulated is lost, no two
runs are mixed and nothing is half-written.
"""

from __future__ import annotations

import contextlib
import errno
import hashlib
import io
import json
import os
import pty
import select
import signal
import subprocess
import sys
import threading
import time
from datetime import datetime
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import the_tests_package
from test_output_synthetic import circle_run
from typer.testing import CliRunner

import wmr_mission.commands.run as run_command_module
import wmr_mission.sim.runner as runner_module
from wmr_mission.cli import app
from wmr_mission.commands.plot import replot_command
from wmr_mission.commands.run import run_command
from wmr_mission.output.reader import load_run
from wmr_mission.output.rundir import CLAIM_FILE, prepare_run_dir, write_run
from wmr_mission.record import Outcome
from wmr_mission.sim.plan import plan_mission
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import check_mission_text, load_mission_text

ROOT = Path(__file__).resolve().parents[1]


def mission_text(
    name: str = "short", *, elapsed: float = 0.5, target: tuple[float, float] = (1.0, 0.5)
) -> str:
    return f"""version: 1
name: {name}
robot:
  dt: 0.01
estimator:
  type: constrained-observer
phases:
  - name: park
    regulate: {{target: {{x: {target[0]}, y: {target[1]}, theta: 0}}}}
    until: {{elapsed: {elapsed}}}
"""


def write_mission(directory: Path, text: str, name: str = "m.yaml") -> Path:
    path = directory / name
    path.write_text(text, encoding="utf-8")
    return path


def cli(*arguments: str, cwd: Path, **options: Any) -> subprocess.CompletedProcess[str]:
    return subprocess.run(
        [sys.executable, "-m", "wmr_mission", *arguments],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=120,
        **options,
    )


# --- 1. two runs never share a directory ----------------------------------


def test_concurrent_runs_of_one_name_in_one_second_get_their_own_directories(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)

    class Frozen(datetime):
        @classmethod
        def now(cls, tz: Any = None) -> Frozen:
            return cls(2026, 1, 2, 3, 4, 5)

    monkeypatch.setattr(run_command_module, "datetime", Frozen)
    targets = [(1.0, 0.5), (-1.0, 0.25), (0.5, -1.0), (0.25, 1.0)]
    paths = [
        write_mission(tmp_path, mission_text("same", target=target), f"m{i}.yaml")
        for i, target in enumerate(targets)
    ]
    codes: list[int] = []
    start = threading.Barrier(len(paths))

    def one(path: Path) -> None:
        start.wait()
        codes.append(run_command(path, out=None, seed=None, plots=False, animate=False))

    threads = [threading.Thread(target=one, args=(path,)) for path in paths]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert codes == [0] * len(paths)
    directories = sorted((tmp_path / "runs").iterdir())
    assert [d.name for d in directories] == [
        "same-20260102-030405",
        "same-20260102-030405-2",
        "same-20260102-030405-3",
        "same-20260102-030405-4",
    ]
    seen = set()
    for directory in directories:
        assert not (directory / CLAIM_FILE).exists()
        manifest = json.loads((directory / "manifest.json").read_text())
        summary = json.loads((directory / "summary.json").read_text())
        target = manifest["resolved_mission"]["phases"][0]["regulate"]["target"]
        # The summary and the manifest of one directory describe one run.
        final = summary["final"]["target"]
        assert (final["x"], final["y"]) == (target["x"], target["y"])
        source = Path(manifest["mission_file"]).read_bytes()
        assert manifest["mission_sha256"] == hashlib.sha256(source).hexdigest()
        seen.add((target["x"], target["y"]))
    assert seen == set(targets)


def test_a_killed_run_s_claim_is_told_from_a_live_one(tmp_path: Path) -> None:
    """A run killed by SIGKILL leaves its claim: the next run at that --out is
    told so (the process that claimed it is gone), not that another run is
    writing there; `plot` says the directory holds nothing but the claim."""
    import socket

    from wmr_mission.output.reader import RunDirError, load_run

    gone = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)  # fmt: skip
    killed = tmp_path / "killed"
    killed.mkdir()
    (killed / CLAIM_FILE).write_text(f"{gone.stdout.strip()} {socket.gethostname()}\n")
    with pytest.raises(FileExistsError, match=r"a run killed before it finished \(process "):
        prepare_run_dir(killed)
    with pytest.raises(RunDirError, match="holds only the claim"):
        load_run(killed)
    live = tmp_path / "live"
    prepare_run_dir(live)  # this process's claim: alive
    with pytest.raises(FileExistsError, match="another run is writing into this directory"):
        prepare_run_dir(live)


def test_one_directory_is_claimed_by_exactly_one_of_racing_runs(tmp_path: Path) -> None:
    target = tmp_path / "out"
    target.mkdir()  # an existing empty directory: the harder case
    start = threading.Barrier(8)
    outcomes: list[str] = []

    def claim() -> None:
        start.wait()
        try:
            prepare_run_dir(target)
            outcomes.append("claimed")
        except FileExistsError:
            outcomes.append("refused")

    threads = [threading.Thread(target=claim) for _ in range(8)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert sorted(outcomes) == ["claimed"] + ["refused"] * 7


# --- 2. a run that stops early leaves a record ----------------------------


def _drain(terminals: dict[int, int], seen: dict[int, bytes], until: Any) -> None:
    """Read the runs' terminals (so that they never block writing) until ``until()``:
    a guard against a hang, long enough for a loop compiled cold on a loaded
    machine (a minute and more) before the first sample."""
    deadline = time.monotonic() + 300
    while not until():
        assert time.monotonic() < deadline, seen
        for terminal in select.select(list(terminals.values()), [], [], 0.1)[0]:
            number = next(n for n, t in terminals.items() if t == terminal)
            with contextlib.suppress(OSError):  # the run has closed its end
                seen[number] += os.read(terminal, 65536)


def test_a_signal_stops_the_run_and_its_samples_are_written(tmp_path: Path) -> None:
    path = write_mission(tmp_path, mission_text("long", elapsed=100_000))
    codes = {signal.SIGINT: 130, signal.SIGTERM: 143}
    processes, terminals = {}, {}
    for number in codes:
        # stderr on a terminal: the progress line says when the loop is running.
        terminals[number], child = pty.openpty()
        processes[number] = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "wmr_mission",
                "run",
                str(path),
                "--out",
                str(tmp_path / signal.Signals(number).name),
            ],
            cwd=tmp_path,
            stdout=subprocess.DEVNULL,
            stderr=child,
        )
        os.close(child)
    seen = dict.fromkeys(codes, b"")
    try:
        _drain(terminals, seen, lambda: all(b"t = " in text for text in seen.values()))
        for number, process in processes.items():
            process.send_signal(number)
        _drain(terminals, seen, lambda: all(p.poll() is not None for p in processes.values()))
        for number, terminal in terminals.items():
            while select.select([terminal], [], [], 0.2)[0]:
                try:
                    chunk = os.read(terminal, 65536)
                except OSError:  # the run has closed its end
                    break
                if not chunk:
                    break
                seen[number] += chunk
    finally:  # reaped, not left running into the next test (a ResourceWarning there)
        for number, process in processes.items():
            process.kill()
            process.wait()
            os.close(terminals[number])
    for number, code in codes.items():
        name = signal.Signals(number).name
        run_dir = tmp_path / name
        stderr = seen[number].decode()
        assert processes[number].returncode == code, stderr
        assert "Traceback" not in stderr
        assert f"by {name}; the samples up to the stop are in {run_dir}" in stderr
        summary = json.loads((run_dir / "summary.json").read_text())
        # said at once, before the record is written
        saving = f"{summary['message']}; saving its {summary['samples']:,} samples to {run_dir}"
        assert stderr.index(saving) < stderr.index("the samples up to the stop are in")
        assert summary["outcome"] == "interrupted"
        assert summary["message"].endswith(f"by {name}")
        # sent once the progress line showed: after the run's first call of the loop
        assert summary["samples"] >= runner_module.FIRST_CHUNK
        rows = (run_dir / "trajectory.csv").read_text().count("\n") - 1
        assert rows == summary["samples"]
        transitions = json.loads((run_dir / "transitions.json").read_text())
        assert transitions[-1]["condition"] == "interrupted"
        assert not (run_dir / CLAIM_FILE).exists()
        assert load_run(run_dir).outcome is Outcome.interrupted
    # `plot` draws the record of a stopped run (and says so in its outcome).
    assert replot_command(tmp_path / "SIGTERM") == 0
    assert (tmp_path / "SIGTERM" / "xy.png").stat().st_size > 0


def test_the_runner_returns_the_samples_up_to_an_interrupt(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    mission = load_mission_text(mission_text(elapsed=10), "m.yaml")
    # The compiled loop lets a stop in between chunks of samples: 100 here.
    monkeypatch.setattr(runner_module, "CHUNK", 100)
    monkeypatch.setattr(runner_module, "FIRST_CHUNK", 100)
    calls = [0]

    def progress_then_stop(t: float, budget: float, phase: str) -> None:
        calls[0] += 1
        if calls[0] == 3:
            raise KeyboardInterrupt

    result = run_mission(mission, progress=progress_then_stop)
    assert result.outcome is Outcome.interrupted
    assert result.samples == 300
    assert np.all(np.isfinite(result.x))
    assert np.all(np.diff(result.t) > 0)
    assert result.transitions[-1].condition == "interrupted"


def test_a_stop_inside_the_first_call_keeps_whole_rows(tmp_path: Path) -> None:
    """A stop in the middle of the run's first call of the loop (plain Python
    takes it at once, here at its 100th sample of 256): the rows before it are
    kept, each whole and as an unstopped run has them, and trajectory.csv holds
    exactly those lines."""
    from wmr_mission import load_mission
    from wmr_mission.controllers import paper

    calls = [0]

    def stopped(*arguments: Any) -> Any:
        calls[0] += 1
        if calls[0] == 100:
            raise KeyboardInterrupt
        return paper.track_input(*arguments)

    mission = load_mission(Path(__file__).resolve().parents[1] / "missions" / "case2.yaml")
    result = run_mission(mission, substitutes={paper.track_input: stopped})
    assert result.outcome is Outcome.interrupted
    assert 0 < result.samples == 99 < runner_module.FIRST_CHUNK
    whole = run_mission(mission)
    for name in ("t", "x", "y", "theta", "x_est", "v", "omega", "x_ref", "phase"):
        np.testing.assert_array_equal(getattr(result, name), getattr(whole, name)[:99])
    write_run(result, tmp_path / "stopped", plots=False, animate=False)
    write_run(whole, tmp_path / "whole", plots=False, animate=False)
    lines = (tmp_path / "stopped" / "trajectory.csv").read_text().splitlines()
    assert lines == (tmp_path / "whole" / "trajectory.csv").read_text().splitlines()[:100]


class _Terminal(io.StringIO):
    def isatty(self) -> bool:
        return True


def _run_with_a_stop(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, stream: io.StringIO, *, during: bool | None
) -> tuple[int, Path, Path, str]:
    """`run` of a 10 s mission with stderr on ``stream``, SIGINT sent after its
    first chunk of samples (``during``), or once its last sample is simulated,
    or never (None); the exit code, the mission, the run directory and what
    ``stream`` showed when the write of the record began."""
    from wmr_mission.output import rundir

    path = write_mission(tmp_path, mission_text("ten", elapsed=10))
    out = tmp_path / "out"

    def simulate(plan: Any, plant: Any = None, ready: Any = None) -> Any:
        def stop(t: float, budget: float, phase: str) -> None:
            os.kill(os.getpid(), signal.SIGINT)

        result = run_mission(plan, plant=plant, ready=ready, progress=stop if during else None)
        if during is False:
            os.kill(os.getpid(), signal.SIGINT)  # held: the record is written whole
        return result

    write_run = rundir.write_run
    shown_at_the_write = []

    def watched(*arguments: Any, **options: Any) -> Any:
        shown_at_the_write.append(stream.getvalue())
        return write_run(*arguments, **options)

    monkeypatch.setattr(run_command_module, "_simulate", simulate)
    monkeypatch.setattr(rundir, "write_run", watched)
    monkeypatch.setattr(sys, "stderr", stream)
    code = run_command(path, out=out, seed=None, plots=False, animate=False)
    return code, path, out, shown_at_the_write[0]


def test_a_stopped_run_says_at_once_that_it_saves_its_samples(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A long record takes seconds to judge and write (a million rows: 13 s),
    silent until it was saved: users pressed Ctrl-C again or killed the run.
    One line says, before the judge and the write begin, that the samples are
    being saved and where; a log (no terminal) gets no progress bar."""
    stream = io.StringIO()
    code, path, out, shown = _run_with_a_stop(tmp_path, monkeypatch, stream, during=True)
    assert code == 130
    summary = json.loads((out / "summary.json").read_text())
    assert summary["outcome"] == "interrupted"
    samples = summary["samples"]
    assert samples > 0
    assert shown.splitlines()[-1] == (
        f"{path}: {summary['message']}; saving its {samples:,} samples to {out} "
        "(Ctrl-C again is ignored until they are saved)"
    )
    assert stream.getvalue()[len(shown) :] == (
        f"{path}: {summary['message']}; the samples up to the stop are in {out}\n"
    )


def test_a_signal_as_the_run_ends_is_answered_as_its_record_is_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A signal once every sample is simulated: the run is written whole, and
    its write begins by saying so."""
    stream = io.StringIO()
    code, path, out, shown = _run_with_a_stop(tmp_path, monkeypatch, stream, during=False)
    assert code == 130
    assert json.loads((out / "summary.json").read_text())["samples"] == 1_001
    said = stream.getvalue()[len(shown) :].splitlines()
    assert said[0] == (
        f"{path}: SIGINT after the simulation ended; saving the whole run, 1,001 samples, "
        f"to {out} (Ctrl-C again is ignored until they are saved)"
    )
    assert said[1].startswith(f"{path}: SIGINT after the simulation ended; the run is written")


@pytest.mark.parametrize("during", [True, None])
def test_a_long_record_shows_the_rows_written_on_a_terminal_when_stopped(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, during: bool | None
) -> None:
    """On a terminal, a stopped run's record of more than a moment shows the
    rows of trajectory.csv written (here from 100 samples on); a run no signal
    came to writes its record without a word, as before."""
    monkeypatch.setattr(run_command_module, "LONG_RUN_SAMPLES", 100)
    stream = _Terminal()
    code, _, out, shown = _run_with_a_stop(tmp_path, monkeypatch, stream, during=during)
    samples = json.loads((out / "summary.json").read_text())["samples"]
    written = stream.getvalue()[len(shown) :]
    if during:
        assert code == 130
        assert "saving trajectory.csv" in written
        assert f"{samples:,} of {samples:,} rows" in written
    else:
        assert code == 0
        assert written == ""


def test_deleting_or_editing_the_mission_during_the_run_changes_nothing(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    original_text = mission_text()
    path = write_mission(tmp_path, original_text)
    run = runner_module.run_mission
    for change in ("delete", "edit"):

        def changing(*args: Any, _change: str = change, **kwargs: Any) -> Any:
            if _change == "delete":
                path.unlink()
            else:
                path.write_text(mission_text(target=(9.0, 9.0)))
            return run(*args, **kwargs)

        monkeypatch.setattr(runner_module, "run_mission", changing)
        if not path.exists():
            path.write_text(original_text)
        out = tmp_path / change
        assert run_command(path, out=out, seed=None, plots=False, animate=False) == 0
        manifest = json.loads((out / "manifest.json").read_text())
        assert manifest["mission_sha256"] == hashlib.sha256(original_text.encode()).hexdigest()
        assert manifest["resolved_mission"]["phases"][0]["regulate"]["target"]["x"] == 1.0


def test_a_mission_file_name_that_is_not_utf8_is_recorded(tmp_path: Path) -> None:
    path = tmp_path / os.fsdecode(b"m\xff.yaml")
    path.write_text(mission_text())
    out = tmp_path / "run"
    assert run_command(path, out=out, seed=None, plots=False, animate=False) == 0
    manifest = json.loads((out / "manifest.json").read_text(encoding="utf-8"))
    assert manifest["mission_file"] == str(path)
    assert (out / "summary.json").is_file()


# --- 3. the manifest hashes what ran ----------------------------------------


def test_a_mission_read_from_a_pipe_is_hashed_as_run(tmp_path: Path) -> None:
    text = mission_text()
    read_end, write_end = os.pipe()
    os.write(write_end, text.encode())
    os.close(write_end)
    out = tmp_path / "run"
    try:
        code = run_command(
            Path(f"/dev/fd/{read_end}"), out=out, seed=None, plots=False, animate=False
        )
    finally:
        os.close(read_end)
    assert code == 0
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["mission_sha256"] == hashlib.sha256(text.encode()).hexdigest()


# --- 4. YAML 1.2 numbers and booleans ----------------------------------------


def _errors(text: str) -> list[str]:
    mission, diagnostics = check_mission_text(text, "m.yaml")
    assert mission is None
    return [str(d) for d in diagnostics if d.severity == "error"]


@pytest.mark.parametrize(
    ("written", "expected"),
    [
        ("010", "m.yaml:10:22: '010' has a leading zero, which YAML 1.1 reads as octal"),
        (
            "1:30",
            "m.yaml:10:22: phases[0].until.elapsed: should be a valid number, got '1:30' "
            "(read as the text '1:30': YAML 1.2 has no base-60 numbers; write 90)",
        ),
        ("1_0", "(read as the text '1_0': write numbers without '_')"),
        ("yes", "(read as the text 'yes': in YAML 1.2, which missions use, the booleans are"),
    ],
)
def test_yaml_1_1_numbers_are_refused_saying_how_they_were_read(
    written: str, expected: str
) -> None:
    errors = _errors(mission_text().replace("elapsed: 0.5", f"elapsed: {written}"))
    assert any(expected in error for error in errors), errors


def test_yaml_1_2_numbers_and_words_read_as_yaml_1_2() -> None:
    text = (
        mission_text().replace("elapsed: 0.5", "elapsed: 0x10").replace("name: park", "name: off")
    )
    text = text.replace("x: 1.0", "x: 1e0").replace("y: 0.5", "y: 0o7")
    mission = load_mission_text(text, "m.yaml")
    assert mission.phases[0].name == "off"
    assert mission.phases[0].until.elapsed == 16
    target = mission.phases[0].regulate.target  # type: ignore[union-attr]
    assert (target.x, target.y) == (1.0, 7.0)
    bad = _errors(mission_text() + "controller: {regulation: {reverse: off}}\n")
    assert any("11:36: controller.regulation.reverse: should be a valid boolean" in e for e in bad)


# --- 5. plausible sizes; the kernels never raise ----------------------------


@pytest.mark.parametrize(
    ("region", "where"),
    [
        ("{type: ellipse, center: [1, 1], semi_axes: [1e-200, 1]}", "semi_axes[0]"),
        ("{type: circle, center: [1, 1], radius: 1e-300}", "radius"),
    ],
)
def test_implausibly_small_sizes_are_refused_with_a_position(region: str, where: str) -> None:
    text = mission_text() + f"regions:\n  dot: {region}\n"
    errors = _errors(text)
    assert any(f"regions.dot.{where}: " in e and "implausibly small" in e for e in errors), errors
    ekf = mission_text().replace(
        "type: constrained-observer",
        "type: ekf\n  measurement_std: {x: 1e-300}",
    )
    message = "7:24: estimator.measurement_std.x: 1e-300 is implausibly small"
    assert any(message in e for e in _errors(ekf))


_TINY_REGION_RUN = """
import dataclasses, hashlib, sys
import numpy as np
from wmr_mission.sim.plan import plan_mission
from wmr_mission.output.rundir import trajectory_csv_text
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission_text
mission = plan_mission(load_mission_text(sys.stdin.read(), "m.yaml"))
phase = mission.phases[0]
kinds, params = phase.constraint_rows
params = params.copy()
params[:, 2:4] = 1e-200  # semi-axes far below what validate allows
phase = dataclasses.replace(phase, constraint_rows=(kinds, params))
result = run_mission(dataclasses.replace(mission, phases=(phase,)))
print(result.outcome.value, hashlib.sha256(trajectory_csv_text(result).encode()).hexdigest())
"""


def test_kernels_never_raise_and_both_builds_agree(tmp_path: Path) -> None:
    text = mission_text() + (
        "regions:\n  dot: {type: ellipse, center: [1.0, 0.3], semi_axes: [0.3, 0.3]}\n"
    )
    text = text.replace("    until:", "    constraints: [{stay_outside: dot}]\n    until:")
    text = text.replace("x: 1.0, y: 0.5", "x: 2.0, y: 0.5")
    outputs = []
    for no_jit in ("0", "1"):
        env = the_tests_package({**os.environ, "WMR_MISSION_NO_JIT": no_jit})
        done = subprocess.run(
            [sys.executable, "-c", _TINY_REGION_RUN],
            cwd=tmp_path,
            input=text,
            capture_output=True,
            text=True,
            env=env,
            timeout=120,
        )
        assert done.returncode == 0, done.stderr
        assert "Error" not in done.stderr
        outputs.append(done.stdout)
    assert outputs[0] == outputs[1]


# --- 6. the runaway threshold follows the mission's scale ---------------------


def test_a_mission_in_map_coordinates_runs_like_one_at_the_origin() -> None:
    def placed(x: float, y: float) -> str:
        return (
            mission_text(elapsed=2, target=(x + 1.0, y + 0.5))
            .replace("  dt: 0.01", f"  dt: 0.01\n  initial_state: {{x: {x}, y: {y}}}")
            .replace(
                "type: constrained-observer",
                f"type: constrained-observer\n  initial_estimate: {{x: {x}, y: {y}}}",
            )
        )

    compiled = plan_mission(load_mission_text(placed(500_000.0, 5_000_000.0), "m.yaml"))
    assert compiled.plant.runaway_position > 5e6
    far = run_mission(compiled)
    near = run_mission(load_mission_text(placed(0.0, 0.0), "m.yaml"))
    assert far.outcome is Outcome.success, far.message
    assert far.samples == near.samples
    assert np.allclose(far.x - 500_000, near.x, atol=1e-6)
    assert np.allclose(far.y - 5_000_000, near.y, atol=1e-6)


# --- 7. I/O errors are messages naming the path --------------------------------


def test_a_full_disk_while_writing_is_a_message_and_keeps_what_was_written(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_mission(tmp_path, mission_text())
    real = json.dump

    def full(value: Any, out: Any, **options: Any) -> None:
        if ".manifest." in out.name:  # JSON files are streamed into their temporary file
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC), out.name)
        real(value, out, **options)

    monkeypatch.setattr(json, "dump", full)
    out = tmp_path / "run"
    assert run_command(path, out=out, seed=None, plots=False, animate=False) == 2
    stderr = capsys.readouterr().err
    assert f"{out / 'manifest.json'}: cannot write: No space left on device" in stderr
    assert sorted(p.name for p in out.iterdir()) == [CLAIM_FILE, "trajectory.csv"]


@pytest.mark.parametrize("fault", ["read-only", "dangling-symlink"])
def test_an_unusable_out_is_reported_before_simulating(
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    fault: str,
) -> None:
    path = write_mission(tmp_path, mission_text())
    out = tmp_path / "out"
    if fault == "dangling-symlink":
        out.symlink_to(tmp_path / "nowhere" / "run")
        expected = f"{out}: is a symbolic link to {tmp_path / 'nowhere' / 'run'}, which does not"
    else:
        out.mkdir()
        real_open = os.open

        def read_only(file: Any, flags: int, *args: Any, **kwargs: Any) -> int:
            if Path(file).parent == out and flags & os.O_CREAT:
                raise OSError(errno.EROFS, os.strerror(errno.EROFS), str(file))
            return real_open(file, flags, *args, **kwargs)

        monkeypatch.setattr(os, "open", read_only)
        expected = f"{out}: Read-only file system"

    def no_simulation(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("simulated although the run directory is unusable")

    # The directory is claimed once the loop is loaded, before its first sample.
    monkeypatch.setattr(runner_module._Run, "_chunks", no_simulation)
    assert run_command(path, out=out, seed=None, plots=False, animate=False) == 2
    assert expected in capsys.readouterr().err


def test_running_out_of_memory_is_a_message_and_leaves_no_directory(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_mission(tmp_path, mission_text())

    def no_memory(*args: Any, **kwargs: Any) -> Any:
        raise MemoryError

    monkeypatch.setattr(runner_module, "run_mission", no_memory)
    out = tmp_path / "run"
    assert run_command(path, out=out, seed=None, plots=False, animate=False) == 1
    assert "not enough memory" in capsys.readouterr().err
    assert not out.exists()


# --- 8. CLI arguments are checked ---------------------------------------------


@pytest.mark.parametrize(
    "arguments",
    [
        ["run", "M", "--seed", "-1"],
        ["run", "M", "--seed", str(2**32)],
        ["run", "M", "--seed", str(2**70)],
        ["bench", "M", "--repeat", "1000000"],
    ],
)
def test_out_of_range_arguments_are_usage_errors(tmp_path: Path, arguments: list[str]) -> None:
    path = write_mission(tmp_path, mission_text())
    arguments = [str(path) if a == "M" else a for a in arguments]
    result = CliRunner().invoke(app, arguments)
    assert result.exit_code == 2, result.output
    assert not (tmp_path / "runs").exists()


def test_bench_of_a_mission_that_ends_at_once_says_so(tmp_path: Path) -> None:
    text = mission_text().replace("until: {elapsed: 0.5}", "until: {mission_time: 0.001}")
    path = write_mission(tmp_path, text)
    result = CliRunner().invoke(app, ["bench", str(path), "--repeat", "1"])
    assert result.exit_code == 1
    assert result.exception is None or isinstance(result.exception, SystemExit)
    assert "nothing to time" in result.output


# --- 9. plot checks what it reads -----------------------------------------------


def _damaged_run(tmp_path: Path, file: str, damage: Any) -> Path:
    write_run(
        circle_run(1001),
        tmp_path,
        mission_sha256="ab" * 32,
        resolved_mission={},
        mission_file="m.yaml",
        plots=False,
        animate=False,
    )
    path = tmp_path / file
    if file.endswith(".json"):
        record = json.loads(path.read_text())
        damage(record)
        path.write_text(json.dumps(record))
    else:
        path.write_text(damage(path.read_text()))
    return tmp_path


def _cut(text: str) -> str:
    return "".join(text.splitlines(keepends=True)[:501])


@pytest.mark.parametrize(
    ("file", "damage", "message"),
    [
        (
            "manifest.json",
            lambda m: m["run"]["regions"]["pond"].pop("radius"),
            "manifest.json: run.regions.pond.radius: Field required",
        ),
        (
            "manifest.json",
            lambda m: m["run"]["regions"].update(pond="a pond"),
            "manifest.json: run.regions.pond: ",
        ),
        (
            "manifest.json",
            lambda m: m["run"].update(mission_name="$\\frac{1$"),
            "manifest.json: run: 'mission_name' '$\\\\frac{1$' is not a name a mission allows",
        ),
        ("trajectory.csv", _cut, "trajectory.csv: 500 rows, but summary.json says 1001 samples"),
        (
            "trajectory.csv",
            lambda text: text.replace(",3\n", ",99999999999999999999\n", 1),
            "trajectory.csv:2: phase2_iterations is out of range 0..1000",
        ),
    ],
)
def test_plot_reports_a_damaged_run_directory(
    tmp_path: Path,
    capsys: pytest.CaptureFixture[str],
    file: str,
    damage: Any,
    message: str,
) -> None:
    run_dir = _damaged_run(tmp_path, file, damage)
    assert replot_command(run_dir) == 1
    stderr = capsys.readouterr().err
    assert stderr == f"{run_dir}: {message}\n" or (message in stderr and stderr.count("\n") == 1)
    assert not (run_dir / "xy.png").exists()


def _row_too_long(text: str) -> str:
    """Row 5 a field longer than Python's CSV reader takes (131,072 characters)."""
    lines = text.splitlines(keepends=True)
    lines[4] = "1," + "9" * 200_000 + "\n"
    return "".join(lines)


@pytest.mark.parametrize(
    ("file", "damage", "message"),
    [
        (
            "trajectory.csv",
            _row_too_long,
            "trajectory.csv:5: not a row of CSV: field larger than field limit (131072)",
        ),
        (
            "summary.json",
            lambda _: "[" * 100_000 + "]" * 100_000,
            "summary.json: nested too deeply to read (arrays and objects inside one another)",
        ),
    ],
)
def test_a_record_no_reader_takes_is_one_line_for_plot_view_and_export(
    tmp_path: Path, capsys: pytest.CaptureFixture[str], file: str, damage: Any, message: str
) -> None:
    """What Python's readers refuse (not an error of the format: a limit of the
    reader, nor a RecursionError of the JSON parser) is the file's problem too,
    never a traceback nor "please report it"."""
    from wmr_mission.review.export import export_command
    from wmr_mission.review.view import view_command

    run_dir = tmp_path / "run"
    run_dir.mkdir()
    path = run_dir / file
    write_run(circle_run(201), run_dir, plots=False, animate=False)
    path.write_text(damage(path.read_text(encoding="utf-8")), encoding="utf-8")
    for command in (
        lambda: replot_command(run_dir),
        lambda: view_command(run_dir),
        lambda: export_command(run_dir, "mcap-json"),
        lambda: export_command(run_dir, "parquet"),
    ):
        assert command() == 1
        assert capsys.readouterr().err == f"{run_dir}: {message}\n"
    assert sorted(p.name for p in run_dir.iterdir()) == [
        "manifest.json",
        "summary.json",
        "trajectory.csv",
        "transitions.json",
    ]


def test_names_with_dollars_are_drawn_as_typed(tmp_path: Path) -> None:
    result = circle_run(200)
    result.phases[0] = type(result.phases[0])("$x", "track")
    result.mission_name = "$\\frac{1$"
    from wmr_mission.output.figures import draw_all

    assert all(path.stat().st_size > 0 for path in draw_all(result, tmp_path))


# --- 10. streams and pipes --------------------------------------------------------


def test_validate_of_a_fifo_without_writer_returns_at_once(tmp_path: Path) -> None:
    fifo = tmp_path / "fifo.yaml"
    os.mkfifo(fifo)
    done = cli("validate", str(fifo), cwd=tmp_path)
    assert done.returncode == 1
    assert f"{fifo}:1:1: the file is empty" in done.stdout


def test_validate_into_a_closed_pipe_exits_with_its_own_code_quietly(tmp_path: Path) -> None:
    # More than a pipe's buffer of output, so that writes meet the closed pipe.
    missions = [str(ROOT / "tests" / "data" / "missions" / "valid" / "minimal.yaml")] * 400
    process = subprocess.Popen(
        [sys.executable, "-m", "wmr_mission", "validate", *missions],
        cwd=tmp_path,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    assert process.stdout is not None
    assert process.stderr is not None
    process.stdout.readline()
    process.stdout.close()  # `| head -1`
    stderr = process.stderr.read().decode()
    process.stderr.close()
    assert process.wait(timeout=120) == 0, stderr
    assert stderr == ""


_WARNING_COMMAND = """
import sys, warnings
from wmr_mission import cli

@cli.app.command("warn")
def warn() -> None:
    warnings.warn("overflow encountered in scalar multiply", RuntimeWarning)

sys.argv = ["wmr-mission", "warn"]
cli.main()
"""


def test_library_warnings_do_not_reach_the_user(tmp_path: Path) -> None:
    done = subprocess.run(
        [sys.executable, "-c", _WARNING_COMMAND], capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0
    assert "Warning" not in done.stderr


# --- 11. constraints no point can meet --------------------------------------------


def test_contradictory_constraints_are_an_error() -> None:
    text = mission_text() + (
        "  - name: fenced\n"
        "    regulate: {target: {x: 0.5, y: 0, theta: 0}}\n"
        "    constraints: [{stay_inside: small}, {stay_outside: big}]\n"
        "    until: {elapsed: 1}\n"
        "regions:\n"
        "  small: {type: circle, radius: 1}\n"
        "  big: {type: circle, radius: 2}\n"
    )
    errors = _errors(text)
    assert (
        "m.yaml:13:18: phase 'fenced' has no point that meets all its constraints: the regions "
        "it must stay outside (big) cover every point inside small"
    ) in errors
    apart = text.replace("big: {type: circle, radius: 2}", "big: {type: circle, radius: 0.5}")
    apart = apart.replace("{stay_outside: big}", "{stay_inside: big}")
    apart = apart.replace(
        "small: {type: circle, radius: 1}", "small: {type: circle, center: [5, 0], radius: 1}"
    )
    message = "the regions it must stay inside (small, big) do not overlap"
    assert any(message in e for e in _errors(apart))
    # A thin but real feasible set is not refused: a ring 1 cm wide.
    ring = text.replace("radius: 2}", "radius: 0.99}")
    mission, diagnostics = check_mission_text(ring, "m.yaml")
    assert mission is not None, diagnostics


# --- 7, continued: free space is checked before simulating ------------------------


def test_too_little_free_space_is_said_before_simulating(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, capsys: pytest.CaptureFixture[str]
) -> None:
    path = write_mission(tmp_path, mission_text())
    usage = run_command_module.shutil.disk_usage(tmp_path)
    monkeypatch.setattr(
        run_command_module.shutil, "disk_usage", lambda _: usage._replace(free=1_000_000)
    )
    out = tmp_path / "run"
    assert run_command(path, out=out, seed=None, plots=False, animate=False) == 0
    stderr = capsys.readouterr().err
    assert f"{out}: warning: 1 MB free; this run may write up to 4.01 MB" in stderr


def test_a_fault_inside_the_loop_ends_the_run_failed_and_keeps_its_samples() -> None:
    """An exception out of the loop's own code (a bug) is no traceback: the run
    ends `failed`, naming the sample, and the samples before it are kept."""
    from wmr_mission import load_mission
    from wmr_mission.controllers import paper
    from wmr_mission.sim.runner import run_mission

    calls = [0]

    def failing(*arguments: Any) -> Any:
        calls[0] += 1
        if calls[0] == 300:
            raise ZeroDivisionError("a fault of our own")
        return paper.track_input(*arguments)

    mission = load_mission(Path(__file__).resolve().parents[1] / "missions" / "case2.yaml")
    result = run_mission(mission, substitutes={paper.track_input: failing})
    assert result.outcome.value == "error"  # a bug of ours, told from a plug-in's failure
    assert result.message.startswith("internal error at sample 299 (t = 2.99 s): ZeroDivisionError")
    assert result.message.endswith("please report it")
    assert result.samples == 299
    assert result.transitions[-1].condition == "error"


def test_a_claim_that_cannot_be_written_is_not_left_behind(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A disk full as the claim is written: the error is said, and no empty
    claim refuses every later run at that --out."""
    from wmr_mission.output import rundir

    real = os.write

    def full(descriptor: int, data: bytes) -> int:
        raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))

    monkeypatch.setattr(rundir.os, "write", full)
    with pytest.raises(OSError, match="No space left on device"):
        prepare_run_dir(tmp_path / "out")
    monkeypatch.setattr(rundir.os, "write", real)
    assert not (tmp_path / "out" / CLAIM_FILE).exists()
    assert prepare_run_dir(tmp_path / "out") == tmp_path / "out"


def test_a_parent_another_run_makes_meanwhile_is_taken(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Two runs in one second make `runs/` together: the one that found it
    missing, then there, took it for a file (runs is not a directory, exit 2;
    seen once in the four concurrent runs above)."""
    from wmr_mission.output import rundir

    parent = tmp_path / "runs"
    exists = Path.exists

    def made_meanwhile(self: Path, *args: Any, **kwargs: Any) -> bool:
        if self == parent and not exists(parent):
            parent.mkdir()  # by the other run, between this one's two looks
        return exists(self, *args, **kwargs)

    monkeypatch.setattr(Path, "exists", made_meanwhile)
    claimed = rundir.prepare_run_dir(parent / "same-20260102-030405")
    assert claimed == parent / "same-20260102-030405"
    assert claimed.is_dir()
