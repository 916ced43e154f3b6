"""The reaction graph's proof (wmr_mission/spec/graph.py): every graph gets a
proof or a positioned error, never an internal one; and the worst case it
proves is the sample budget every part of the tool uses."""

from __future__ import annotations

import inspect
import itertools
import sys
import time
from typing import Any

import yaml
from hypothesis import HealthCheck, example, given, settings
from hypothesis import strategies as st

from wmr_mission.api import mission_from_dict
from wmr_mission.sim.plan import plan_mission, sample_budget
from wmr_mission.sim.reactions import Reactor
from wmr_mission.sim.runner import run_mission
from wmr_mission.spec.checks import MAX_SAMPLES
from wmr_mission.spec.graph import worst_case_samples
from wmr_mission.spec.loader import check_mission_text


def _hold(name: str, reaction: Any = None, seconds: float = 1.0) -> dict[str, Any]:
    """A phase that ends after ``seconds`` or times out at twice that (a hold
    settles at once, so its `elapsed` ends it)."""
    phase: dict[str, Any] = {"name": name, "hold": {}, "until": {"elapsed": seconds}}
    phase["timeout"] = 2 * seconds
    if reaction is not None:
        phase["on_timeout"] = reaction
    return phase


def _mission(phases: list[Any], contingencies: dict[str, Any] | None = None) -> dict[str, Any]:
    return {
        "version": 1,
        "name": "t",
        "robot": {"dt": 0.02, "limits": {"v": 2, "omega": 3}},
        "phases": phases,
        "contingencies": contingencies or {},
    }


def _errors(written: dict[str, Any]) -> list[str]:
    text = yaml.safe_dump(written, sort_keys=False)
    _, diagnostics = check_mission_text(text, "m.yaml")
    return [str(d) for d in diagnostics if d.severity == "error"]


def _line_of(written: dict[str, Any], needle: str) -> int:
    text = yaml.safe_dump(written, sort_keys=False)
    return next(n for n, line in enumerate(text.splitlines(), 1) if needle in line)


def _self_calling(then: str) -> dict[str, Any]:
    """A contingency whose own phase calls the same contingency."""
    return _mission(
        [_hold("a", "c")], {"c": {"phases": [_hold("c-a", "c")], "then": then, "times": 3}}
    )


def test_a_contingency_calling_itself_then_resume_is_a_positioned_loop() -> None:
    # Its phase ends, resumes its caller (itself), ends again, ...: uncounted for ever.
    written = _self_calling("resume")
    errors = _errors(written)
    assert errors == [
        f"m.yaml:{_line_of(written, 'then: resume')}:11: these phases can loop for ever: "
        "c-a -> c-a; bound the loop with {retry: {times: N}} or by running a contingency "
        "(its times)"
    ]


def test_a_contingency_calling_itself_then_next_is_a_positioned_error() -> None:
    # What is next after c is what follows its caller, c's own last phase: c's end again.
    written = _self_calling("next")
    errors = _errors(written)
    assert len(errors) == 1
    assert errors[0].startswith(f"m.yaml:{_line_of(written, 'then: next')}:11: then: next of ")
    assert "can lead back to its own end" in errors[0]
    assert "internal error" not in errors[0]


def test_two_contingencies_calling_each_other_then_next_is_a_positioned_error() -> None:
    written = _mission(
        [_hold("a", "c")],
        {
            "c": {"phases": [_hold("c-a", "d")], "then": "next"},
            "d": {"phases": [_hold("d-a", "c")], "then": "next"},
        },
    )
    errors = _errors(written)
    assert errors
    assert all("can lead back to its own end" in e for e in errors), errors


def test_a_deep_graph_is_proved_without_recursion() -> None:
    """4,000 phases, each timing out into the next, and a chain of 100 contingencies
    each ending `then: next` whose phase calls the following one: proved (the
    recursion it used to take went one call deep per contingency, and for ever
    round a loop), in well under a second per thousand phases."""
    phases = [_hold(f"p{i}", "next", 0.1) for i in range(4000)]
    phases[0]["on_timeout"] = "c0"
    contingencies = {
        f"c{i}": {"phases": [_hold(f"c{i}-a", f"c{i + 1}" if i < 99 else "fail")], "then": "next"}
        for i in range(100)
    }
    written = _mission(phases, contingencies)
    started = time.perf_counter()
    mission = mission_from_dict(written)
    elapsed = time.perf_counter() - started
    assert elapsed < 20, elapsed  # validate's every check, not the graph's alone
    # The proved worst case: every phase to its elapsed time (0.1 s = 5 samples, + 1
    # to enter), and each contingency once (1 s: 51) followed by the phases after p0.
    assert worst_case_samples(mission) == 4000 * 6 + 100 * (51 + 3999 * 6) + 1


