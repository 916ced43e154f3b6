"""`type: python`: a controller or an estimator from the user's own module.

Plain Python and numba ``@jitclass`` plug-ins give the same trajectories; an
estimator plug-in sees each measurement or None; each error class ends as the
issue says: an entry that does not load at its FILE:LINE:COL (exit 1),
validate never importing it unless --check-entries, and a step that raises or
returns the wrong shape ending the run failed with its message and sample."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np
import plugin_examples
import pytest
from typer.testing import CliRunner

from wmr_mission.api import MissionError, mission_from_text, run_mission
from wmr_mission.cli import app
from wmr_mission.kernels.model import step, wrap_angle

MISSION = """\
version: 1
name: plugged
robot: {{dt: 0.01, initial_state: {{x: 0.1, y: -0.1, theta: 0.5}}, limits: {{v: 5, omega: 10}}}}
sensors: {{noise_std: {{x: 0.005, y: 0.005, theta: 0.005}}, period: 0.02, seed: 3}}
estimator: {estimator}
controller:
  type: python
  entry: "plugin_examples:{controller}"
  params: {{x: 10, y: 64, theta: 16}}
phases:
  - name: eight
    track: {{path: {{type: expression, x: "3*sin(0.5*t)", y: "3*sin(0.5*t)*cos(0.5*t)"}}}}
    until: {{elapsed: 3}}
  - name: park
    regulate: {{target: {{x: 0.5, y: 0, theta: 0}}}}
    until: {{elapsed: 1}}
