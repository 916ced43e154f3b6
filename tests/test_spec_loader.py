"""Loading missions: values, defaults, positions and refusals."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest

from wmr_mission.estimators.ekf import Ekf
from wmr_mission.estimators.observer import ConstrainedObserver
from wmr_mission.geometry.paths.ellipse import EllipsePath
from wmr_mission.geometry.paths.expression import ExpressionPath
from wmr_mission.spec.loader import (
    MAX_FILE_BYTES,
    MissionError,
    check_mission,
    check_mission_text,
    load_mission,
    load_mission_text,
)
from wmr_mission.spec.models import (
    HoldPhase,
    Mission,
    RegulatePhase,
    StayInside,
    TrackPhase,
)

ROOT = Path(__file__).resolve().parents[1]

MINIMAL = """\
version: 1
name: t
phases:
  - name: wait
    hold: {}
    until: {elapsed: 1}
"""


def test_case2_loads_with_plain_floats() -> None:
    mission = load_mission(ROOT / "missions" / "case2.yaml")
    assert isinstance(mission, Mission)
    orbit = mission.phases[1]
    assert isinstance(orbit, TrackPhase)
    assert isinstance(orbit.track.path, EllipsePath)
    assert orbit.track.path.angular_rate == pytest.approx(0.4 * 3.141592653589793)
    assert orbit.track.path.start == "current"
    spiral = mission.phases[0]
    assert isinstance(spiral, TrackPhase)
    assert isinstance(spiral.track.path, ExpressionPath)
    assert spiral.until.reaches == "ellipse"
    assert spiral.on_timeout == "fail"
    back = mission.phases[2]
    assert isinstance(back, RegulatePhase)
    assert back.constraints == (StayInside(stay_inside="ellipse"),)
    assert back.until.settled is not None
    assert back.until.settled.speed == 0.01
    assert mission.expect.max_constraint_violation is not None
    assert mission.expect.max_constraint_violation.max == 0.001


def test_defaults_are_the_papers_but_the_regulators_weights() -> None:
    mission = load_mission_text(MINIMAL, "m.yaml")
    assert mission.robot.dt == 0.01
    assert (mission.robot.initial_state.x, mission.robot.initial_state.y) == (0.0, 0.0)
    assert mission.sensors.measure == ("x", "y", "theta")
    estimator = mission.estimator
    assert isinstance(estimator, ConstrainedObserver)
    assert estimator.initial_estimate is None  # the initial state; the case studies say [1, 1, 0]
    # Q: four times the case studies' I (docs/paper-notes.md, eq. (17)); they write it
    assert mission.controller.Q == (4.0, 4.0, 4.0)
    assert mission.controller.R == (1.0, 1.0)
    assert mission.controller.W == (100.0, 100.0, 100.0)
    assert mission.controller.M == (100.0, 100.0)
    assert isinstance(mission.phases[0], HoldPhase)


def test_default_output_error_bounds_cover_measured_states_only() -> None:
    text = MINIMAL.replace("phases:", "sensors: {measure: [x, y]}\nphases:").replace(
        "hold: {}", "regulate: {target: {x: 1}}"
    )
    estimator = load_mission_text(text, "m.yaml").estimator
    assert isinstance(estimator, ConstrainedObserver)
    assert estimator.output_error_bounds == {"x": (-0.05, 0.05), "y": (-0.05, 0.05)}


def test_default_initial_estimate_is_the_initial_state() -> None:
    # A mission starting at (5, 5) used to begin 5.7 m off, at the paper's [1, 1, 0].
    from wmr_mission.sim.plan import plan_mission

    text = MINIMAL.replace("phases:", "robot: {initial_state: {x: 5, y: 5, theta: 2}}\nphases:")
    for estimator in ("", "estimator: {type: ekf}\n"):
        mission = load_mission_text(text.replace("phases:", estimator + "phases:"), "m.yaml")
        np.testing.assert_array_equal(plan_mission(mission).initial_estimate, [5.0, 5.0, 2.0])


def test_default_output_error_bounds_stay_clear_of_the_noise() -> None:
    # +-max(0.05, 5 sigma) per measured state: phase II acts on estimation
    # errors, not on the noise (docs/paper-notes.md, eq. (4)).
    text = MINIMAL.replace(
        "phases:", "sensors: {noise_std: {x: 0.02, y: 0.001, theta: 0.05}}\nphases:"
    )
    estimator = load_mission_text(text, "m.yaml").estimator
    assert isinstance(estimator, ConstrainedObserver)
    assert estimator.output_error_bounds == {
        "x": (-0.1, 0.1),
        "y": (-0.05, 0.05),
        "theta": (-0.25, 0.25),
    }


def test_the_noise_has_one_meaning_however_it_is_written() -> None:
    """sensors.noise_std is read once (Sensors.measured_noise): the default
    bounds, the warning on bounds inside the noise, the estimators' defaults
    and the draws all follow a noise written as an expression as they follow
    the number (the default bounds once took an expression for no noise)."""
    from wmr_mission.sim.plan import plan_mission

    plans = []
    for noise in ("0.02", "2*k"):
        text = MINIMAL.replace(
            "phases:",
            f"parameters: {{k: 0.01}}\nsensors: {{measure: [x, y], noise_std: {{x: {noise}, "
            "y: 0.001, theta: 0.3}}\nphases:",
        ).replace("hold: {}", "regulate: {target: {x: 1}}")
        mission = load_mission_text(text, "m.yaml")
        assert mission.sensors.measured_noise() == {"x": 0.02, "y": 0.001}
        assert isinstance(mission.estimator, ConstrainedObserver)
        assert mission.estimator.output_error_bounds == {"x": (-0.1, 0.1), "y": (-0.05, 0.05)}
        plans.append(plan_mission(mission))
    for plan in plans:  # theta is not measured: it has no noise to draw
        np.testing.assert_array_equal(plan.noise_std, [0.02, 0.001, 0.0])
        assert plan.estimator_tuning.motion_floor == 0.02


def test_scalars_use_parameters() -> None:
    text = MINIMAL.replace("phases:", "parameters: {k: 0.25}\nphases:").replace(
        "hold: {}", "regulate: {target: {x: 2*k, y: -k, theta: pi/2}}"
    )
    phase = load_mission_text(text, "m.yaml").phases[0]
    assert isinstance(phase, RegulatePhase)
    assert phase.regulate.target.x == 0.5
    assert phase.regulate.target.y == -0.25
    assert phase.regulate.target.theta == pytest.approx(1.5707963267948966)


def test_ekf_is_selected_by_type() -> None:
    text = MINIMAL.replace("phases:", "estimator: {type: ekf}\nphases:")
    estimator = load_mission_text(text, "m.yaml").estimator
    assert isinstance(estimator, Ekf)
    assert estimator.initial_std.theta == 0.5
    assert estimator.measurement_std is None


def test_models_are_frozen() -> None:
    mission = load_mission_text(MINIMAL, "m.yaml")
    with pytest.raises(ValueError, match="frozen"):
        mission.robot.dt = 0.1  # type: ignore[misc]


def test_every_error_of_a_file_is_reported_at_once() -> None:
    text = """\
