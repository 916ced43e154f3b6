"""The robustness of a phase's temporal `expect` formulas (wmr_mission.spec.temporal).

The quantitative semantics is signal temporal logic's, in discrete time as
rtamt evaluates it offline (tests/test_temporal.py holds the two equal to
1e-9), over the samples k = 0 .. n-1 of a phase:

    rho(s <= c, k)            = c - s[k]     (s >= c: s[k] - c)
    rho(a and b, k)           = min(rho(a, k), rho(b, k));   or: max
    rho(always[i, j] a, k)    = min of rho(a, m) over m in [k + i, k + j]
    rho(eventually[i, j] a, k)= max of the same
    rho(a until[i, j] b, k)   = max over m in [k + i, k + j] of
                                min(rho(b, m), min of rho(a, l) over l in [k, m - 1])

with the window in samples, cut at the phase's end (a minimum over nothing is
+inf, a maximum -inf). A formula's value is its rho at the phase's first sample.

Each atom is measured in its bound's size, ``(c - s) / |c|`` (over 1 of the
unit when c = 0), as a check's margin is (wmr_mission.verdicts.check): the
formula's rho is then the margin of the check it makes, and
``always[entry, end](cross_track <= 0.1)`` has the margin of
``cross_track_error_max: {max: 0.1}``.

Each window minimum and maximum costs O(n) whatever its width (van Herk's
blocks), and ``until`` O(n log n) (a doubling scan): a one-hour mission's
formulas cost a few array passes, not a loop over samples.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable, Mapping
from typing import TYPE_CHECKING, Any, cast

import numpy as np

from wmr_mission.basics import FloatArray, cached_value
from wmr_mission.spec.located import written_phases
from wmr_mission.spec.numbers import MissionNumbers
from wmr_mission.verdicts.check import Check
from wmr_mission.verdicts.tracking import Known, Placement, placed_known, reference_known
from wmr_mission.verdicts.zones import zones_of

if TYPE_CHECKING:
    from wmr_mission.record import PhaseRecord, RunRecord
    from wmr_mission.spec.temporal import (
        Always,
        Atom,
        Both,
        Either,
        Eventually,
        Node,
        Until,
        Window,
    )

# The formulas' grammar (wmr_mission.spec.temporal) is imported where a formula
# is read: a run whose mission writes none never loads it (docs/performance.md,
# Start-up).

__all__ = ["PhaseSignals", "formula_checks", "panel_of", "phase_values", "robustness"]

_INF = math.inf


@functools.cache
def _nodes() -> tuple[type[Atom], type[Both], type[Either], type[Always], type[Eventually]]:
    """The grammar's node types, imported once where a formula is first read
    (an import statement in a function costs 2 us at each call: a case-2 row
    reads two formulas, each through four such functions)."""
    from wmr_mission.spec.temporal import Always, Atom, Both, Either, Eventually

    return Atom, Both, Either, Always, Eventually


@functools.lru_cache(maxsize=256)
def _read(text: str) -> tuple[Node, tuple[str, ...]]:
    """A formula and the signals it names, in order: read once per text (a
    campaign judges the same few formulas in every run)."""
    from wmr_mission.spec.temporal import parse_formula, signals_of

    node = parse_formula(text)
    return node, tuple(sorted(signals_of(node)))


def robustness(
    node: Node,
    signals: Mapping[str, FloatArray],
    dt: float,
    instants: Mapping[str, float],
    normalised: bool = True,
) -> FloatArray:
    """The robustness of ``node`` at every sample (``signals`` of one length;
    ``instants``: the seconds ``entry`` and ``settle`` stand for)."""
    atom, both, either, always, eventually = _nodes()
    if isinstance(node, atom):
        values = signals[node.signal]
        rho: FloatArray = values - node.bound if node.above else node.bound - values
        if normalised:  # in the new array: the same quotients, one array fewer
            rho /= abs(node.bound) or 1.0
        return rho
    if isinstance(node, (both, either)):
        left = robustness(node.left, signals, dt, instants, normalised)
        right = robustness(node.right, signals, dt, instants, normalised)
        found: FloatArray = (np.minimum if isinstance(node, both) else np.maximum)(left, right)
        return found
    n = len(next(iter(signals.values())))
    if isinstance(node, (always, eventually)):
        first, last = _samples(node.window, dt, instants, n)
        body = robustness(node.body, signals, dt, instants, normalised)
        if isinstance(node, always):
            return _window(body, first, last, np.minimum, _INF)
        return _window(body, first, last, np.maximum, -_INF)
    node = cast("Until", node)  # the one node left
    first, last = _samples(node.window, dt, instants, n)
    left = robustness(node.left, signals, dt, instants, normalised)
    right = robustness(node.right, signals, dt, instants, normalised)
    return _until(left, right, first, last)


def robustness_at_start(
    node: Node, signals: Mapping[str, FloatArray], dt: float, instants: Mapping[str, float]
) -> float:
    """:func:`robustness` at the first sample alone, a formula's value, over
    finite ``signals``: an outermost ``always`` or ``eventually`` is one pick
    over its window, not a pick at every sample (the same values picked: min
    and max round nothing, so the same bits), and of an atom, or of a window
    to the phase's end over one, one pick over the signal (:func:`_picked`)."""
    _, both, either, always, eventually = _nodes()
    if isinstance(node, (both, either)):
        left = robustness_at_start(node.left, signals, dt, instants)
        right = robustness_at_start(node.right, signals, dt, instants)
        return float((np.minimum if isinstance(node, both) else np.maximum)(left, right))
    if not isinstance(node, (always, eventually)):
        return float(robustness(node, signals, dt, instants)[0])
    n = len(next(iter(signals.values())))
    first, last = _samples(node.window, dt, instants, n)
    if last < first or first >= n:
        return _INF if isinstance(node, always) else -_INF
    picked = _picked(node, signals, dt, instants, n, first, min(last, n - 1))
    if picked is not None:
        return picked
    body = robustness(node.body, signals, dt, instants)[first : last + 1]
    return float(body.min() if isinstance(node, always) else body.max())