"""
OBSERVER = "{type: constrained-observer}"


def mission(controller: str, estimator: str = OBSERVER) -> str:
    return MISSION.format(controller=controller, estimator=estimator)


COLUMNS = ("x", "y", "theta", "x_est", "y_est", "theta_est", "v", "omega", "phase")


def test_a_plain_and_a_compiled_controller_give_the_same_trajectory() -> None:
    plain = run_mission(mission_from_text(mission("watched")))
    compiled = run_mission(mission_from_text(mission("compiled")))
    assert plain.outcome.value == compiled.outcome.value == "success"
    for column in COLUMNS:
        assert getattr(plain, column).tobytes() == getattr(compiled, column).tobytes(), column
    # It tracked: the law works through the plug-in's reference.
    assert plain.summary()["phases"][0]["tracking_error"]["rms"] < 0.01

    # What the plug-in was given, sample by sample: t_k, the estimate x_{k|k}
    # and the reference (the path's point and motion; the target at rest).
    seen = plugin_examples.SEEN
    assert len(seen) == plain.samples - 1  # each step; the closing row has none
    for k, (t, estimate, reference) in enumerate(seen):
        assert t == k * 0.01
        assert estimate == (plain.x_est[k], plain.y_est[k], plain.theta_est[k])
        tracking, x, y, theta, v, omega = reference
        assert tracking == (plain.phase[k] == 0)
        if tracking:
            assert (x, y) == (plain.x_ref[k], plain.y_ref[k])
            local = k * 0.01
            speed = math.hypot(1.5 * math.cos(0.5 * local), 1.5 * math.cos(local))
            assert v == pytest.approx(speed, rel=1e-2)
        else:
            assert (x, y, theta, v, omega) == (0.5, 0.0, 0.0, 0.0, 0.0)
    # The limits apply to the plug-in's input.
    assert np.all(np.abs(plain.omega) <= 10.0)


def test_an_estimator_plug_in_gets_each_measurement_or_none() -> None:
    text = mission("plain", '{type: python, entry: "plugin_examples:blend", params: {blend: 0.2}}')
    result = run_mission(mission_from_text(text))
    assert result.outcome.value == "success"
    calls = plugin_examples.CALLS
    assert len(calls) == result.samples - 1
    measured = ~np.isnan(result.x_meas)
    for k in range(1, result.samples):
        had, applied = calls[k - 1]
        assert had == measured[k], k  # None between measurements (period 0.02)
        assert applied == (result.v[k - 1], result.omega[k - 1])
        predicted = step(
            result.x_est[k - 1], result.y_est[k - 1], result.theta_est[k - 1],
            result.v[k - 1], result.omega[k - 1], 0.01,
        )  # fmt: skip
        estimate = np.array([result.x_est[k], result.y_est[k], result.theta_est[k]])
        if not had:
            np.testing.assert_allclose(estimate, predicted, rtol=0, atol=1e-12)
            continue
        wanted = [
            predicted[0] + 0.2 * (result.x_meas[k] - predicted[0]),
            predicted[1] + 0.2 * (result.y_meas[k] - predicted[1]),
            predicted[2] + 0.2 * wrap_angle(result.theta_meas[k] - predicted[2]),
        ]
        np.testing.assert_allclose(estimate, wanted, rtol=0, atol=1e-12)
    assert measured[1:].sum() > 100


def test_a_plain_and_a_compiled_estimator_give_the_same_trajectory() -> None:
    """The estimator's step in the compiled loop: None between measurements
    and each measurement typed as numba compiles them."""
    runs = {
        entry: run_mission(mission_from_text(mission("plain", (
            f'{{type: python, entry: "plugin_examples:{entry}", params: {{blend: 0.2}}}}'
        ))))
        for entry in ("drawn", "compiled_drawn", "blend")
    }  # fmt: skip
    for result in runs.values():
        assert result.outcome.value == "success", result.message
    for column in COLUMNS:
        plain = getattr(runs["drawn"], column).tobytes()
        assert getattr(runs["compiled_drawn"], column).tobytes() == plain, column
        assert getattr(runs["blend"], column).tobytes() == plain, column  # checked above


def _run(tmp_path: Path, text: str) -> tuple[int, str, dict[str, object] | None]:
    path = tmp_path / "plugged.yaml"
    path.write_text(text, encoding="utf-8")
    out = tmp_path / "run"
    result = CliRunner().invoke(app, ["run", str(path), "--out", str(out), "--no-plots"])
    assert result.exception is None or isinstance(result.exception, SystemExit), result.exception
    summary = out / "summary.json"
    written = json.loads(summary.read_text()) if summary.exists() else None
    return result.exit_code, result.stderr, written


# Where the controller's entry is written in MISSION.
ENTRY_LINE, ENTRY_COLUMN = next(
    (number, line.index('"plugin_examples') + 1)
    for number, line in enumerate(mission("plain").splitlines(), start=1)
    if "entry:" in line
)


@pytest.mark.parametrize(
    ("entry", "said"),
    [
        ("no_such_module:make", "cannot import 'no_such_module:make': No module named"),
        (
            "plugin_examples:no_such",
            "cannot load 'plugin_examples:no_such': 'plugin_examples' has no attribute 'no_such'",
        ),
        (
            "plugin_examples:NOT_CALLABLE",
            "cannot load 'plugin_examples:NOT_CALLABLE': it is not callable (int 3)",
        ),
    ],
)
def test_an_entry_that_does_not_load_is_refused_at_its_position(
    tmp_path: Path, entry: str, said: str
) -> None:
    text = mission("plain").replace("plugin_examples:plain", entry)
    code, err, summary = _run(tmp_path, text)
    assert code == 1
    assert f"plugged.yaml:{ENTRY_LINE}:{ENTRY_COLUMN}: {said}" in err, err
    assert summary is None  # nothing ran
    with pytest.raises(MissionError, match=said.split(":")[0]):
        run_mission(mission_from_text(text))


def test_a_module_that_raises_on_import_is_refused_with_where(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "exploding.py").write_text("x = 1\nraise ZeroDivisionError('at import')\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    text = mission("plain").replace("plugin_examples:plain", "exploding:make")
    code, err, _ = _run(tmp_path, text)
    assert code == 1
    assert (
        f":{ENTRY_LINE}:{ENTRY_COLUMN}: cannot import 'exploding:make': importing 'exploding' "
        f"raised ZeroDivisionError: at import ({tmp_path / 'exploding.py'}:2)"
    ) in err, err


def test_validate_checks_an_entry_s_syntax_and_imports_it_only_when_asked(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    marker = tmp_path / "imported"
    (tmp_path / "noisy.py").write_text(
        f"open({str(marker)!r}, 'w').close()\n\ndef make(params, setup):\n    return None\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    path = tmp_path / "m.yaml"
    path.write_text(mission("plain").replace("plugin_examples:plain", "noisy:make"))
    validate = CliRunner().invoke(app, ["validate", str(path)])
    assert validate.exit_code == 0, validate.stderr
    assert not marker.exists()  # never imported
    assert "noisy" not in sys.modules
    checked = CliRunner().invoke(app, ["validate", "--check-entries", str(path)])
    assert checked.exit_code == 0, checked.stderr
    assert marker.exists()  # --check-entries imports it, as a run does
    path.write_text(mission("plain").replace("plugin_examples:plain", "noisy:absent"))
    missing = CliRunner().invoke(app, ["validate", str(path)])
    assert missing.exit_code == 0
    missing = CliRunner().invoke(app, ["validate", "--check-entries", str(path)])
    assert missing.exit_code == 1
    assert f"m.yaml:{ENTRY_LINE}:{ENTRY_COLUMN}: cannot load 'noisy:absent'" in missing.stdout
    # The syntax is checked always, without importing anything.
    path.write_text(mission("plain").replace("plugin_examples:plain", "../../etc/passwd"))
    bad = CliRunner().invoke(app, ["validate", str(path)])
    assert bad.exit_code == 1
    assert "controller.entry: '../../etc/passwd' is not an entry: expected 'module:callable'" in (
        bad.stdout
    )


@pytest.mark.parametrize(
    ("controller", "sample", "said"),
    [
        ("gives_up", 25, "RuntimeError: no idea where to go (" + plugin_examples.__file__),
        ("compiled_gives_up", 25, "RuntimeError: no idea where to go"),
        ("three_numbers", 0, "ValueError: a controller plug-in's step returns two numbers"),
        ("refuses", 0, "making the plug-in raised ValueError: params need a 'gain', got ['theta'"),
        (
            "text",
            25,
            "TypeError: a controller plug-in's step returns two numbers (v, omega), not text",
        ),
        # what the step returned cannot be read: what it returns, said so
        (
            "one_number",
            25,
            "a controller plug-in's step returns two numbers (v, omega); what it returned "
            "cannot be read: TypeError: object of type 'float' has no len()",
        ),
        ("nothing", 25, "returns two numbers (v, omega); what it returned cannot be read"),
        # the call itself fails: said as it is, not as what the step returned
        ("wrong_signature", 0, "a plug-in failed at sample 0 (t = 0 s): TypeError: WrongSign"),
        # the plug-in's own: the run's samples, its message and summary.json kept
        ("out_of_memory", 25, "MemoryError: the plug-in's map did not fit"),
    ],
)
def test_a_plug_in_that_fails_ends_the_run_failed_with_its_message_and_sample(
    tmp_path: Path, controller: str, sample: int, said: str
) -> None:
    code, err, summary = _run(tmp_path, mission(controller))
    assert code == 1
    assert summary is not None
    assert summary["outcome"] == "failed"
    message = str(summary["message"])
    assert said in message, message
    if controller != "refuses":
        assert message.startswith(f"a plug-in failed at sample {sample} (t = {sample * 0.01:g} s)")
    # The samples done before it are kept; failed at the first, the start is.
    assert summary["samples"] == max(sample, 1)
    assert said in err


def test_a_step_returning_a_non_finite_number_is_a_divergence(tmp_path: Path) -> None:
    """docs/controllers.md: not limited into a finite input (and a timeout)."""
    code, err, summary = _run(tmp_path, mission("infinite"))
    assert code == 1
    assert summary is not None
    assert summary["outcome"] == "diverged"
    assert "diverged in phase 'eight' at t = 0.25 s: the input is not finite" in err
    assert summary["samples"] == 26  # the samples before it, and the one that diverged


@pytest.mark.parametrize(
    ("entry", "said"),
    [
        ("text_estimate", "TypeError: an estimator plug-in's step returns three numbers (x, y, "
         "theta), not text"),
        # a column [[x], [y], [theta]]: what a step returns, said so
        ("column_estimate", "an estimator plug-in's step returns three numbers (x, y, theta); "
         "what it returned cannot be read: TypeError: float() argument must be"),
    ],
)  # fmt: skip
def test_an_estimator_step_returning_what_is_not_three_numbers_fails_the_run(
    tmp_path: Path, entry: str, said: str
) -> None:
    estimator = f'{{type: python, entry: "plugin_examples:{entry}", params: {{blend: 0.5}}}}'
    code, err, summary = _run(tmp_path, mission("plain", estimator))
    assert code == 1
    assert summary is not None
    assert summary["outcome"] == "failed"
    assert said in str(summary["message"])
    assert said in err


@pytest.mark.parametrize(("lost", "said"), [("nan", "nan"), ("1e12", "1e+12")])
def test_an_estimate_that_runs_away_is_said_as_the_estimate_s(
    tmp_path: Path, lost: str, said: str
) -> None:
    """A divergence, as docs/controllers.md says, named as the estimator's: the
    robot's state stays where the loop keeps running, the estimate does not
    (not a number, or a terametre off)."""
    estimator = (
        '{type: python, entry: "plugin_examples:lost_estimate", '
        f"params: {{blend: 0.5, lost: '{lost}'}}}}"
    )
    code, err, summary = _run(tmp_path, mission("plain", estimator))
    assert code == 1
    assert summary is not None
    assert summary["outcome"] == "diverged"
    assert f"the estimate ran away (x = {said} m," in err
    assert "the state did not (x = " in err
    assert "the state ran away" not in err


def test_the_manifest_says_a_plain_plug_in_s_loop_ran_as_plain_python(tmp_path: Path) -> None:
    """manifest.json's `loop` and `numba_cpu` are the run's, not the process's:
    numba loaded, a plug-in of plain Python objects still runs the loop plain."""
    from wmr_mission.kernels import jit

    jit.load()  # as after an earlier compiled run in the same process
    out = tmp_path / "run"
    result = run_mission(mission_from_text(mission("plain")))
    assert result.loop_compiled is False
    result.write(out, plots=False)
    manifest = json.loads((out / "manifest.json").read_text())
    assert manifest["loop"] == "plain Python"
    assert manifest["environment"]["numba_cpu"] is None
    compiled = run_mission(mission_from_text(mission("compiled")))
    assert compiled.loop_compiled is jit.compiling()


def test_the_loop_is_compiled_for_a_jitclass_plug_in_only() -> None:
    """What the runner asks before compiling the loop: numba can type a
    jitclass plug-in's object, not a plain one's (then the loop is plain)."""
    from wmr_mission.controllers.plugin import ControllerSetup
    from wmr_mission.estimators.plugin import EstimatorSetup
    from wmr_mission.kernels import jit

    gains = {"x": 1.0, "y": 1.0, "theta": 1.0}
    controller = ControllerSetup(0.01, 1.0, 1.0)
    estimator = EstimatorSetup(0.01, (True, True, True), (0.1, 0.1, 0.1), (0.0, 0.0, 0.0))
    # With numba off (WMR_MISSION_NO_JIT=1) every loop is plain Python.
    compiling = jit.compiling()
    assert jit.typeable(plugin_examples.compiled(gains, controller)) == compiling
    assert jit.typeable(plugin_examples.compiled_drawn({"blend": 0.5}, estimator)) == compiling
    assert not jit.typeable(plugin_examples.plain(gains, controller))
    assert not jit.typeable(plugin_examples.drawn({"blend": 0.5}, estimator))


def test_a_campaign_runs_plug_ins_and_counts_one_that_fails(tmp_path: Path) -> None:
    """Campaigns apply unchanged: the entry varies like any field, the workers
    import the plug-in, and a failing one is a `failed` row, not a lost campaign."""
    from wmr_mission import run_campaign

    path = tmp_path / "plugged.yaml"
    path.write_text(mission("plain"), encoding="utf-8")
    campaign = tmp_path / "campaign.yaml"
    campaign.write_text(
        f"""version: 1