version: 1
name: several
robot:
  dtt: 0.01
  limits: {v: -1}
sensors:
  measure: [x, y, z]
phases:
  - name: one
    hold: {}
    until: {elapsed: 1, elapsd: 2}
  - name: two
    regulate: {target: {x: 1, y: 0, theta: bad name}}
    timeout: 5
"""
    mission, diagnostics = check_mission_text(text, "several.yaml")
    assert mission is None
    positions = [(d.line, d.column) for d in diagnostics]
    assert positions == [(4, 3), (5, 15), (7, 19), (11, 25), (13, 44)]
    messages = "\n".join(d.message for d in diagnostics)
    assert "did you mean 'dt'?" in messages
    assert "did you mean 'elapsed'?" in messages
    assert "greater than 0" in messages


def test_mission_error_lists_every_error() -> None:
    text = MINIMAL.replace("name: t", "name: T").replace("elapsed: 1", "elapsed: -1")
    with pytest.raises(MissionError) as caught:
        load_mission_text(text, "m.yaml")
    lines = str(caught.value).splitlines()
    assert len(caught.value.diagnostics) == 2
    assert lines[0].startswith("m.yaml:2:7: name: expected lower-case")
    assert lines[1].startswith("m.yaml:6:22: phases[0].until.elapsed: should be greater than 0")


def test_warnings_do_not_stop_loading() -> None:
    text = MINIMAL.replace("elapsed: 1", "elapsed: 1.005")
    mission, diagnostics = check_mission_text(text, "m.yaml")
    assert mission is not None
    assert [d.severity for d in diagnostics] == ["warning"]
    assert load_mission_text(text, "m.yaml") == mission


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("", "the file is empty"),
        ("null\n", "the file holds only null: expected a mission mapping"),
        ("~\n", "the file holds only null: expected a mission mapping"),
        ("---\n", "the file holds only null: expected a mission mapping"),
        ("null\n...\n", "the file holds only null: expected a mission mapping"),
        ("!!str version: 1\n", "YAML tag '!!str' is not allowed"),
        ("version: ! 1\n", "YAML tag '!' is not allowed"),
        ("- 1\n- 2\n", "a mission is a mapping"),
        ("42\n", "a mission is a mapping"),
        ("version: [\n", "YAML syntax error"),
        ("a: &x 1\nb: *x\n", "anchor '&x' is not allowed"),
        ("{{{{", "YAML syntax error"),
        ("version: 1\x00\n", "is not allowed in YAML text"),
    ],
)
def test_odd_inputs_give_a_message(text: str, message: str) -> None:
    mission, diagnostics = check_mission_text(text, "odd.yaml")
    assert mission is None
    assert any(message in d.message for d in diagnostics), diagnostics


def test_alias_bomb_is_refused_quickly() -> None:
    lines = ["a0: &a0 [x, x, x, x, x, x, x, x, x, x]"]
    lines += [f"a{i}: &a{i} [*a{i - 1}, *a{i - 1}, *a{i - 1}, *a{i - 1}]" for i in range(1, 30)]
    _, diagnostics = check_mission_text("\n".join(lines) + "\n", "bomb.yaml")
    assert diagnostics[0].line == 1
    assert "anchor '&a0' is not allowed" in diagnostics[0].message


def test_oversized_file_is_refused_before_reading(tmp_path: Path) -> None:
    path = tmp_path / "big.yaml"
    path.write_text(MINIMAL + "# " + "x" * MAX_FILE_BYTES + "\n", encoding="utf-8")
    mission, diagnostics = check_mission(path)
    assert mission is None
    assert [(d.line, d.column) for d in diagnostics] == [(1, 1)]
    assert "file too large" in diagnostics[0].message


def test_ten_megabyte_expression_is_refused(tmp_path: Path) -> None:
    path = tmp_path / "huge.yaml"
    expression = "+".join(["t"] * 5_000_000)
    path.write_text(
        MINIMAL.replace(
            "hold: {}", f'track: {{path: {{type: expression, x: "{expression}", y: "0"}}}}'
        ),
        encoding="utf-8",
    )
    _, diagnostics = check_mission(path)
    assert "file too large" in diagnostics[0].message
    _, diagnostics = check_mission_text(path.read_text(encoding="utf-8"), "huge.yaml")
    assert "file too large" in diagnostics[0].message


INJECTIONS = [
    "__import__('os').system('touch x')",
    "().__class__",
    "().__class__.__bases__[0].__subclasses__()",
    "open('x', 'w')",
    "exec('import os')",
    "lambda: 0",
    "t if t else t",
    "[t for t in ()]",
    "t.real",
    "os.system",
]


@pytest.mark.parametrize("expression", INJECTIONS)
def test_injection_in_expression_is_refused_and_not_executed(
    expression: str, tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    quoted = expression.replace('"', '\\"')
    text = MINIMAL.replace(
        "hold: {}", f'track: {{path: {{type: expression, x: "{quoted}", y: "0"}}}}'
    )
    mission, diagnostics = check_mission_text(text, "evil.yaml")
    assert mission is None
    assert len(diagnostics) == 1
    assert diagnostics[0].line == 5
    assert "phases[0].track.path.x: invalid expression:" in diagnostics[0].message
    assert os.listdir(tmp_path) == []


def test_a_mistake_in_an_expression_folded_over_lines_is_at_its_own_line() -> None:
    text = MINIMAL.replace(
        "hold: {}",
        "track:\n      path:\n        type: expression\n        x: >-\n          2*cos(t)\n"
        "          + foo(t)\n        y: '0'",
    )
    _, diagnostics = check_mission_text(text, "folded.yaml")
    (error,) = diagnostics
    assert "function 'foo' is not allowed" in error.message
    assert (error.line, error.column) == (10, 13)  # the `foo` of `+ foo(t)`
    assert text.splitlines()[error.line - 1][error.column - 1 :] == "foo(t)"


def test_python_tag_is_refused_and_not_executed(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.chdir(tmp_path)
    text = MINIMAL + "description: !!python/object/apply:os.system ['touch x']\n"
    mission, diagnostics = check_mission_text(text, "evil.yaml")
    assert mission is None
    assert "YAML tag '!!python/object/apply:os.system' is not allowed" in diagnostics[0].message
    assert os.listdir(tmp_path) == []


def test_expression_error_points_into_the_expression() -> None:
    text = MINIMAL.replace("hold: {}", "regulate: {target: {x: '1 + 2*q'}}")
    _, diagnostics = check_mission_text(text, "m.yaml")
    (diagnostic,) = diagnostics
    line = text.splitlines()[diagnostic.line - 1]
    assert line[diagnostic.column - 1] == "q"
    assert "unknown name 'q'" in diagnostic.message


def test_unknown_key_without_close_match_lists_the_fields() -> None:
    text = MINIMAL.replace("name: t", "name: t\nrobot: {zzz: 1}")
    _, diagnostics = check_mission_text(text, "m.yaml")
    assert diagnostics[0].message == (
        "unknown field 'zzz'; expected one of: dt, initial_state, limits, disturbances, footprint"
    )


def test_non_utf8_file(tmp_path: Path) -> None:
    path = tmp_path / "latin1.yaml"
    path.write_bytes(b"version: 1\nname: caf\xe9\n")
    _, diagnostics = check_mission(path)
    assert [(d.line, d.column, d.message) for d in diagnostics] == [
        (2, 10, "the file is not UTF-8 text")
    ]


def test_unreadable_path_is_a_diagnostic(tmp_path: Path) -> None:
    _, diagnostics = check_mission(tmp_path)
    assert "cannot read the file" in diagnostics[0].message
    with pytest.raises(MissionError, match="cannot read the file"):
        load_mission(tmp_path / "missing.yaml")


def test_the_mission_models_are_built_when_first_used() -> None:
    """`validate` and `run` build the validators of the models a mission uses
    when it is checked, not the 68 models' each at import (defer_build:
    `python benchmarks/measure.py startup`). Here in a fresh process: after
    the import only the threshold the defaults instantiate is built; after
    one mission is checked, the mission and what it uses validate."""
    import subprocess
    import sys

    probe = """