# --- the worst case counts the repetitions -------------------------------------


def _long(reaction: Any, seconds: float = 400_000.0) -> dict[str, Any]:
    return {
        "name": "far",
        "regulate": {"target": {"x": 1, "y": 0, "theta": 0}},
        "until": {"settled": {"position": 0.01, "heading": 0.01}},
        "timeout": seconds,
        "on_timeout": reaction,
    }


def test_retries_count_in_the_sample_budget() -> None:
    # 400,000 s at dt 0.02 is 2e7 samples, under the limit of 5e7 once; 101 times it is not.
    written = _mission([_long({"retry": {"times": 100}})])
    (error,) = _errors(written)
    assert "in the worst case the mission lasts 4.04e+07 s = 2,020,000,102 samples" in error
    assert "every retry and contingency as often as its count allows" in error
    once = _mission([_long("fail")])
    assert _errors(once) == []
    assert worst_case_samples(mission_from_dict(once)) == 20_000_000 + 1 + 1


def test_a_contingency_s_times_count_in_the_sample_budget() -> None:
    written = _mission(
        [_hold("a", "c")],
        {"c": {"phases": [_long("next")], "then": "next", "times": 100}},
    )
    (error,) = _errors(written)
    assert "= 2,000,000,152 samples" in error


def test_the_runner_s_budget_is_the_proved_worst_case() -> None:
    written = _mission(
        [_hold("a", {"retry": {"times": 3, "then": "c"}}), _hold("b", None, 2.0)],
        {"c": {"phases": [_hold("c-a")], "then": "next", "times": 2}},
    )
    mission = mission_from_dict(written)
    # An entry of a 1 s phase is 51 samples, of b 101. a then b; each of a's 3 retries
    # is followed by a and b again; c's 2 runs each by c-a and b (then: next).
    expected = (51 + 101) + 3 * (51 + 101) + 2 * (51 + 101) + 1
    assert worst_case_samples(mission) == expected
    assert sample_budget(mission) == expected
    assert plan_mission(mission).max_samples == expected


def test_a_mission_time_ends_a_phase_by_then_whenever_it_starts() -> None:
    phases = [_hold("a", None, 10.0), {"name": "b", "hold": {}, "until": {"mission_time": 12}}]
    mission = mission_from_dict(_mission(phases))
    # a: 500 samples + 1; b ends by 12 s (600 samples + 1), not 60 s after it starts.
    assert worst_case_samples(mission) == 601 + 1
    assert sample_budget(mission) <= MAX_SAMPLES


# --- any small graph: a proof or a positioned error, and the proof bounds the run --


NAMES = ("p0", "p1", "p2")
CONTINGENCIES = ("c0", "c1")


def _reactions() -> st.SearchStrategy[Any]:
    fallback = st.one_of(
        # the contingencies twice: loops through them are what is hard to prove
        st.sampled_from(["fail", "next", *CONTINGENCIES, *CONTINGENCIES, "hold"]),
        st.builds(lambda n: {"goto": n}, st.sampled_from(NAMES)),
    )
    return st.one_of(
        fallback,
        st.builds(
            lambda times, then: {"retry": {"times": times, "then": then}},
            st.integers(1, 2),
            fallback,
        ),
    )


@st.composite
def small_graphs(draw: st.DrawFn) -> dict[str, Any]:
    def phase(name: str) -> dict[str, Any]:
        reaction = draw(st.one_of(st.none(), _reactions()))
        if draw(st.booleans()):  # a 1 m move cannot settle in 0.06 s: it times out
            written: dict[str, Any] = {
                "name": name,
                "regulate": {"target": {"x": 1, "y": 0, "theta": 0}},
                "until": {"settled": {"position": 0.01, "heading": 0.01}},
                "timeout": 0.06,
            }
        else:
            written = {"name": name, "hold": {}, "until": {"elapsed": 0.04}}
        if reaction is not None:
            written["on_timeout"] = reaction
        return written

    count = draw(st.integers(1, len(NAMES)))
    phases = [phase(n) for n in NAMES[:count]]
    contingencies = {}
    for c in CONTINGENCIES:
        if draw(st.booleans()):
            size = draw(st.integers(1, 2))
            then = draw(
                st.one_of(
                    st.sampled_from(["resume", "next", "end", "fail"]),
                    st.builds(lambda n: {"goto": n}, st.sampled_from(NAMES)),
                )
            )
            contingencies[c] = {
                "phases": [phase(f"{c}-{j}") for j in range(size)],
                "then": then,
                "times": draw(st.integers(1, 2)),
            }
    return _mission(phases, contingencies)