def _picked(
    node: Always | Eventually,
    signals: Mapping[str, FloatArray],
    dt: float,
    instants: Mapping[str, float],
    n: int,
    first: int,
    last: int,
) -> float | None:
    """The value of ``node`` over its samples ``first .. last`` (within the
    phase) where its body is an atom, or a window to the phase's end over one:
    None for any other body, and for a value of 0, whose sign the picks below
    may not keep.

    An atom's rho, (c - s) / |c| or (s - c) / |c|, rounds monotonically in s:
    its least over some samples is its rho at the signal's largest (or least),
    one pick over the signal and no array of rho. A window to the end over an
    atom, at sample k, picks over k + i .. n - 1: an ``always`` of it grows
    with k, an ``eventually`` shrinks, so the outer window's pick is the inner
    one's at its last sample (at its first where both pick alike). Only a 0
    has two signs: each other value has one set of bits, whichever sample
    gives it."""
    atom, _, _, always, eventually = _nodes()
    least = isinstance(node, always)
    body = node.body
    if not isinstance(body, atom):
        inner = body
        if not isinstance(inner, (always, eventually)) or not isinstance(inner.body, atom):
            return None
        start, stop = _samples(inner.window, dt, instants, n)
        if stop < n - 1 or stop < start:
            return None
        inner_least = isinstance(inner, always)
        k = first if inner_least == least else last
        if k + start >= n:
            return _INF if inner_least else -_INF
        first, least, body = k + start, inner_least, inner.body
        last = n - 1
    values = signals[body.signal][first : last + 1]
    # the least rho at the largest signal, unless the atom bounds it from below
    s = float(values.max() if least != body.above else values.min())
    rho = (s - body.bound if body.above else body.bound - s) / (abs(body.bound) or 1.0)
    return rho if rho != 0.0 else None


def _samples(window: Window, dt: float, instants: Mapping[str, float], n: int) -> tuple[int, int]:
    """The window's first and last sample from the one it is read at (last = n:
    to the phase's end)."""

    start, stop = window.start, window.stop
    start = start if isinstance(start, float) else instants.get(start, _INF)
    stop = stop if isinstance(stop, float) else instants.get(stop, _INF)
    first = math.ceil(start / dt - 1e-9)
    last = n if stop >= n * dt else math.floor(stop / dt + 1e-9)
    return min(first, n), min(last, n)