from pathlib import Path
from wmr_mission.fields import Model
import wmr_mission.spec.models as models
def below(c):
    for s in c.__subclasses__():
        yield s
        yield from below(s)
every = set(below(Model))
print(len(every) > 60, sorted(c.__name__ for c in every if c.__pydantic_complete__))
from wmr_mission.spec.loader import load_mission
mission = load_mission(Path("missions/case2.yaml"))
print(models.Mission.__pydantic_complete__, mission.phases[0].name)
"""
    root = Path(__file__).resolve().parent.parent
    done = subprocess.run(
        [sys.executable, "-c", probe], cwd=root, capture_output=True, text=True, timeout=120
    )
    assert done.returncode == 0, done.stderr
    assert done.stdout.splitlines() == ["True ['Threshold']", "True spiral-out"]


@pytest.mark.parametrize("side", ["stay_inside", "stay_outside"])
def test_a_polygon_crossing_itself_is_refused_as_such_alone(side: str) -> None:
    """Kept inside as kept outside: its edges bound nothing, so nothing else is
    said of what is inside it (no "do not overlap", no "initial_state outside")."""
    path = Path(__file__).parent / "data" / "missions" / "invalid"
    text = (path / "polygon_crossing_itself_kept_inside.yaml").read_text(encoding="utf-8")
    _, diagnostics = check_mission_text(text.replace("stay_inside", side), "bow.yaml")
    assert [(d.line, d.column, d.message.split(":")[0]) for d in diagnostics] == [
        (7, 15, "polygon 'bow' crosses itself, so it is not convex (or has no area)")
    ]


def test_a_key_written_a_level_too_high_is_told_where_it_belongs() -> None:
    """`limits:` beside `robot:` was 'unknown field; expected one of: version,
    name, ...', with no word of robot.limits."""
    from wmr_mission.spec.loader import check_mission_text

    text = (
        "version: 1\nname: m\nrobot:\n  dt: 0.01\nlimits: {v: 1, omega: 2}\n"
        "phases:\n  - name: go\n    track: {path: {type: line, heading: 0, speed: 0.5}}\n"
        "    until: {elapsed: 3}\n"
    )
    [found] = check_mission_text(text, "m.yaml")[1]
    assert (found.line, found.column) == (5, 1)
    assert found.message == "unknown field 'limits'; it belongs in 'robot' (robot.limits)"


