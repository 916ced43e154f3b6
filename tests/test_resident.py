"""Memory a long run gives back: the compiler's code once the loop is loaded
(wmr_mission.kernels.resident), the heap's free pages around the figures."""

from __future__ import annotations

import gc
import subprocess
import sys
import textwrap
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from test_output_costs import _laps

import wmr_mission.output.figures as plots_module
import wmr_mission.sim.runner as runner_module
import wmr_mission.verdicts.signals as signals_module
from wmr_mission.api import load_mission
from wmr_mission.kernels import jit
from wmr_mission.kernels.resident import read_only_spans
from wmr_mission.sim.plan import sample_budget
from wmr_mission.sim.runner import run_mission

SMAPS = """\
7f0000000000-7f0000001000 r--p 00000000 fe:00 11 /venv/llvmlite/binding/libllvmlite.so
Size:                  4 kB
Rss:                   4 kB
Anonymous:             0 kB
7f0000001000-7f0000009000 r-xp 00001000 fe:00 11 /venv/llvmlite/binding/libllvmlite.so
Size:                 32 kB
Rss:                  32 kB
Anonymous:             0 kB
7f0000009000-7f000000a000 r--p 00009000 fe:00 11 /venv/llvmlite/binding/libllvmlite.so
Size:                  4 kB
Rss:                   4 kB
Anonymous:             4 kB
7f000000a000-7f000000b000 rw-p 0000a000 fe:00 11 /venv/llvmlite/binding/libllvmlite.so
Size:                  4 kB
Rss:                   4 kB
Anonymous:             0 kB
7f000000b000-7f000000c000 r-xp 00000000 fe:00 12 /usr/lib/libc.so.6
Size:                  4 kB
Rss:                   4 kB
Anonymous:             0 kB
7f000000c000-7f000000d000 r--p 00000000 00:00 0
Size:                  4 kB
Anonymous:             0 kB
"""


def test_only_the_compilers_unwritten_mappings_are_given_back() -> None:
    """Its code and read-only data go; a mapping holding a page of its own
    (relocated data), a writable one, another library's, and anonymous
    memory stay."""
    spans = read_only_spans(SMAPS.splitlines(), "/libllvmlite")
    assert spans == [(0x7F0000000000, 0x7F0000001000), (0x7F0000001000, 0x7F0000009000)]


@pytest.mark.skipif(not sys.platform.startswith("linux"), reason="/proc/self/smaps is Linux's")
def test_a_librarys_pages_given_back_leave_the_process_and_come_back_on_use() -> None:
    """In a process of its own: numpy's compiled code leaves the resident set,
    and numpy computes as before, its pages read back from the file."""
    code = textwrap.dedent(
        """
        import numpy as np
        from wmr_mission.kernels.resident import give_back_compiler_pages

        def resident(library):
            total, mapped = 0, False
            for line in open("/proc/self/smaps"):
                fields = line.split()
                if not fields[0].endswith(":"):
                    mapped = len(fields) >= 6 and library in fields[5]
                elif fields[0] == "Rss:" and mapped:
                    total += int(fields[1])
            return total

        library = "_multiarray_umath"
        before = float(np.linalg.norm(np.arange(1000.0).reshape(10, 100) @ np.ones(100)))
        held = resident(library)
        given = give_back_compiler_pages(library)
        left = resident(library)
        after = float(np.linalg.norm(np.arange(1000.0).reshape(10, 100) @ np.ones(100)))
        print(held, given, left, before == after)
        """
    )
    done = subprocess.run(
        [sys.executable, "-c", code], check=True, capture_output=True, text=True, timeout=60
    )
    held, given, left, same = done.stdout.split()
    assert int(held) > 1000  # kB
    assert int(given) > 1000 * 1024
    assert int(left) < int(held) // 4  # what is left: its relocated data
    assert same == "True"


RUN = """\
version: 1
name: short
robot: {dt: 0.01, limits: {v: 10, omega: 20}}
estimator: {type: constrained-observer}
phases:
  - name: lap
    track: {path: {type: circle, center: [0, 1], radius: 1, angular_rate: 1}}
    until: {elapsed: 0.5}
"""


