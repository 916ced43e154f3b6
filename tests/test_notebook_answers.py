"""The notebook's answers: one notice before a foreground compile, a short
RunResult repr, the campaign's rows of one type."""

from __future__ import annotations

from pathlib import Path

import pytest

from wmr_mission import api
from wmr_mission.commands import compile as compile_loop
from wmr_mission.kernels import cache, jit
from wmr_mission.output.result import RunResult
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.loader import load_mission

MISSIONS = Path(__file__).resolve().parent.parent / "missions"


def test_one_notice_before_a_foreground_compile(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    monkeypatch.setattr(jit, "loaded", lambda: False)
    monkeypatch.setattr(jit, "compiling", lambda: True)
    monkeypatch.setattr(cache, "cache_directory", lambda: tmp_path)  # no ready marker in it
    monkeypatch.setattr(api, "_noticed", [])
    api._compile_notice()
    api._compile_notice()
    err = capsys.readouterr().err
    assert err.count("\n") == 1
    assert err.startswith("wmr-mission: loading the simulation loop, compiled first")
    # a cache marked ready, or a loop loaded already: nothing to say
    (tmp_path / compile_loop.READY).write_text(compile_loop.ready_stamp())
    monkeypatch.setattr(api, "_noticed", [])
    api._compile_notice()
    monkeypatch.setattr(jit, "loaded", lambda: True)
    api._compile_notice()
    assert capsys.readouterr().err == ""


def test_a_run_result_repr_is_one_short_line() -> None:
    result: RunResult = run_mission(load_mission(MISSIONS / "case1.yaml"))
    text = repr(result)
    assert text == (
        f"RunResult(mission='case1', outcome='success', samples={result.samples}, "
        f"duration={float(result.t[-1] - result.t[0]):.6g} s, phases=4, seed=0)"
    )
    assert len(text) < 120