def test_a_region_name_that_is_no_identifier_is_shown_at_its_name() -> None:
    """A region named `post-left` was reported at the `{` of its value: the
    name is what is wrong (region names are identifiers; phase names may
    hold '-')."""
    from wmr_mission.spec.loader import check_mission_text

    text = (
        "version: 1\nname: m\nregions:\n  post-left: {type: circle, center: [3, 0], radius: 1}\n"
        "phases:\n  - name: go\n    hold: {}\n    until: {elapsed: 1}\n"
    )
    [found] = check_mission_text(text, "m.yaml")[1]
    assert (found.line, found.column) == (4, 3)
    assert found.message.startswith("regions.post-left: expected an identifier")


UNITS_MISSION = """\
version: 1
name: m
parameters: {h: 0.5}
robot:
  limits: {v: 1, omega: 2}
sensors: {noise_std: {x: 0, y: 0, theta: 0.01}, dropout: {probability: 0}}
phases:
  - name: go
    track: {path: {type: expression, x: "0.5*t", y: "0"}}
    until: {elapsed: 3}
"""


UNIT_CASES = [
    (
        "x: 0,",
        "x: 1cm,",
        "sensors.noise_std.x: units are not written: x is in m; write 0.01 for 1 cm",
    ),
    (
        "y: 0,",
        "y: 1 cm,",
        "sensors.noise_std.y: units are not written: y is in m; write 0.01 for 1 cm",
    ),
    (
        "omega: 2}",
        "omega: 2 rad/s}",
        "robot.limits.omega: units are not written: omega is in rad/s; write 2 for 2 rad/s",
    ),
    (
        "v: 1,",
        "v: 0.5m/s,",
        "robot.limits.v: units are not written: v is in m/s; write 0.5 for 0.5 m/s",
    ),
    (
        "v: 1,",
        "v: 18 km/h,",
        "robot.limits.v: units are not written: v is in m/s; write 5 for 18 km/h",
    ),
    (
        "theta: 0.01}",
        "theta: 90deg}",
        "sensors.noise_std.theta: units are not written: theta is in rad; write 1.5708 for 90 deg",
    ),
    (
        "v: 1,",
        "v: 2 rad/s,",
        "robot.limits.v: units are not written: v is in m/s; write the number alone",
    ),
    (
        "probability: 0}",
        "probability: 5 %}",
        "sensors.dropout.probability: units are not written: write 0.05 for 5 %",
    ),
    (
        'x: "0.5*t"',
        'x: "2 m"',
        "phases[0].track.path.x: units are not written: x is in m; write 2 for 2 m",
    ),
]