@pytest.mark.parametrize(("compiled", "beyond"), [(False, 0), (True, 0), (True, 1)])
def test_a_long_compiled_run_gives_the_compilers_pages_back_before_its_first_sample(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch, compiled: bool, beyond: int
) -> None:
    """Once the compiled loop is loaded (numba loaded), before the directory is
    claimed, and after numba's reference-counting runtime is made: the claim's
    first sample does not wait for it. A plain Python run
    has no compiler to give back; a short run keeps it (its sample budget
    under LONG_RUN: reading the mappings would not pay)."""
    monkeypatch.setenv(jit.NO_JIT, "1")  # the loop as plain Python: numba as if loaded
    monkeypatch.setattr(runner_module.jit, "loaded", lambda: compiled)
    path = tmp_path / "short.yaml"
    path.write_text(RUN)
    mission = load_mission(path)
    monkeypatch.setattr(runner_module, "LONG_RUN", sample_budget(mission) + beyond)
    calls: list[str] = []
    monkeypatch.setattr(runner_module, "give_back_compiler_pages", lambda: calls.append("given"))
    monkeypatch.setattr(runner_module.jit, "make_runtime", lambda: calls.append("runtime"))
    result = run_mission(mission, ready=lambda: calls.append("ready"))
    assert result.samples == 51
    # The reference-counting runtime made first: making it runs LLVM, whose
    # pages the judge's passes would otherwise read back (37 MB of the 1-hour run).
    expected = ["runtime", "given", "ready"] if compiled and not beyond else ["ready"]
    assert calls == expected


def _drawing_steps(
    monkeypatch: pytest.MonkeyPatch, tmp_path: Path, long_run: int, formats: tuple[str, ...]
) -> list[str]:
    """What draw_all does, in order: signals computed, heap given back, figures made."""
    steps: list[str] = []
    real_signals, real_figure = signals_module.run_signals, plots_module.new_figure

    def signals(*args: Any) -> Any:
        steps.append("signals")
        return real_signals(*args)

    def figure(*args: Any) -> Any:
        steps.append("figure")
        return real_figure(*args)

    monkeypatch.setattr(signals_module, "run_signals", signals)
    monkeypatch.setattr(plots_module, "new_figure", figure)

    def given() -> None:
        steps.append("given" if gc.get_freeze_count() == 0 else "given, the old objects left")

    monkeypatch.setattr(plots_module, "give_back_freed_heap", given)
    monkeypatch.setattr(
        plots_module, "give_back_compiler_pages", lambda: steps.append("compiler's given")
    )
    monkeypatch.setattr(plots_module, "LONG_RUN", long_run)
    written = plots_module.draw_all(_laps(1000), tmp_path, formats)
    assert len(written) == len(plots_module.FIGURE_NAMES) * len(formats)
    return steps


def test_a_long_runs_figures_compute_the_signals_first_and_give_the_heap_back(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The verdicts' signals once, before any figure (matplotlib not loaded
    with their temporaries resident), the heap's free pages given back before
    them (all the garbage collected: the judge's) and before each figure (the
    young garbage: the figure before's), and the compiler's pages the judge's
    passes read back in; a short run's figures spend no collection."""
    figures = len(plots_module.FIGURE_NAMES)
    steps = _drawing_steps(monkeypatch, tmp_path, 1000, ("png", "svg"))
    each = ["given, the old objects left", "figure"]
    assert steps == ["given", "compiler's given", "signals", *(each * figures * 2)]
    assert gc.get_freeze_count() == 0
    monkeypatch.undo()
    steps = _drawing_steps(monkeypatch, tmp_path, 1001, ("png",))
    assert steps == ["signals", *(["figure"] * figures)]


def test_verdicts_png_keeps_the_signals_thinned_not_at_every_sample() -> None:
    """Its lines at the thinned samples, each with the range of all its
    samples: a long run's signals at every sample are freed before the
    figure is drawn (and before matplotlib is loaded)."""
    run = _laps(60_000)
    lines = plots_module.verdict_lines(run)
    every = signals_module.run_signals(run)
    kept = plots_module.thin(0, run.samples).size
    assert kept < 21_000
    assert lines.thinned.keys() == every.lines.keys()
    assert lines.thinned
    for panel, drawn in every.lines.items():
        for name, values in drawn.items():
            assert lines.thinned[panel][name].shape == (kept,)
            finite = values[np.isfinite(values)]
            assert lines.ranges[panel][name] == (float(finite.min()), float(finite.max()))
