"""A stop at any moment of `run` (docs/reliability.md): SIGINT or SIGTERM sent
at any time into a 1,000 s mission at dt 0.001 exits 130 or 143, and once the
first sample is simulated its samples are kept with the outcome
``interrupted``. No stop is lost: not inside an import, not inside numba's
dispatcher, not swallowed by code that catches a KeyboardInterrupt."""

from __future__ import annotations

import json
import os
import shutil
import signal
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from conftest import the_tests_package

from wmr_mission.output.rundir import CLAIM_FILE
from wmr_mission.record import Outcome
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission, load_mission_text
from wmr_mission.stopping import STOP_SIGNALS, StopSignals

DATA = Path(__file__).resolve().parent / "data"
LONG = DATA / "long-circle.yaml"
LONG_SAMPLES = 1_000_001
CODES = {signal.SIGINT: 130, signal.SIGTERM: 143}
RUN = [sys.executable, "-m", "wmr_mission", "run", str(LONG), "--no-plots"]


@pytest.fixture(autouse=True)
def _runs_removed(tmp_path: Path) -> Iterator[None]:
    """Each run of the 1,000 s mission writes up to 200 MB: removed once checked,
    so that the 272 runs of the sweep never fill the disk."""
    yield
    shutil.rmtree(tmp_path, ignore_errors=True)


def start(run_dir: Path) -> subprocess.Popen[bytes]:
    return subprocess.Popen(
        [*RUN, "--out", str(run_dir)],
        cwd=run_dir.parent,
        env=the_tests_package(dict(os.environ)),
        stdout=subprocess.DEVNULL,
        stderr=subprocess.PIPE,
    )


def stopped_as_promised(process: subprocess.Popen[bytes], number: int, run_dir: Path) -> None:
    """Exit 128 + the signal; a run directory only with the samples simulated."""
    _, err = process.communicate(timeout=300)
    stderr = err.decode()
    code = process.returncode
    if code == -number:
        # Killed by the signal as a shell shows it (128 + the signal): either
        # before the interpreter had run a line of the command, and nothing was
        # claimed, or once the command had written and flushed everything,
        # and the run is whole.
        if run_dir.exists():
            assert not (run_dir / CLAIM_FILE).exists()
            summary = json.loads((run_dir / "summary.json").read_text())
            assert summary["samples"] == LONG_SAMPLES, stderr
            assert "expectation not met" in stderr  # the command's last word
        return
    if code == 1 and "Fatal Python error: init_import_site" in stderr:
        # A SIGINT within Python's own start, its `site` import (the
        # environment's .pth files): the interpreter's KeyboardInterrupt, its
        # exit 1, before a line of the command ran (docs/reliability.md)
        assert number == signal.SIGINT
        assert not run_dir.exists()
        return
    assert code == CODES[number], stderr
    assert "Traceback" not in stderr
    if not run_dir.exists():  # stopped before the first sample: nothing claimed
        # said once the mission is being read; before, the command had not begun
        assert stderr == "" or "interrupted before the simulation" in stderr, stderr
        return
    assert not (run_dir / CLAIM_FILE).exists()
    summary = json.loads((run_dir / "summary.json").read_text())
    rows = (run_dir / "trajectory.csv").read_text().count("\n") - 1
    assert rows == summary["samples"] > 0
    name = signal.Signals(number).name
    if summary["outcome"] == "interrupted":
        assert summary["message"].endswith(f"by {name}")
        assert f"the samples up to the stop are in {run_dir}" in stderr
    else:  # the stop came once every sample was simulated: written whole
        assert summary["samples"] == LONG_SAMPLES
        assert (
            f"{name} after the simulation ended; the run is written whole" in stderr
            or f"{name} as the run ended; its record is complete" in stderr
        )


def test_a_stop_at_any_moment_of_a_long_run_default(tmp_path: Path) -> None:
    """Two moments at once: SIGTERM during start-up, and SIGINT the instant the
    run directory appears (claimed just before the first sample). On a loaded
    machine that signal can land before the first sample, and the directory
    is released as promised: then the claimed moment is tried again."""
    early = start(tmp_path / "early")
    try:
        time.sleep(0.4)
        early.send_signal(signal.SIGTERM)
        stopped_as_promised(early, signal.SIGTERM, tmp_path / "early")
    finally:
        early.kill()
        early.communicate()  # its stderr pipe closed, whatever failed
    for attempt in range(5):
        run_dir = tmp_path / f"claimed-{attempt}"
        claimed = start(run_dir)
        try:
            # The directory is claimed once the loop is loaded: compiled first
            # where the cache lacks it (pytest naming this file: no compile
            # first), half a minute to 3 minutes by the machine's load
            # (wmr_mission.kernels.jit.ONE_VARIANT), over 120 s with both cores
            # loaded five times over.
            deadline = time.monotonic() + 300
            while not run_dir.exists() and claimed.poll() is None:
                assert time.monotonic() < deadline
                time.sleep(0.005)
            claimed.send_signal(signal.SIGINT)
            stopped_as_promised(claimed, signal.SIGINT, run_dir)
        finally:
            claimed.kill()
            claimed.communicate()
        if run_dir.exists():
            break
    summary = json.loads((run_dir / "summary.json").read_text())
    # A stop as soon as the directory exists: the samples simulated by then.
    assert summary["outcome"] == "interrupted"
    assert 0 < summary["samples"] < LONG_SAMPLES