@pytest.mark.parametrize(
    ("written", "said"),
    [
        (
            "0.1",
            "7:34: phases[0].expect.turn_rate_jump_max: expected {max: NUMBER}, 'auto' or "
            "null, got 0.1: write {max: 0.1}",
        ),
        (
            "{max: 10cm}",
            "7:40: phases[0].expect.turn_rate_jump_max.max: units are not written: "
            "turn_rate_jump_max is in rad/s; write the number alone",
        ),
        ("{max: -1}", "7:40: phases[0].expect.turn_rate_jump_max.max: should be greater than"),
        ("aut", "7:34: phases[0].expect.turn_rate_jump_max: expected {max: NUMBER}, 'auto' or"),
    ],
)
def test_a_threshold_written_wrong_is_said_once_in_the_form_it_takes(
    written: str, said: str
) -> None:
    # a threshold is {max: N}, 'auto' or null: a mapping was also told it is no
    # 'auto', and a number that it is no mapping, at the threshold's parent
    text = MINIMAL.replace(
        "    until: {elapsed: 1}\n",
        f"    until: {{elapsed: 1}}\n    expect: {{turn_rate_jump_max: {written}}}\n",
    )
    _, diagnostics = check_mission_text(text, "m.yaml")
    assert len(diagnostics) == 1, diagnostics
    assert str(diagnostics[0]).startswith(f"m.yaml:{said}")


