"""The compiled loop: the same bytes compiled and as plain Python, however the
run is cut into chunks; Ctrl-C between chunks; a cache nobody can write."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_updates import PACED

from wmr_mission.api import mission_from_text
from wmr_mission.kernels import jit, loop
from wmr_mission.output.result import RunResult
from wmr_mission.output.rundir import write_trajectory
from wmr_mission.record import Outcome
from wmr_mission.sim import runner
from wmr_mission.sim.draws import Draws
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission

MISSIONS = Path(__file__).resolve().parent.parent / "missions"
COLUMNS = ("t", "x", "y", "theta", "x_est", "y_est", "theta_est", "v", "omega")
COLUMNS += ("x_ref", "y_ref", "constraint", "phase", "phase2_iterations")


def same_arrays(a: RunResult, b: RunResult) -> None:
    assert a.samples == b.samples
    for name in COLUMNS:
        np.testing.assert_array_equal(getattr(a, name), getattr(b, name), err_msg=name)
    assert a.transitions == b.transitions


@pytest.mark.slow
@pytest.mark.parametrize("name", ["case1", "case2", "noisy-ekf"])
def test_pure_python_fallback_writes_the_same_bytes(name: str, tmp_path: Path) -> None:
    """``WMR_MISSION_NO_JIT=1`` runs the same loop source as plain Python."""
    out = tmp_path / "fallback"
    env = {**os.environ, "WMR_MISSION_NO_JIT": "1"}
    command = [sys.executable, "-m", "wmr_mission", "run", str(MISSIONS / f"{name}.yaml")]
    done = subprocess.run(
        [*command, "--out", str(out), "--no-plots"], env=env, capture_output=True, text=True
    )
    result = run_mission(load_mission(MISSIONS / f"{name}.yaml"))
    # the same verdict (noisy-ekf's turn rate jitters: expect-failed), the same bytes
    assert done.returncode == (0 if result.outcome is Outcome.success else 1), done.stderr
    fast = write_trajectory(result, tmp_path / "f")
    assert (out / "trajectory.csv").read_bytes() == fast.read_bytes()


@pytest.mark.parametrize("name", ["noisy-observer", "fence"])
def test_chunk_boundaries_change_nothing(name: str, monkeypatch: pytest.MonkeyPatch) -> None:
    """Paths sampled ahead, noise drawn ahead and the recorder's growth join
    up exactly at chunk boundaries, even at a few samples per chunk."""
    mission = load_mission(MISSIONS / f"{name}.yaml")
    whole = run_mission(mission)
    monkeypatch.setattr(runner, "CHUNK", 7)
    monkeypatch.setattr(runner, "MAX_PRESIZED", 16)
    same_arrays(run_mission(mission), whole)


def test_a_phase_ends_at_its_bound_in_one_call_and_noise_is_drawn_as_used(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """noisy-observer: a 30 s circle (until elapsed), then a stop. One call
    loads the loop, then one call per phase: the circle exits at its bound in
    the call that reaches it. Where someone waits for the first samples (a
    progress callback, as the command line's run has) the run's first call
    is short and the next four times longer. The run is shorter than a block
    of draws, so it draws one block: the next is drawn only once the last is
    used up."""
    call = runner._Run._call
    calls = []

    def counted(self: runner._Run, *args: Any) -> int:
        calls.append(args[-1])  # stop
        return call(self, *args)

    ahead = Draws.ahead
    blocks: list[np.ndarray] = []  # held, so no two blocks share an id

    def recorded(self: Draws) -> np.ndarray:
        drawn = ahead(self)
        block = drawn if drawn.base is None else drawn.base
        if not any(block is known for known in blocks):
            blocks.append(block)
        return drawn

    monkeypatch.setattr(runner._Run, "_call", counted)
    monkeypatch.setattr(Draws, "ahead", recorded)
    mission = load_mission(MISSIONS / "noisy-observer.yaml")
    result = run_mission(mission)
    assert result.outcome is Outcome.success
    assert [t.condition for t in result.transitions] == ["elapsed", "settled"]
    assert 3000 < result.samples < Draws.BLOCK
    assert calls[:2] == [0, 3001]  # stop: up to the bound, then its exit
    assert len(calls) == 3
    assert len(blocks) == 1
    calls.clear()
    awaited = run_mission(mission, progress=lambda t, budget, phase: None)
    first = runner.FIRST_CHUNK
    assert calls[:4] == [0, first, 5 * first, 3001]
    assert len(calls) == 5
    same_arrays(awaited, result)


def test_ctrl_c_between_chunks_returns_what_was_simulated(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setattr(runner, "CHUNK", 500)
    monkeypatch.setattr(runner, "FIRST_CHUNK", 500)
    mission = load_mission(MISSIONS / "noisy-observer.yaml")
    calls = []

    def progress(t: float, budget: float, phase: str) -> None:
        calls.append(t)
        if len(calls) == 2:
            raise KeyboardInterrupt

    result = run_mission(mission, progress=progress)
    assert result.outcome is Outcome.interrupted
    # The last sample recorded, just before the progress report the stop came in.
    assert result.t[-1] == pytest.approx(calls[-1] - 0.01)
    assert result.message == f"interrupted in phase 'circle' at t = {result.t[-1]:g} s"
    assert result.samples == 2 * runner.CHUNK
    assert result.transitions[-1].condition == "interrupted"
    assert np.all(np.isfinite(result.x))
    assert np.all(np.isfinite(result.x_est))
    np.testing.assert_array_equal(result.x, run_mission(mission).x[: result.samples])


# Runs in a fresh interpreter where no directory but the temporary one can be
# written (as with a root-owned install and HOME=/nonexistent), or none at all.
UNWRITABLE = """
import sys, tempfile
allowed = sys.argv[1]
real = tempfile.TemporaryFile
def guarded(*args, dir=None, **kwargs):
    if allowed == "" or not str(dir).startswith(allowed):
        raise PermissionError(13, "Permission denied", str(dir))
    return real(*args, dir=dir, **kwargs)
tempfile.TemporaryFile = guarded
from wmr_mission.kernels import jit, model
print(jit.compiled(model.wrap_angle)(7.0))
"""


@pytest.mark.parametrize("writable", ["temporary", "nothing"])
def test_an_unwritable_cache_never_crashes(writable: str, tmp_path: Path) -> None:
    env = {key: value for key, value in os.environ.items() if key != "NUMBA_CACHE_DIR"}
    env.update({"HOME": "/nonexistent", "XDG_CACHE_HOME": "/nonexistent", "TMPDIR": str(tmp_path)})
    env.pop("WMR_MISSION_NO_JIT", None)
    allowed = str(tmp_path) if writable == "temporary" else ""
    done = subprocess.run(
        [sys.executable, "-c", textwrap.dedent(UNWRITABLE), allowed],
        env=env,
        capture_output=True,
        text=True,
    )
    assert done.returncode == 0, done.stderr
    assert float(done.stdout) == pytest.approx(7.0 - 2 * np.pi)
    notice = done.stderr.strip().splitlines()
    # where the cache is, then, for a cache there, the compile its miss starts
    assert len(notice) == (2 if writable == "temporary" else 1), done.stderr
    cached = list(tmp_path.rglob("*.nbi"))
    if writable == "temporary":
        assert str(tmp_path) in notice[0]
        assert notice[1].startswith("wmr-mission: compiling the simulation loop, not in the")
        assert cached
    else:
        assert "compiled on every run" in notice[0]
        assert not cached


class _Dispatcher:
    """A compiled loop's dispatcher, its calls counted; ``typed`` overloads
    shown (2: as if it had compiled two, so that no call can skip it)."""

    def __init__(self, dispatcher: Any, calls: list[int], typed: int) -> None:
        self.dispatcher, self.calls, self.typed = dispatcher, calls, typed

    @property
    def overloads(self) -> dict[Any, Any]:
        real = self.dispatcher.overloads
        return real if self.typed == 1 else {**real, object(): None}

    def __call__(self, *args: Any) -> int:
        self.calls.append(args[-1])  # stop
        return int(self.dispatcher(*args))


@pytest.mark.skipif(not jit.compiling(), reason="numba's dispatcher: the compiled loop only")
def test_a_compiled_run_types_its_arguments_once(monkeypatch: pytest.MonkeyPatch) -> None:
    """case2: one call loads the loop, then one per phase. Numba's dispatcher
    types the arguments of the first (some 30 us); the others, their phases
    of the same types, go straight to the compiled loop, with the same samples."""
    mission = load_mission(MISSIONS / "case2.yaml")
    compiled = jit.compiled
    runs: list[list[int]] = []

    def counting(typed: int) -> Any:
        def made(fn: Any, **options: Any) -> Any:
            if fn.__name__ != loop.run_segment.__name__:
                return compiled(fn, **options)
            runs.append([])
            return _Dispatcher(compiled(fn, **options), runs[-1], typed)

        return made

    monkeypatch.setattr(jit, "compiled", counting(1))
    fast = run_mission(mission)
    monkeypatch.setattr(jit, "compiled", counting(2))
    dispatched = run_mission(mission)
    assert [t.condition for t in fast.transitions] == ["reaches", "elapsed", "settled"]
    assert runs[0] == [0]  # the load: the phases, and the spiral's second call, skip it
    assert len(runs[1]) == 4  # every call through the dispatcher
    same_arrays(fast, dispatched)


@pytest.mark.skipif(not jit.compiling(), reason="numba's dispatcher: the compiled loop only")
@pytest.mark.parametrize(
    ("change", "typed_after"), [("look_ahead: 0.6", True), ("speed: 0.5", False)]
)
def test_a_new_controller_tuning_is_typed_by_the_dispatcher(
    change: str, typed_after: bool, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A look-ahead update hands the loop a tuning of its own from the sample
    it takes over: the calls after it go through numba's dispatcher, which
    types it, not straight to the loop typed with the mission's tuning; a
    speed update keeps the tuning, and the dispatcher typed the first call only."""
    text = PACED.format(
        path="{type: line, heading: 0, speed: 1, start: [0, 1]}",
        change=change,
        controller="controller: {tracking: {look_ahead: 0.1, time_constant: 0.5}}",
        at=0.1,
    )
    compiled = jit.compiled
    calls: list[int] = []

    def made(fn: Any, **options: Any) -> Any:
        if fn.__name__ != loop.run_segment.__name__:
            return compiled(fn, **options)
        return _Dispatcher(compiled(fn, **options), calls, 1)

    monkeypatch.setattr(jit, "compiled", made)
    result = run_mission(mission_from_text(text))
    update = next(t for t in result.transitions if t.condition == "update")
    k = round(update.time / result.dt)
    assert k == 10
    assert calls[0] == 0
    assert any(stop > k for stop in calls) is typed_after


def test_phases_of_the_same_types_are_one_type_to_the_loop() -> None:
    """What a phase is typed by: not its values; each array's dtype, dimensions,
    order, writeability; each other field's class."""
    mission = load_mission(MISSIONS / "case2.yaml")
    plan = runner.plan_mission(mission)
    phases = [runner.PhaseRun(p, plan, i) for i, p in enumerate(plan.phases)]
    entered = [phase.enter(0, np.array([0.5, 0.2, 0.1])) for phase in phases]
    types = {runner._phase_types(phase) for phase in entered}
    assert len(types) == 1
    spiral = entered[0]
    frozen = spiral.target.copy()
    frozen.flags.writeable = False
    for other in (
        spiral._replace(target=frozen),
        spiral._replace(target=spiral.target.astype(np.float32)),
        spiral._replace(near=spiral.near.reshape(1, 3)),
        spiral._replace(constraint_params=np.asfortranarray(np.zeros((2, 7)))),
        spiral._replace(settled=np.zeros(6)[::2]),
        spiral._replace(mission_time=1),
        spiral._replace(tracking=1),
    ):
        assert runner._phase_types(other) not in types
    assert runner._phase_types(spiral._replace(entry_sample=7, target=np.ones(3))) in types


def test_a_phase_whose_end_cannot_be_foreseen_starts_with_a_shorter_chunk(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """keep-out: its first leg tracks until near a point, within a timeout of
    30 s (3 000 samples). Its first call runs UNFORESEEN_CHUNK samples, not
    up to the timeout (it would sample that much path ahead), nor FIRST_CHUNK
    (each call costs its arguments and a path block); the next four times
    more, in which the leg's 796 samples end."""
    call = runner._Run._call
    calls = []

    def counted(self: runner._Run, *args: Any) -> int:
        calls.append(args[-1])  # stop
        return call(self, *args)

    monkeypatch.setattr(runner._Run, "_call", counted)
    result = run_mission(load_mission(MISSIONS / "keep-out.yaml"))
    assert result.transitions[0].condition == "near"
    first = runner.UNFORESEEN_CHUNK
    assert runner.FIRST_CHUNK < first < result.transitions[0].time / 0.01 < 5 * first < 3000
    assert calls[:3] == [0, first, 5 * first]


def test_the_kernels_given_whole_records_every_sample_are_compiled_into_the_loop() -> None:
    """docs/performance.md, "How the loop passes its records": numba passes a
    record of arrays to a function it does not inline as all their
    descriptors, copied onto the stack at every call. track_input called so
    cost noisy-ekf's tracking step 0.12 us of its 0.36 (the call's copies).
    The kernels of the step given whole records (a phase, a tuning, the
    plant, the scratch) are inlined. (record_sample, given the phase and
    the recording outside the step, inlined measured the same.)"""
    from wmr_mission.controllers import constrained_tracking, kanayama, paper, pure_pursuit
    from wmr_mission.estimators import ekf, observer

    per_sample = (
        loop.exit_condition,
        paper.next_input, paper.track_input, paper.regulate_input,
        constrained_tracking.aim_round_zones, constrained_tracking.keep_constraints,
        kanayama.next_input, pure_pursuit.next_input,
        observer.next_estimate, observer.observer_step, ekf.next_estimate, ekf.ekf_step,
    )  # fmt: skip
    assert [
        k.__qualname__ for k in per_sample if not isinstance(k, jit.Kernel) or not k.inline
    ] == []