@pytest.mark.sweep
@pytest.mark.parametrize("number", list(CODES))
@pytest.mark.parametrize("tenth", range(101))
def test_a_stop_at_any_moment_of_a_long_run(tmp_path: Path, number: int, tenth: int) -> None:
    """SIGINT or SIGTERM sent at 0.1 s steps from 0 to 10 s into the run (it
    takes 7-50 s, the machine and its load deciding)."""
    run_dir = tmp_path / "run"
    process = start(run_dir)
    time.sleep(tenth / 10)
    if process.poll() is not None:  # a fast machine: the run ended before the moment
        process.communicate()  # and its stderr pipe is closed
        assert process.returncode in (0, 1)
        summary = json.loads((run_dir / "summary.json").read_text())
        assert summary["samples"] == LONG_SAMPLES
        return
    process.send_signal(number)
    stopped_as_promised(process, number, run_dir)


@pytest.mark.sweep
@pytest.mark.parametrize("hundredth", range(30, 100))
def test_a_stop_in_the_first_second(tmp_path: Path, hundredth: int) -> None:
    """SIGTERM at 0.01 s steps through the first second, while the command
    starts: a stop the instant a handler was installed, or inside an import
    on the way to the run's own, ended 1 in 25 of these by SIGINT with
    nothing said (a KeyboardInterrupt raised there marks the interpreter to
    exit by SIGINT); held instead, it exits 143."""
    run_dir = tmp_path / "run"
    process = start(run_dir)
    time.sleep(hundredth / 100)
    process.send_signal(signal.SIGTERM)
    stopped_as_promised(process, signal.SIGTERM, run_dir)


def test_a_stop_swallowed_on_its_way_still_stops_the_run() -> None:
    """Code that catches the KeyboardInterrupt (here the progress callback, as
    a library's ``except`` turned one into an ImportError) does not lose the
    stop: the run ends ``interrupted`` at the next chunk of samples."""
    mission = load_mission(LONG)
    calls = []

    def progress(t: float, budget: float, phase: str) -> None:
        calls.append(t)
        if len(calls) == 2:
            try:
                os.kill(os.getpid(), signal.SIGTERM)
                time.sleep(0.05)  # the handler runs here
            except KeyboardInterrupt:
                pass

    with StopSignals(STOP_SIGNALS) as stop:
        result = run_mission(mission, progress=progress)
    assert stop.received == [signal.SIGTERM]
    assert result.outcome is Outcome.interrupted
    assert result.transitions[-1].condition == "interrupted"
    assert 0 < result.samples < 100_000
    assert np.all(np.isfinite(result.x))


def test_a_stop_held_before_the_loop_loads_ends_the_run_before_it_compiles(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A Ctrl-C in a run's first second (held while the command starts and
    the paths' math loads) ends the run before its loop is loaded or
    compiled, not after a compile of tens of seconds."""
    from wmr_mission.sim import runner

    text = """version: 1
name: short
robot: {dt: 0.01}
phases:
  - name: line
    track: {path: {type: line, heading: 0, speed: 0.3}}
    until: {elapsed: 1}
"""
    mission = load_mission_text(text, "m.yaml")
    calls: list[int] = []
    call = runner._Run._call

    def counted(self: Any, *args: Any) -> int:
        calls.append(args[-1])
        return call(self, *args)

    monkeypatch.setattr(runner._Run, "_call", counted)
    with StopSignals(STOP_SIGNALS, "hold"):
        os.kill(os.getpid(), signal.SIGINT)
        result = run_mission(mission)
    assert result.outcome is Outcome.interrupted
    assert result.samples == 0
    assert calls == []  # the loop never called, so never loaded nor compiled
    assert run_mission(mission).outcome is Outcome.success
    assert calls[0] == 0  # the zero-sample call that loads the loop, then the chunks


def test_a_stop_before_the_first_sample_claims_nothing() -> None:
    """``ready`` (where `run` claims its directory) comes after the loop is
    loaded: a stop held by then ends the run with no sample and no claim."""
    text = """version: 1
name: short
robot: {dt: 0.01}
phases:
  - name: park
    regulate: {target: {x: 1, y: 0, theta: 0}}
    until: {elapsed: 1}
"""
    mission = load_mission_text(text, "m.yaml")
    ready = []
    with StopSignals(STOP_SIGNALS, "hold"):
        os.kill(os.getpid(), signal.SIGINT)
        result = run_mission(mission, ready=lambda: ready.append(1))
    assert result.outcome is Outcome.interrupted
    assert result.samples == 0
    assert ready == []
    assert run_mission(mission, ready=lambda: ready.append(1)).outcome is Outcome.success
    assert ready == [1]


def test_ctrl_c_among_the_command_line_s_imports_kills_without_a_traceback() -> None:
    """The program's first module gives SIGINT its default action before the
    command line imports anything: a Ctrl-C among those imports printed their
    KeyboardInterrupt traceback (25 of 60 stops sent 5-150 ms into
    `validate`). A library user's Ctrl-C stays Python's KeyboardInterrupt."""
    from importlib.metadata import entry_points

    [script] = [e for e in entry_points(group="console_scripts") if e.name == "wmr-mission"]
    assert script.value == "wmr_mission._start:program"
    stopped = subprocess.run(
        [
            sys.executable, "-c",
            "import os, signal, time, wmr_mission._start\n"
            "os.kill(os.getpid(), signal.SIGINT)\n"
            "import wmr_mission.cli\n"
            "time.sleep(30)\n",
        ],
        capture_output=True, text=True, timeout=60, env=the_tests_package(dict(os.environ)),
    )  # fmt: skip
    assert stopped.returncode == -signal.SIGINT
    assert "Traceback" not in stopped.stderr
    library = subprocess.run(
        [
            sys.executable, "-c",
            "import signal, wmr_mission, wmr_mission.api\n"
            "assert signal.getsignal(signal.SIGINT) is signal.default_int_handler\n",
        ],
        capture_output=True, text=True, timeout=60, env=the_tests_package(dict(os.environ)),
    )  # fmt: skip
    assert library.returncode == 0, library.stderr