def test_a_mission_threshold_written_as_a_number_says_the_threshold_to_write() -> None:
    text = MINIMAL + "expect:\n  final_position_error: 0.05\n"
    _, diagnostics = check_mission_text(text, "m.yaml")
    assert [str(d) for d in diagnostics] == [
        "m.yaml:8:25: expect.final_position_error: should be a mapping, got 0.05: write {max: 0.05}"
    ]


@pytest.mark.parametrize(
    ("field", "written", "message"), UNIT_CASES, ids=[c[1] for c in UNIT_CASES]
)
def test_a_number_written_with_a_unit_says_the_number_to_write(
    field: str, written: str, message: str
) -> None:
    """`noise_std: {x: 1cm}` was refused with the grammar of expressions
    ("implicit products: write 2*t") and `omega: 2 rad/s` as "should be a valid
    number": neither said that units are not written, nor which unit the field is in."""
    text = UNITS_MISSION.replace(field, written, 1)
    mission, diagnostics = check_mission_text(text, "m.yaml")
    assert mission is None
    [found] = [str(d) for d in diagnostics]
    value = written.split(": ")[1].rstrip(",}")
    line = 1 + next(i for i, row in enumerate(text.splitlines()) if written in row)
    column = 1 + text.splitlines()[line - 1].index(value)
    assert found == f"m.yaml:{line}:{column}: {message}"


def test_a_formula_is_not_a_number_with_a_unit() -> None:
    """An expression is read as one, a parameter named like a unit too."""
    valid = UNITS_MISSION.replace('"0.5*t"', '"2*h*t"').replace("x: 0,", "x: 2*h,")
    assert check_mission_text(valid, "m.yaml")[0] is not None
    [found] = check_mission_text(UNITS_MISSION.replace('"0.5*t"', '"2 h"'), "m.yaml")[1]
    assert "unexpected 'h': expected an operator" in found.message
    assert "units" not in found.message
    [found] = check_mission_text(UNITS_MISSION.replace('"0.5*t"', '"2 apples"'), "m.yaml")[1]
    assert "units" not in found.message