name: plugged
mission: {path}
runs: 2
seed: 5
vary:
  controller.entry: {{grid: ["plugin_examples:plain", "plugin_examples:gives_up"]}}
""",
        encoding="utf-8",
    )
    done = run_campaign(campaign, workers=2)
    summary = done.summary
    assert summary["outcomes"] == {"failed": 2, "success": 2}
    cells = {cell["values"]["controller.entry"]: cell for cell in summary["cells"]}
    assert cells["plugin_examples:plain"]["succeeded"] == 2
    assert cells["plugin_examples:gives_up"]["succeeded"] == 0
    rows = done.rows.to_dict("records") if hasattr(done.rows, "to_dict") else done.rows
    for row in rows:
        if row["outcome"] == "failed":
            assert row["reason"].startswith("a plug-in failed at sample 25 (t = 0.25 s)")


def test_a_campaign_s_manifest_says_a_plain_plug_in_s_loop_ran_plain(tmp_path: Path) -> None:
    """A sweep of a mission with a plug-in of plain Python objects: its
    manifest says the runs ran as plain Python, as each worst run's does, not
    the compiled loop the sweep's process loaded; with a jitclass plug-in,
    compiled. So does a search's (falsify)."""
    from wmr_mission import falsify_campaign, run_campaign
    from wmr_mission.kernels import jit

    for controller, loop in (("plain", "plain Python"), ("compiled", "compiled")):
        path = tmp_path / f"{controller}.yaml"
        path.write_text(mission(controller), encoding="utf-8")
        campaign = tmp_path / f"{controller}-campaign.yaml"
        campaign.write_text(
            f"version: 1\nname: plugged\nmission: {path}\nruns: 2\nseed: 5\n"
            "vary:\n  robot.initial_state.theta: {uniform: [-0.1, 0.1]}\n",
            encoding="utf-8",
        )
        expected = loop if jit.compiling() else "plain Python"
        out = tmp_path / f"{controller}-out"
        run_campaign(campaign, workers=1, out=out)
        searched = tmp_path / f"{controller}-falsify"
        falsify_campaign(campaign, budget=2, method="random", workers=1, out=searched)
        for directory in (out, searched):
            manifest = json.loads((directory / "manifest.json").read_text())
            assert manifest["loop"] == expected, (controller, directory)
            assert (manifest["environment"]["numba_cpu"] is None) == (expected == "plain Python")