def _window(
    values: FloatArray,
    first: int,
    last: int,
    pick: Callable[..., FloatArray],
    empty: float,
) -> FloatArray:
    """``pick`` (np.minimum or np.maximum) of ``values[k + first .. k + last]``
    at each k, the samples past the end counted as ``empty``."""
    n = values.size
    if first == 0 and last >= n - 1 and n:  # from each sample to the end: no padding
        running: FloatArray = pick.accumulate(values[::-1])[::-1]  # type: ignore[attr-defined]
        return running
    out = np.full(n, empty)
    if last < first or first >= n:
        return out
    if last >= n - 1:  # to the phase's end: the running pick from the end
        out[: n - first] = pick.accumulate(values[first:][::-1])[::-1]  # type: ignore[attr-defined]
        return out
    width = last - first + 1
    # van Herk: in blocks of `width`, the running pick from each block's start
    # and from its end; a window spans at most two blocks.
    blocks = -(-(n + width) // width)
    padded = np.full(blocks * width, empty)
    padded[:n] = values
    shaped = padded.reshape(blocks, width)
    ahead = pick.accumulate(shaped, axis=1).ravel()  # type: ignore[attr-defined]
    behind = pick.accumulate(shaped[:, ::-1], axis=1)[:, ::-1].ravel()  # type: ignore[attr-defined]
    out[: n - first] = pick(behind[first:n], ahead[first + width - 1 : n + width - 1])
    return out


def _until(left: FloatArray, right: FloatArray, first: int, last: int) -> FloatArray:
    """``left until[first, last] right`` at every sample, as the docstring's
    definition: for the window [i, j], min(always[0, i - 1] left, (left until
    right) and eventually[0, j - i] right, read i samples on). The second is
    the bounded until from each sample (a bound on the untimed one, met by a
    right side within the window: the larger of the two picks is the
    window's)."""
    n = left.size
    if last < first or first >= n:
        return np.full(n, -_INF)
    from_here = np.minimum(
        _unbounded_until(left, right), _window(right, 0, last - first, np.maximum, -_INF)
    )
    shifted = np.full(n, -_INF)
    shifted[: n - first] = from_here[first:]
    if first == 0:
        return shifted
    found: FloatArray = np.minimum(_window(left, 0, first - 1, np.minimum, _INF), shifted)
    return found


def _unbounded_until(left: FloatArray, right: FloatArray) -> FloatArray:
    """rho(k) = max(right[k], min(left[k], rho(k + 1))), rho(n) = -inf, as a
    doubling scan: each step is the clamp x -> max(p, min(q, x)), and two
    clamps make one, (p1, q1) after (p2, q2) = (max(p1, min(q1, p2)), min(q1, q2))."""
    p, q = right.copy(), left.copy()
    step = 1
    while step < p.size:
        later_p, later_q = p[step:], q[step:]
        p[:-step] = np.maximum(p[:-step], np.minimum(q[:-step], later_p))
        q[:-step] = np.minimum(q[:-step], later_q)
        step *= 2
    return p  # each clamp applied to rho(n) = -inf


def phase_formulas(mission: Mapping[str, Any] | None, phase_name: str) -> tuple[str, ...]:
    """The formulas in force in a phase (its name as run, ``name#lap`` in a
    repeat; a contingency's too): its own `expect`'s ``temporal``, else the mission's."""
    written = phase_name.split("#", 1)[0]
    shared = ((mission or {}).get("expect") or {}).get("temporal")
    for _, phase in written_phases(mission):
        if str(phase.get("name")) == written:
            own = (phase.get("expect") or {}).get("temporal")
            return tuple(own if own is not None else shared or ())
    return tuple(shared or ())


def phase_values(
    result: RunRecord,
    info: PhaseRecord,
    window: slice,
    settle_time: float,
    numbers: MissionNumbers,
    mission: Mapping[str, Any] | None,
    placement: Callable[[], Placement | None] | None = None,
    formulas: tuple[str, ...] | None = None,
    known: Callable[[], Known] | None = None,
    entry: Callable[[], float] | None = None,
) -> dict[str, Any]:
    """``{"temporal": {formula: rho}}`` for a phase's summary (nothing when it
    has no formula; ``formulas``: its :func:`phase_formulas`, if at hand): rho
    None where a signal it names is not finite at some sample (a divergence) or
    the formula fails over an empty window; a formula is left out where the
    phase does not measure a signal it names (a mission-wide formula on a phase
    of another kind), or where it holds over an empty window (nothing to judge).
    ``entry``: [s] the entry its tracking leaves out (``entry_time``), where a
    window names it (0 without)."""
    formulas = phase_formulas(mission, info.name) if formulas is None else formulas
    if not formulas:
        return {}
    signals = PhaseSignals(result, info, window, numbers, placement, known)
    values: dict[str, float | None] = {}
    past_end: list[str] = []  # decided by a window with no sample: it lies past the end
    for text in formulas:
        node, names = _read(text)
        named = {name: signals.get(name) for name in names}
        arrays = {name: a[: signals.end] for name, a in named.items() if a is not None}
        if len(arrays) < len(named):  # a signal the phase does not measure
            continue
        if not all(map(_finite, arrays.values())):
            values[text] = None
            continue
        # the entry's end where a window names it: the one its tracking leaves out
        instants = {"entry": entry() if entry and "entry" in text else 0.0, "settle": settle_time}
        rho = robustness_at_start(node, arrays, numbers.dt, instants)
        if rho == _INF:
            continue
        if rho == -_INF:  # finite signals: only a window with no sample gives -inf
            past_end.append(text)
        values[text] = rho if math.isfinite(rho) else None
    if not values:
        return {}
    return {"temporal": values, **({PAST_END: past_end} if past_end else {})}


def _finite(values: FloatArray) -> bool:
    """Whether every value is finite: their sum is finite only then (or, where
    it overflows, each is looked at)."""
    return math.isfinite(np.add.reduce(values)) or bool(np.isfinite(values).all())


def panel_of(formula: str) -> str:
    """The panel a formula's check is drawn on: its first signal's."""
    from wmr_mission.spec.temporal import SIGNALS, Always, Atom, Eventually, parse_formula

    node = parse_formula(formula)
    while not isinstance(node, Atom):
        node = node.body if isinstance(node, Always | Eventually) else node.left
    return SIGNALS[node.signal].panel


# A phase summary's key beside ``temporal``: the formulas whose value (null)
# a window past the phase's end decided, -inf, which JSON does not hold.
PAST_END = "temporal_past_end"
_PAST_END_ADVICE = (
    "{formula}: a window of it lies past the end of phase {phase!r}, where it has no "
    "sample and `eventually` fails (-inf); start the window within the phase, or make "
    "the phase last longer"
)


def formula_checks(phase: Mapping[str, Any]) -> list[Check]:
    """A phase summary's formulas as checks: ``rho >= 0``, their value the
    formula's rho, which is then their margin; one a window past the phase's
    end decided says so in its advice."""
    name = str(phase.get("name"))
    values = phase.get("temporal") or {}
    past_end = set(phase.get(PAST_END) or ())
    return [
        Check(
            text,
            name,
            0.0,
            value,
            _PAST_END_ADVICE.format(formula=text, phase=name) if text in past_end else None,
            lower=True,
        )
        for text, value in values.items()
    ]


class PhaseSignals:
    """The signals of one phase, computed when a formula names them (None: the
    phase does not measure it)."""

    def __init__(
        self,
        result: RunRecord,
        info: PhaseRecord,
        window: slice,
        numbers: MissionNumbers,
        placement: Callable[[], Placement | None] | None = None,
        known: Callable[[], Known] | None = None,
    ) -> None:
        self.result, self.info, self.window, self.numbers = result, info, window, numbers
        self._known = known  # the phase's reference_known, if at hand
        self._found: dict[str, FloatArray | None] = {}
        # the places on the path of the samples whose reference is known (None:
        # none, or a position not finite), shared with the phase's metrics
        self._placement = placement

    @cached_value
    def end(self) -> int:
        """One past the last sample the phase's formulas judge: a track phase's
        last whose reference point is known (one that ends the run has none
        at the run's last sample, as its tracking and its final error have it:
        its formulas on the path read no NaN there), else the phase's last."""
        w = self.window
        size = int(w.stop - w.start)
        if self.info.kind != "track":
            return size
        r = self.result
        known, these = (
            self._known() if self._known is not None else reference_known(r.x_ref[w], r.y_ref[w])
        )
        if these is None or not known.size or known[-1] or not known.any():
            return size  # every one known, or the last, or none: the whole phase
        return int(np.flatnonzero(known)[-1]) + 1

    def get(self, name: str) -> FloatArray | None:
        if name not in self._found:
            self._found |= self._measured(name)
        return self._found.get(name)

    def _measured(self, name: str) -> dict[str, FloatArray | None]:
        r, w, info = self.result, self.window, self.info
        if name in ("cross_track", "lag"):
            return self._on_path()
        if name in ("zone_depth", "clearance"):
            zones = zones_of(info.constraints, r.regions)
            if not zones:
                return {"zone_depth": None, "clearance": None}
            depth = np.max([zone.depth(r.x[w], r.y[w]) for zone in zones], axis=0)
            return {"zone_depth": depth, "clearance": -depth - self.numbers.body}
        if name in ("target_distance", "heading_error"):
            if info.target is None or info.kind == "track":
                return {"target_distance": None, "heading_error": None}
            tx, ty, heading = self._aims()
            if name == "target_distance":
                return {name: np.hypot(r.x[w] - tx, r.y[w] - ty)}
            turned = r.theta[w] - heading
            return {name: np.abs((turned + np.pi) % (2.0 * np.pi) - np.pi)}
        if name == "speed":
            return {name: np.abs(r.v[w])}
        return {name: np.abs(r.omega[w])}  # turn_rate

    def _aims(self) -> tuple[Any, Any, Any]:
        """The target in force at each sample (x, y, heading): an update may
        move it; numbers when one is in force throughout."""
        w, info = self.window, self.info
        stretches = info.targets_in_force(w.start, w.stop)
        if len(stretches) == 1 and stretches[0][:2] == (w.start, w.stop):
            return stretches[0][2]
        aims = np.repeat(np.array([info.target]), w.stop - w.start, axis=0)
        for first, stop, aim in stretches:
            aims[first - w.start : stop - w.start] = aim
        return tuple(aims.T)

    def _on_path(self) -> dict[str, FloatArray | None]:
        """The cross-track error and the lag at every sample of a track phase,
        the entry's included (NaN where the reference is unknown)."""
        r, w, numbers = self.result, self.window, self.numbers
        if self.info.kind != "track":
            return {"cross_track": None, "lag": None}
        if self._known is not None:
            known, these = self._known()
        else:
            known, these = reference_known(r.x_ref[w], r.y_ref[w])
        if not (these is None and known.size) and not known.any():  # (None: every one known)
            return {"cross_track": None, "lag": None}
        placement = self._placement() if self._placement is not None else placed(r, w)
        if placement is None:
            return {"cross_track": np.full(known.size, np.nan), "lag": np.full(known.size, np.nan)}
        if these is None:  # every one known: on_path's own new arrays, no copy into the phase's
            cross, lag = placement.on_path(numbers.tracking_tolerance)
        else:
            cross, lag = np.full(known.size, np.nan), np.full(known.size, np.nan)
            cross[known], lag[known] = placement.on_path(numbers.tracking_tolerance)
        return {"cross_track": cross, "lag": lag}


def placed(result: RunRecord, window: slice, known: Known | None = None) -> Placement | None:
    """The places on the path of a phase's samples whose reference is known
    (None where none is, or where a position is not finite); ``known``: the
    phase's :func:`reference_known`, if at hand."""
    r = result
    return placed_known(r.x[window], r.y[window], r.x_ref[window], r.y_ref[window], known)[1]