@settings(
    max_examples=100, deadline=None, suppress_health_check=[HealthCheck.too_slow], derandomize=True
)
@given(small_graphs())
@example(_self_calling("next"))
@example(_self_calling("resume"))
def test_every_small_graph_is_proved_or_refused_at_a_position(written: dict[str, Any]) -> None:
    for error in _errors(written):
        assert "internal error" not in error, error
        assert not error.startswith("m.yaml:1:1:"), error


@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(small_graphs())
def test_a_proved_graph_s_run_stays_within_its_worst_case(written: dict[str, Any]) -> None:
    if _errors(written):
        return
    mission = mission_from_dict(written)
    result = run_mission(mission)
    assert result.transitions[-1].to_phase is None  # it ended
    assert result.samples <= worst_case_samples(mission)


def test_a_deep_chain_of_contingencies_runs_without_recursion() -> None:
    """A run through 100 contingencies (the most a mission holds), each called
    from the timed-out phase of the one before and each ending `then: next`:
    the last one's end goes back up the 100 callers in a loop, within 30
    frames of Python stack, where the recursion it used to take went one
    frame deeper per caller."""
    depth = 100

    def timing_out(name: str, reaction: str) -> dict[str, Any]:
        return {
            "name": name,
            "hold": {},
            "until": {"elapsed": 10},
            "timeout": 0.04,
            "on_timeout": reaction,
        }

    last = {"name": f"c{depth - 1}-a", "hold": {}, "until": {"elapsed": 0.04}}
    contingencies = {
        f"c{i}": {
            "phases": [timing_out(f"c{i}-a", f"c{i + 1}") if i < depth - 1 else last],
            "then": "next",
        }
        for i in range(depth)
    }
    phases = [timing_out("a", "c0"), {"name": "b", "hold": {}, "until": {"elapsed": 0.04}}]
    mission = mission_from_dict(_mission(phases, contingencies))
    plans = plan_mission(mission)
    assert plans.reactions is not None
    reactor = Reactor(plans.reactions)
    index: int | None = 0
    for _ in range(depth):
        assert index is not None
        index = reactor.react(index, "timeout").enter
    assert index is not None
    limit = sys.getrecursionlimit()
    sys.setrecursionlimit(len(inspect.stack()) + 30)
    try:
        decision = reactor.completed(index)
    finally:
        sys.setrecursionlimit(limit)
    assert decision.reaction == "then: next"
    # The run: what follows the first caller, a, comes after the last contingency.
    result = run_mission(mission)
    moves = [(t.from_phase, t.to_phase) for t in result.transitions]
    names = ["a", *(f"c{i}-a" for i in range(depth))]
    assert moves[:depth] == list(itertools.pairwise(names))
    assert moves[depth] == (f"c{depth - 1}-a", "b")
    assert result.transitions[depth].reaction == "then: next"
    assert result.outcome.value == "success"


def test_too_many_contingencies_says_how_many() -> None:
    contingencies = {f"c{i}": {"phases": [_hold(f"c{i}-a")], "then": "next"} for i in range(101)}
    written = _mission([_hold("a", "c0")], contingencies)
    first = _line_of(written, "contingencies:") + 1  # where the mapping begins
    assert _errors(written) == [
        f"m.yaml:{first}:3: contingencies: expected at most 100 items, got 101"
    ]


UNREACHED = """\
version: 1
name: unreached
robot:
  limits: {v: 1, omega: 2}
phases:
  - name: a
    track: {path: {type: line, heading: 0, speed: 0.5}}
    timeout: 2
    on_timeout: {goto: GOTO}
  - name: b
    regulate: {target: {x: 0, y: 1, theta: 0}}
    until: {settled: {position: 0.05, heading: 0.05}}
    timeout: 10
  - name: c
    regulate: {target: {x: 1, y: 0, theta: 0}}
    until: {settled: {position: 0.05, heading: 0.05}}
    timeout: 10
"""


def test_a_phase_no_phase_goes_on_to_is_warned_of() -> None:
    """`a` ends only by its timeout, which goes to `c`: `b` never ran, and
    the run said `success` without a word of it."""
    from wmr_mission.spec.loader import check_mission_text

    def warned(text: str) -> list[tuple[int, int, str]]:
        found = check_mission_text(text, "m.yaml")[1]
        return [(d.line, d.column, d.message) for d in found if d.severity == "warning"]

    [(line, column, message)] = warned(UNREACHED.replace("GOTO", "c"))
    assert (line, column) == (10, 5)
    assert message.startswith("phase 'b' never runs")
    assert warned(UNREACHED.replace("GOTO", "b")) == []  # c follows b
