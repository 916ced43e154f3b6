"""The phase state machine around the compiled loop.

The fixed-step loop itself (plant, sensors, estimator, controller, exit
conditions, recording, divergence checks) is :func:`wmr_mission.kernels.loop.run_segment`.
This module runs it chunk by chunk: it enters phases (instantiating paths
from the estimated pose), samples each track phase's path ahead, draws the
noise and disturbances ahead, records transitions, reports progress between chunks,
and turns Ctrl-C into an ``interrupted`` result holding every sample so far.
"""

from __future__ import annotations

import functools
import math
import time
from collections.abc import Callable, Generator, Mapping
from dataclasses import replace
from enum import StrEnum
from typing import Any

import numpy as np
from numpy.lib.stride_tricks import sliding_window_view

from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.controllers.constrained_tracking import (
    AIM_GAP,
    PASS_POINTS,
    WAY_COLUMNS,
    WAY_HEAD,
    comes_near,
    kept_out,
    nearest_chords,
    pass_points,
    pass_reach,
    way_at,
)
from wmr_mission.geometry.paths import Trajectory
from wmr_mission.geometry.routes import TURN_CREEP
from wmr_mission.kernels import jit, loop, scalar_math
from wmr_mission.kernels.corrective import max_row_value
from wmr_mission.kernels.loop import FLOAT_COLUMNS, EnteredPhase, PathBlock, Recording, Signals
from wmr_mission.kernels.model import preview_rows, wrap_angle
from wmr_mission.kernels.resident import LONG_RUN, give_back_compiler_pages
from wmr_mission.output.result import RunResult
from wmr_mission.plugins import failure_message
from wmr_mission.record import Outcome, PhaseRecord, Transition
from wmr_mission.sim.draws import Draws
from wmr_mission.sim.plan import MissionPlan, PhasePlan, UpdatePlan, plan_mission
from wmr_mission.sim.plant_side import PlantSide, PlantStopped
from wmr_mission.sim.reactions import (
    Breach,
    Decision,
    Reactor,
    breach_at,
    missed_verdicts,
    nearest_ahead,
)
from wmr_mission.spec.checks import distance_to, importing_entries
from wmr_mission.spec.loader import validate_mission
from wmr_mission.spec.models import Mission
from wmr_mission.stopping import HOLD, RAISE, stop_owed
from wmr_mission.stopping import mode as stop_mode
from wmr_mission.verdicts import recovery
from wmr_mission.verdicts.metrics import judge_mission

# Samples per call of the compiled loop: between calls the runner reports
# progress and Ctrl-C gets in (a few milliseconds apart when compiled). The
# run's first call where its first samples are awaited, and a track phase
# whose end cannot be foreseen, start with shorter chunks: the first samples
# come at once (as plain Python too), and a short phase samples little path
# ahead (PhaseRun.first_chunk). A call costs some 50 us compiled (its
# arguments, a path block), as much as sampling 500 rows more of an
# expression path (case 2's spiral: 257 rows 65 us, 513 rows 91 us, 1 025
# rows 145 us), so such a phase starts at UNFORESEEN_CHUNK: keep-out makes
# 14 calls, not 17.
CHUNK = 4096
FIRST_CHUNK = 256
UNFORESEEN_CHUNK = 512
# [s] how far ahead of where it was left a resumed phase looks for its path.
RESUME_HORIZON = 120.0
# The path a track phase's ways round its zones are decided on: over its bound
# (timeout or elapsed), at most WAY_HORIZON samples of it, at WAY_SAMPLES
# points, then as many about the nearest (a 30 s phase at 1 m/s: chords of
# 23 cm, then 5 mm).
WAY_HORIZON = 2**20
WAY_SAMPLES = 128
# The path's samples the pass of a way round is taken from (Run._pass).
PASS_SAMPLES = 129
# Largest recorder pre-sized from the mission's sample budget; it grows beyond.
MAX_PRESIZED = 2_000_000
NEVER = 2**62  # the sample a run that is not a session pauses at


class Status(StrEnum):
    pending = "pending"
    running = "running"
    done = "done"
    timed_out = "timed-out"


class Recorder:
    """Pre-sized columns (wmr_mission.kernels.loop.Recording), one row per sample; grows
    by doubling if a run outlasts its estimate. Columns are contiguous, so the
    result hands them out as views, without copying."""

    def __init__(self, capacity: int) -> None:
        self.record = self._allocate(max(16, capacity))

    @staticmethod
    def _allocate(capacity: int) -> Recording:
        # np.empty: pages a short run never writes are never touched.
        return Recording(
            np.empty((len(FLOAT_COLUMNS), capacity)).T,
            np.empty(capacity, dtype=np.int64),
            np.empty(capacity, dtype=np.int64),
            np.empty(capacity, dtype=np.int64),
            np.zeros(1, dtype=np.int64),
        )

    @property
    def count(self) -> int:
        return int(self.record.rows[0])

    def reserve(self, rows: int) -> None:
        """Room for ``rows`` more rows."""
        old = self.record
        capacity = old.phase.shape[0]
        if self.count + rows <= capacity:
            return
        grown = self._allocate(max(2 * capacity, self.count + rows))
        n = self.count
        grown.floats[:n] = old.floats[:n]
        for new, kept in zip(grown[1:4], old[1:4], strict=True):
            new[:n] = kept[:n]
        grown.rows[0] = n
        self.record = grown


class Retimed:
    """A path run from its own time ``start`` [s] at ``rate`` times its pace:
    the same curve, the reference moving ``rate`` times as fast."""

    def __init__(self, path: Trajectory, start: float, rate: float) -> None:
        self.path, self.start, self.rate = path, start, rate

    def sample(self, t: Any) -> tuple[FloatArray, FloatArray, FloatArray, FloatArray]:
        x, y, dx, dy = self.path.sample(self.start + self.rate * np.asarray(t, dtype=np.float64))
        return x, y, self.rate * dx, self.rate * dy


class PhaseRun:
    """One phase's lifecycle in a run: ``enter`` at its first sample gives the
    record the compiled loop runs it with; ``path_ahead`` samples its path."""

    def __init__(self, phase: PhasePlan, mission: MissionPlan, index: int) -> None:
        self.phase = phase
        self.mission = mission
        self.index = index
        self.status = Status.pending
        self.entry_sample = 0
        self.target = np.zeros(3)
        # the way round each of its zones, for the path in force (EnteredPhase.ways_round)
        self.ways = np.zeros((phase.constraint_rows[0].shape[0], WAY_COLUMNS))
        self._trajectory: Trajectory | None = None
        # The rows of its path sampled last: the path's sample of the first, the rows.
        self._sampled: tuple[int, FloatArray] = (0, np.zeros((0, 4)))
        # Samples the path is ahead of the phase's clock: where a resumed phase
        # rejoined its path (wmr_mission.sim.reactions.nearest_ahead).
        self.path_shift = 0
        self.left_at = 0  # the path's sample the phase was last left at
        # Its reference (docs/mission-format.md, "References that change on-line"):
        # the updates written that took over, the number of the reference in
        # force (0: its own), and the target in force.
        self.fired = 0
        self.reference = 0
        self.target_in_force = phase.target
        # the path in force as made, its written pace, and where (its own time
        # [s]) and how fast (a factor) a speed update runs it; the controller's
        # tuning in force (None: the mission's)
        self._made: Trajectory | None = None
        self.pace = phase.pace
        self.warp = (0.0, 1.0)
        self.tuning: Any = None
        # Samples after which the phase ends for sure (elapsed or timeout).
        bounds = [phase.until.elapsed_samples, phase.timeout_samples]
        self.bound = min((b for b in bounds if b is not None), default=2**62)
        # Its first chunk: short only for a track phase whose end cannot be
        # foreseen (a condition other than elapsed and timeout), so it samples
        # little path it never uses; any other phase runs to its bound (or
        # CHUNK) per call.
        until = phase.until
        conditions = (until.mission_time, until.reaches, until.near, until.settled, until.heading)
        unforeseen = phase.kind == "track" and any(c is not None for c in conditions)
        self.first_chunk = min(UNFORESEEN_CHUNK, CHUNK) if unforeseen else CHUNK

    def enter(self, k: int, estimate: FloatArray, resume_from: int | None = None) -> EnteredPhase:
        """The phase entered at sample k; ``resume_from`` (the path's sample the
        phase was left at) keeps its path, rejoined where it passes nearest ahead."""
        self.status = Status.running
        self.entry_sample = k
        pose = (float(estimate[0]), float(estimate[1]), float(estimate[2]))
        phase = self.phase
        self.path_shift = 0
        if resume_from is None:  # a phase entered afresh takes its own reference again
            self.fired = self.reference = 0
            self.target_in_force = phase.target
            self.pace, self.warp, self.tuning = phase.pace, (0.0, 1.0), None
        if phase.kind == "track" and resume_from is not None and self._trajectory is not None:
            horizon = min(self.bound, round(RESUME_HORIZON / self.mission.dt))
            self.path_shift = nearest_ahead(
                self._trajectory.sample, resume_from, horizon, self.mission.dt, *pose[:2]
            )
        elif phase.kind == "track":
            assert phase.make_trajectory is not None
            self._trajectory = self._made = phase.make_trajectory(pose)
            self._sampled = (0, np.zeros((0, 4)))
            self._find_ways()
        self.target[:] = self.target_in_force or pose
        until = phase.until
        reaches_kinds, reaches_params = until.reaches_rows
        reaches_sign = 0.0
        if reaches_kinds.shape[0]:
            reaches_sign = math.copysign(
                1.0, _max_row_value(reaches_kinds, reaches_params, pose[0], pose[1])
            )
        kinds, params = phase.constraint_rows
        return EnteredPhase(
            number=self.index,
            tracking=phase.kind == "track",
            entry_sample=k,
            target=self.target,
            constraint_kinds=kinds,
            constraint_params=params,
            ways_round=self.ways,
            elapsed_samples=-1 if until.elapsed_samples is None else until.elapsed_samples,
            mission_time=math.nan if until.mission_time is None else until.mission_time,
            reaches_kinds=reaches_kinds,
            reaches_params=reaches_params,
            reaches_sign=reaches_sign,
            near=np.array(until.near if until.near is not None else (math.nan,) * 3),
            settled=np.array(until.settled if until.settled is not None else (math.nan,) * 3),
            heading=np.array(until.heading if until.heading is not None else (math.nan,) * 2),
            timeout_samples=-1 if phase.timeout_samples is None else phase.timeout_samples,
        )

    @property
    def pending(self) -> UpdatePlan | None:
        """The update the phase watches for: the first that has not taken over."""
        updates = self.phase.updates
        return updates[self.fired] if self.fired < len(updates) else None

    def take_over(self, k: int, estimate: FloatArray, update: UpdatePlan) -> None:
        """``update`` takes over at sample k: its path, made from the estimated
        pose x_{k|k}, restarts at its own t = 0 at sample k; its target is the
        phase's from sample k (docs/paper-notes.md, "References that change on-line")."""
        if update.controller_tuning is not None:  # first: the ways round read its look-ahead
            self.tuning = update.controller_tuning
        if update.make_trajectory is not None:
            pose = (float(estimate[0]), float(estimate[1]), float(estimate[2]))
            self._trajectory = self._made = update.make_trajectory(pose)
            self._sampled = (0, np.zeros((0, 4)))
            self.path_shift = self.entry_sample - k
            self.pace, self.warp = update.pace, (0.0, 1.0)
            self._find_ways()
        if update.speed is not None and self._made is not None and self.pace:
            # the same path on from the reference point in force, its own time
            # running speed / pace as fast (docs/mission-format.md)
            start, rate = self.warp
            now = start + rate * (k - self.entry_sample + self.path_shift) * self.mission.dt
            self.warp = (now, update.speed / self.pace)
            self._trajectory = Retimed(self._made, *self.warp)
            self._sampled = (0, np.zeros((0, 4)))
            self.path_shift = self.entry_sample - k
        if update.hold and self.phase.kind == "regulate":
            self.target_in_force = (float(estimate[0]), float(estimate[1]), float(estimate[2]))
            self.target[:] = self.target_in_force
        if update.target is not None:
            self.target_in_force = update.target
            self.target[:] = update.target  # the array the loop reads (EnteredPhase.target)
        self.reference += 1

    def _find_ways(self) -> None:
        """The way round each keep-out zone of the path just made, decided
        once (constrained_tracking.ways_round): from the path over the
        phase's bound, at WAY_SAMPLES points, and again at WAY_SAMPLES
        points over the two chords about the one nearest each zone, the
        path sampled once for all zones each time."""
        assert self._trajectory is not None
        self.ways[:] = 0.0  # none of an earlier path's: where this one never moves, none
        kinds, params = self.phase.constraint_rows
        if not kinds.shape[0]:  # no zone: a campaign's run enters such phases by the thousand
            return
        keep_out, centres = kept_out(kinds, params)
        if not keep_out.size:
            return
        samples = min(self.bound, WAY_HORIZON)
        t = np.linspace(0.0, samples * self.mission.dt, min(samples, WAY_SAMPLES) + 1)
        x, y, speed = self._path_points(t)
        chords, shares = nearest_chords(x, y, centres[:, 0], centres[:, 1])
        moving = chords >= 0
        keep_out, centres = keep_out[moving], centres[moving]
        chords, shares = chords[moving], shares[moving]
        if not keep_out.size:
            return
        whole = (x, y, chords, shares)  # the path over the bound, for the passes
        # where the path last rests before each zone, of these samples: holds
        # its position, as a route turning in place at a stop does (creeping
        # at TURN_CREEP)
        resting = speed <= TURN_CREEP
        rests = [np.flatnonzero(resting[: k + 1]) for k in chords.tolist()]
        rest_points = [(x[r[-1]], y[r[-1]]) if r.size else None for r in rests]
        last = t.size - 1
        near = np.array(  # a row a zone
            [np.linspace(t[max(k - 1, 0)], t[min(k + 2, last)], WAY_SAMPLES + 1) for k in chords]
        )
        x, y, speed = (np.reshape(z, near.shape) for z in self._path_points(near.ravel()))
        chords, shares = nearest_chords(x, y, centres[:, 0], centres[:, 1])
        clear = self._clear()
        for j, i in enumerate(keep_out.tolist()):
            kind = int(kinds[i])
            near_and_whole = ((x[j], y[j]), whole[:2])
            # the path about its chord nearest the zone's centre, and over the
            # whole bound: a long zone's end may be where the path passes it
            if not any(comes_near(kind, params[i], px, py, clear) for px, py in near_and_whole):
                continue  # never near over the phase's bound: no way round it
            k, share = int(chords[j]), float(shares[j])
            way = way_at(x[j], y[j], k, share, kind, params[i])
            if k >= 0:
                way[5] = speed[j, k] + share * (speed[j, k + 1] - speed[j, k])
                rest = rest_points[j]
                if rest is not None:
                    way[6] = max(way[2] * (way[0] - rest[0]) + way[3] * (way[1] - rest[1]), 0.0)
                t_near = near[j, k] + share * (near[j, k + 1] - near[j, k])
                reach = pass_reach(int(kinds[i]), params[i])
                way[WAY_HEAD:] = self._pass(t_near, way, reach, whole, j)
            self.ways[i] = way

    def _clear(self) -> float:
        """[m] How near a keep-out zone the phase's path may pass with no
        way round it: the margin kept round every zone, the look-ahead of
        the controller's tuning in force (0 for one without) and the aim's
        gap beyond them (AIM_GAP at most). A zone the path over the phase's
        bound stays this far from needs no ramp: on the tangent line of the
        path's point nearest it, a zone the path reached only after the
        phase's end was ramped towards (docs/paper-notes.md, eq. (28), "No
        way round a zone the phase does not reach")."""
        tuning = self.tuning if self.tuning is not None else self.mission.controller_tuning
        look_ahead = float(getattr(tuning, "look_ahead", 0.0))
        return float(self.mission.plant.constraint_margin) + look_ahead + AIM_GAP

    def _pass(
        self,
        t_near: float,
        way: FloatArray,
        reach: float,
        whole: tuple[FloatArray, FloatArray, IntArray, FloatArray],
        j: int,
    ) -> FloatArray:
        """The pass of a way round (constrained_tracking.pass_points), evenly
        along the path: from ``whole``, the path over the bound (x, y, and
        each zone's nearest chord and share of it), where its chord there is
        a sixteenth of the pass's ``reach`` or shorter; else from the path about
        its time ``t_near``, PASS_SAMPLES points over twice the time its
        speed there takes to cover that reach (the whole bound where it rests
        there). Read again, the path cost keep-out.yaml's loop 9 % more."""
        x, y, chords, shares = whole
        k = int(chords[j])
        if math.hypot(x[k + 1] - x[k], y[k + 1] - y[k]) <= reach / 16.0:
            return pass_points(x, y, k, float(shares[j]), reach)
        end = min(self.bound, WAY_HORIZON) * self.mission.dt
        span = 2.0 * reach / way[5] if way[5] > 0.0 else end
        t = np.linspace(max(t_near - span, 0.0), min(t_near + span, end), PASS_SAMPLES)
        x, y, _ = self._path_points(t)
        chords, shares = nearest_chords(x, y, way[:1], way[1:2])
        if chords[0] < 0:  # the path rests there throughout
            rests = [np.full(PASS_POINTS, way[0]), np.full(PASS_POINTS, way[1]), np.zeros(2)]
            return np.concatenate(rests)
        return pass_points(x, y, int(chords[0]), float(shares[0]), reach)

    def _path_points(self, t: FloatArray) -> tuple[FloatArray, FloatArray, FloatArray]:
        """The path's points at its times ``t``, and its speed there."""
        assert self._trajectory is not None
        with np.errstate(all="ignore"):  # a diverging path is followed as far as it is finite
            x, y, dx, dy = self._trajectory.sample(t)
            speed = np.hypot(dx, dy)
        return x, y, speed

    @property
    def tracks_a_path(self) -> bool:
        return self._trajectory is not None

    def path_ahead(self, local_sample: int, rows: int, wanted: int = 0) -> PathBlock:
        """The path at phase-local samples ``local_sample`` onwards: point and
        unit tangent (NaN where the path rests). ``wanted`` rows (more than
        ``rows``) are sampled where a session pauses the loop sooner than a run
        would, and the calls that follow take them from there."""
        if self._trajectory is None or rows == 0:
            return PathBlock(local_sample, np.zeros((0, 4)))
        start = local_sample + self.path_shift  # the path's own sample
        first, block = self._sampled
        if not first <= start <= start + rows <= first + block.shape[0]:
            first, block = self._sampled = start, self._sample(start, max(rows, wanted))
        return PathBlock(local_sample, block[start - first : start - first + rows])

    def _sample(self, start: int, rows: int) -> FloatArray:
        """The path's rows; under a turn-rate acceleration limit each row also
        holds the path as previewed (previewed)."""
        limits, dt = self.mission.plant.limits, self.mission.dt
        half = preview_rows(limits, dt)
        if half == 0:
            return self._sample_rows(start, rows)
        around = self._sample_rows(start - half, rows + 2 * half, at_rest_before=True)
        return previewed(around, half, float(limits[3]) * dt * dt)

    def _sample_rows(self, start: int, rows: int, at_rest_before: bool = False) -> FloatArray:
        assert self._trajectory is not None
        t = (start + np.arange(rows, dtype=np.float64)) * self.mission.dt
        if at_rest_before:  # before its start the path is where it starts
            t = np.maximum(t, 0.0)
        x, y, dx, dy = self._trajectory.sample(t)
        block = np.empty((rows, 4))
        block[:, 0] = x
        block[:, 1] = y
        speed = np.hypot(dx, dy)
        moving = speed > 1e-12
        np.divide(dx, speed, out=block[:, 2], where=moving)
        np.divide(dy, speed, out=block[:, 3], where=moving)
        if not moving.all():  # only where it rests: numpy fills two columns slowly
            block[~moving, 2:] = np.nan
        return block


def previewed(rows: FloatArray, half: int, turn_step: float) -> FloatArray:
    """The path's rows (point, unit tangent) from ``half`` rows in to
    ``half`` from the end, each followed by the path previewed there: its
    tangent the mean of the tangents over a window either side, its point
    moved across the path by the mean's (along it, where the path's timing
    puts it). The window is half the time the turn-rate acceleration limit
    (``turn_step``: the limit times dt^2) takes from rest to the path's
    sharpest turn rate nearby (turn_windows): a step of the path's turn rate
    becomes a ramp at that limit centred on the step, and a short arc the
    trapezoid (or triangle) of turn rate that turns the arc's angle
    (docs/paper-notes.md, eq. (27), "The path's turn previewed"). Each row's
    mean is summed over its own window, in the same order whichever block
    it is sampled in, so a run's bytes do not depend on where its chunks
    start."""
    count = rows.shape[0] - 2 * half
    tangents = np.nan_to_num(rows[:, 2:])  # a resting row's turns nothing
    windows = turn_windows(rows[:, 2:], half, turn_step)
    means = np.empty((count, 4))
    for reach in np.unique(windows).tolist():
        at = np.flatnonzero(windows == reach)
        width = 2 * reach + 1
        taken = (at + half - reach)[:, None] + np.arange(width)
        means[at, :2] = rows[taken, :2].sum(axis=1) / width
        means[at, 2:] = tangents[taken].sum(axis=1)
    block = np.empty((count, 8))
    block[:, :4] = rows[half : half + count]
    tx, ty = block[:, 2], block[:, 3]
    resting = np.isnan(tx)
    across = (means[:, 1] - block[:, 1]) * tx - (means[:, 0] - block[:, 0]) * ty
    block[:, 4] = np.where(resting, block[:, 0], block[:, 0] - across * ty)
    block[:, 5] = np.where(resting, block[:, 1], block[:, 1] + across * tx)
    norm = np.hypot(means[:, 2], means[:, 3])
    turned = norm > 1e-9
    with np.errstate(invalid="ignore", divide="ignore"):
        block[:, 6] = np.where(turned, means[:, 2] / norm, np.nan)
        block[:, 7] = np.where(turned, means[:, 3] / norm, np.nan)
    return block


def turn_windows(tangents: FloatArray, half: int, turn_step: float) -> IntArray:
    """Per row from ``half`` in, how many rows either side its previewed
    tangent is averaged over: the path's sharpest turn per row within
    ``half`` rows either side over twice ``turn_step`` (the turn-rate
    acceleration limit times dt^2), half the rows the limit ramps the turn
    rate from rest to it in, so that the mean ramps a step of the path's
    turn rate at the limit, centred on the step. A line stays a line
    whatever its window; an arc's point is moved in by the same window all
    along it. At most ``half`` (the turn-rate limit's own ramp,
    preview_rows), and ``half`` where the path rests within it (a turn in
    place, or its start: no turn rate to ramp from)."""
    tx, ty = tangents[:, 0], tangents[:, 1]
    turns = np.arctan2(tx[:-1] * ty[1:] - ty[:-1] * tx[1:], tx[:-1] * tx[1:] + ty[:-1] * ty[1:])
    sharpest = sliding_window_view(np.abs(turns), 2 * half, axis=0).max(axis=1)  # NaN: at rest
    reach = np.minimum(np.rint(sharpest / (2.0 * turn_step)), half)
    return np.where(np.isnan(sharpest), half, reach).astype(np.intp)


# Per compiled loop, its entry point once it has one: found from the
# dispatcher's overloads by their signature, which hashes numba's types of
# every argument in Python (some 40 us, as much as the call it saves).
_entry_points: dict[int, tuple[Any, Callable[..., int]]] = {}


def _entry_point(dispatcher: Any) -> Callable[..., int] | None:
    """The compiled entry point of ``dispatcher`` if it has compiled one
    signature alone (the one it just typed); else None, and for a loop run as
    plain Python (no overloads)."""
    overloads = getattr(dispatcher, "overloads", None)
    if overloads is None or len(overloads) != 1:
        return None
    kept = _entry_points.get(id(dispatcher))
    if kept is None or kept[0] is not dispatcher:
        overload = next(iter(dispatcher.overloads.values()))
        kept = _entry_points[id(dispatcher)] = (dispatcher, overload.entry_point)
    return kept[1]


def _phase_types(phase: EnteredPhase) -> tuple[Any, ...]:
    """What numba types a phase by (numba.typeof): each field's class and, of
    an array, its dtype, dimensions, order, and whether it is writeable and
    aligned. Phases with the same are one type to the compiled loop."""
    return tuple(
        (v.dtype, v.ndim, v.flags.num & _TYPED_FLAGS) if type(v) is np.ndarray else type(v)
        for v in phase
    )


# Numpy's flags numba types an array by: C and Fortran order, aligned, writeable.
_TYPED_FLAGS = 0x1 | 0x2 | 0x100 | 0x400


# Called once per phase or run: plain Python (wmr_mission.kernels.jit.plain).
_max_row_value = jit.plain(max_row_value)
_record_sample = jit.plain(loop.record_sample)


ProgressCallback = Callable[[float, float, str], None]


@functools.cache
def bound_loop(estimator_step: Callable[..., int], control_step: Callable[..., None]) -> Any:
    """The loop for one estimator and one controller: ``run_segment`` with
    their steps bound to the names it calls them by (wmr_mission.kernels.variants),
    one copy per pair, so each is compiled and cached once."""
    return jit.bind(
        loop.run_segment, {"estimator_step": estimator_step, "control_step": control_step}
    )


def run_mission(
    mission: Mission | MissionPlan,
    *,
    seed: int | None = None,
    progress: ProgressCallback | None = None,
    substitutes: Mapping[Any, Callable[..., Any]] | None = None,
    plant: PlantSide | None = None,
    ready: Callable[[], None] | None = None,
) -> RunResult:
    """Simulate ``mission`` and return every sample as arrays.

    A :class:`Mission` is checked first exactly as a mission file is (raises
    ``MissionError``), and the run is judged by its ``expect`` thresholds, as
    ``wmr-mission run`` does. ``progress(t, t_budget, phase_name)`` is called
    between chunks of samples. The run stops cleanly on a timeout with
    ``on_timeout: fail``, on divergence and on Ctrl-C (outcome
    ``interrupted``); what was produced up to then is in the result. A
    mission's reactions (a timeout, a geofence breach, a missed verdict) are
    decided between chunks (wmr_mission.sim.reactions).

    ``substitutes`` replaces kernels by functions of the same signature (the
    reference step, wmr_mission.sim.reference.REFERENCE): the loop then runs
    as plain Python.

    ``plant``: a plant other than the loop's own (wmr_mission.sim.plant_side,
    wmr_mission.backends); told to stop on every way out of the run.

    ``ready()`` is called once the loop is loaded (or compiled), just before
    the first sample is simulated: ``wmr-mission run`` claims its run directory
    then. A stop (wmr_mission.stopping) before it returns an ``interrupted``
    result without samples and without calling it.
    """
    if isinstance(mission, MissionPlan):
        plan = mission if seed is None else replace(mission, seed=seed)
        return _run(plan, progress, substitutes, plant, ready)
    with importing_entries():  # a run imports its plug-ins
        checked = validate_mission(mission)
    result = _run(plan_mission(checked, seed), progress, substitutes, plant, ready)
    judge_mission(result, checked)  # a success that misses an `expect` is not one
    return result


def _run(
    plan: MissionPlan,
    progress: ProgressCallback | None,
    substitutes: Mapping[Any, Callable[..., Any]] | None,
    plant: PlantSide | None,
    ready: Callable[[], None] | None = None,
) -> RunResult:
    if plant is None:
        return _Run(plan, progress, substitutes, ready=ready).run()
    substitutes = {**(substitutes or {}), **plant.substitutes()}
    try:
        result = _Run(plan, progress, substitutes, plant, ready).run()
    finally:
        plant.stop()  # a zero command on every way out, before the record is made
    result.realtime = plant.report()
    result.backend = plant.describe()
    return result


class RunFault(RuntimeError):
    """An exception inside the loop: the run ends ``failed`` (a plug-in's code,
    the plant side) or ``error`` (a fault of our own) with this message, and
    keeps the samples done before it."""

    def __init__(self, message: str, outcome: Outcome = Outcome.failed) -> None:
        super().__init__(message)
        self.outcome = outcome


def _honour_stop() -> None:
    """A stop held, or raised and swallowed on its way (wmr_mission.stopping), ends the run here."""
    if stop_owed():
        raise KeyboardInterrupt


def _within(pose: FloatArray, far: float) -> bool:
    """A pose the loop keeps running at: its position within ``far`` [m] of
    the origin on each axis, its heading finite (wmr_mission.kernels.loop)."""
    return abs(pose[0]) < far and abs(pose[1]) < far and math.isfinite(pose[2])


def _seconds(samples: int, dt: float) -> float:
    """``samples * dt`` without its rounding tail (53.48, not 53.480000000000004),
    for the times people read in transitions.json."""
    return round(samples * dt, 9)


class _Run:
    def __init__(
        self,
        mission: MissionPlan,
        progress: ProgressCallback | None,
        substitutes: Mapping[Any, Callable[..., Any]] | None,
        plant: PlantSide | None = None,
        ready: Callable[[], None] | None = None,
    ) -> None:
        m = self.m = mission
        self.plant = plant
        self.ready = ready
        self.progress = progress
        self.recorder = Recorder(min(m.max_samples, MAX_PRESIZED))
        self.transitions: list[Transition] = []
        self.phases = [PhaseRun(p, m, i) for i, p in enumerate(m.phases)]
        # (sample, number) where each reference took over: the `reference`
        # column, written for a mission with updates or a session that made one
        # (0: the phase's own, n: its n-th update).
        self.references: list[tuple[int, int]] = []
        # Per regulate phase, (sample, x, y, theta) where each target took over:
        # its entries and its updates (PhaseRecord.targets).
        self.targets: dict[int, list[tuple[int, float, float, float]]] = {}
        self.updated = any(p.updates for p in m.phases)
        # A session (start_mission) pauses the run before this sample; a run never.
        self.pause_at = NEVER
        # A call of the compiled loop without numba's dispatcher: the phase it
        # was last made with, the types of the phase the dispatcher typed
        # (_phase_types), the compiled entry point, and the controller's
        # tuning it was typed with (_segment).
        self._fast: tuple[EnteredPhase, tuple[Any, ...], Callable[..., int], Any] | None = None
        # A plant side that takes a planner's plans (wmr_mission.backends.ros2): each
        # new one, once, as an update of the phase in force (called with the
        # sample, the phase's index and kind); else None.
        self.plans: Callable[[int, int, str], UpdatePlan | None] | None = getattr(
            plant, "plans", None
        )
        self.active: PhaseRun = self.phases[0]
        self._steps: Generator[None, UpdatePlan | None, RunResult] | None = None
        self.actuation, self.sensing = m.disturbances.records(m.dt, m.measured)
        # A `type: python` plug-in: made here, for this run; an exception out
        # of its code ends the run failed (RunFault), never the tool.
        self.plugin = m.estimator.plugin or m.controller.plugin
        self.failure: str | None = None
        try:
            self.estimator_memory = m.estimator.new_memory(m.estimator_tuning, m.initial_estimate)
            self.scratch = m.controller.new_scratch(m.controller_tuning)
        except Exception as error:
            if not self.plugin:
                raise
            self.failure = f"making the plug-in raised {failure_message(error)}"
            self.estimator_memory = self.scratch = None
        segment = bound_loop(m.estimator.step, m.controller.step)
        compiles = m.estimator.compiles and m.controller.compiles
        if self.plugin and compiles and jit.compiling():
            compiles = jit.typeable(self.estimator_memory, self.scratch)
        if not substitutes and compiles and jit.compiling():
            # A loop running a plug-in's kernels is compiled afresh in each
            # process: the cache's stamp covers the package's sources only.
            parts: list[Any] = [m.estimator.tuning_record, m.estimator.step]
            parts += [m.controller.tuning_record, m.controller.step]
            cached = not self.plugin and all(
                part.__module__.startswith("wmr_mission.") for part in parts
            )
            # A jitclass plug-in's objects are reference counted.
            self.segment: Callable[..., int] = jit.compiled(
                segment, counted=self.plugin, cached=cached
            )
            self.ticks_are_ns = False
        else:
            self.segment = jit.plain(segment, substitutes)
            self.ticks_are_ns = True
        self.signals = Signals(
            state=m.initial_state.copy(),
            estimate=m.initial_estimate.copy(),
            estimate_prev=m.initial_estimate.copy(),
            measurement=np.zeros(3),
            measured=np.full(3, math.nan),
            u=np.zeros(2),
            u_prev=np.zeros(2),
            aim_now=np.zeros(8),
            aim=np.zeros(8),
            memory=np.zeros(m.controller.memory_size),
            held=np.full(4, math.nan),
            counters=np.zeros(loop.CLOCK + 1, dtype=np.int64),
            exit_value=np.zeros(1),
            commands=np.zeros((self.actuation.input_delay + 1, 2)),
            applied=np.zeros(2),
            burst=np.zeros(1, dtype=np.int64),
        )
        self.loop_ns = 0
        # The wall clock and the loop's ticks at the loop's start and at its
        # last return, to convert ticks to nanoseconds.
        self._started = (time.perf_counter_ns(), 0)
        self._returned_ns = self._started[0]

    def _call(self, phase: EnteredPhase, path: PathBlock, draws: FloatArray, stop: int) -> int:
        m = self.m
        try:
            status = self._segment(phase, path, draws, stop)
        except PlantStopped:  # the plant side's own word
            raise
        except Exception as error:  # MemoryError too: a plug-in's is its failure
            if isinstance(error, MemoryError) and not self.plugin:
                raise  # the command's: not enough memory for the run
            # The rows recorded are the samples done: the failed one is the next.
            k = self.recorder.count
            where = f"at sample {k} (t = {_seconds(k, m.dt):.6g} s): {failure_message(error)}"
            if self.plugin and self.plant is not None:
                raise RunFault(f"a plug-in or the plant side failed {where}") from error
            if self.plugin:
                raise RunFault(f"a plug-in failed {where}") from error
            if self.plant is not None:
                raise RunFault(f"the plant side failed {where}") from error
            raise RunFault(f"internal error {where}; please report it", Outcome.error) from error
        self._returned_ns = time.perf_counter_ns()
        return status

    def _segment(self, phase: EnteredPhase, path: PathBlock, draws: FloatArray, stop: int) -> int:
        m = self.m
        tuning = self.phases[phase.number].tuning  # a look-ahead update's, else the mission's
        if tuning is None:
            tuning = m.controller_tuning
        arguments = (
            m.plant, self.actuation, self.sensing, m.estimator_tuning, self.estimator_memory,
            tuning, self.scratch, phase, path, draws, self.signals, self.recorder.record, stop,
        )  # fmt: skip
        fast = self._fast
        contiguous = path.rows.flags.c_contiguous and draws.flags.c_contiguous
        if fast is not None and contiguous and fast[3] is tuning:
            # Numba's dispatcher takes some 30 us to type these arguments: a
            # third of a session's step of 100 samples, and of a campaign's run
            # as much as its Python around the loop. Every argument but the
            # phase and the tuning is of the types of every call of the run
            # (float64 arrays, C order, checked above), the tuning is the one
            # the dispatcher typed, and the phase too or one of the same types.
            if fast[0] is not phase and fast[1] == _phase_types(phase):
                fast = self._fast = (phase, *fast[1:])
            if fast[0] is phase:
                return int(fast[2](*arguments))
        status = int(self.segment(*arguments))
        if self._fast is None and not self.ticks_are_ns and not self.plugin:
            entry = _entry_point(self.segment)
            if entry is not None and contiguous:
                self._fast = (phase, _phase_types(phase), entry, tuning)
        return status

    def run(self) -> RunResult:
        result = self.advance()
        assert result is not None  # never paused
        return result

    def advance(self, update: UpdatePlan | None = None) -> RunResult | None:
        """Run up to ``pause_at`` (None) or to the end (the result). ``update``
        takes over in the active phase at the sample the run was paused at."""
        try:
            if self.failure is not None:
                return self._failed(self.failure)
            if self._steps is None:
                self._steps = self._loop()
                update = None  # nothing to update before the first sample
            # A stop is held while compiled code runs and taken between chunks: a
            # KeyboardInterrupt raised inside numba's dispatcher is lost or comes
            # out seconds later (a SIGINT 2-5 s into a 1,000 s run stopped it 10 s
            # later, or never). Plain Python takes it at once: rows count whole.
            with stop_mode(RAISE if self.ticks_are_ns else HOLD):
                self._steps.send(update)
            return None
        except StopIteration as end:
            result: RunResult = end.value
            return result
        except KeyboardInterrupt:  # SIGINT, or SIGTERM mapped to it by the command
            return self._interrupted()
        except PlantStopped as stopped:  # the plant side's cause: measurements stopped
            return self._interrupted(Outcome.failed, str(stopped))
        except RunFault as failed:
            if stop_owed():  # a plug-in turned the stop into an error of its own
                return self._interrupted()
            return self._failed(str(failed), failed.outcome)

    def _failed(self, message: str, outcome: Outcome = Outcome.failed) -> RunResult:
        """A fault inside the loop (a plug-in's, the plant side's or our own):
        the samples done before it, with ``outcome``; a failure at the first
        sample keeps the start (a run has a row)."""
        m = self.m
        t = _seconds(self.recorder.count, m.dt)  # the sample that failed
        if self.recorder.count == 0:
            nan = math.nan
            _record_sample(
                self.recorder.record, self.phases[0].enter(0, m.initial_estimate), 0.0,
                m.initial_state[0], m.initial_state[1], m.initial_state[2], m.initial_estimate,
                np.zeros(2), nan, nan, 0, np.full(3, nan),
            )  # fmt: skip
        record = self.recorder.record
        last = self.recorder.count - 1
        active = self.phases[int(record.phase[last]) if last >= 0 else 0]
        self.transitions.append(Transition(t, active.phase.name, None, outcome.value, math.nan))
        return self._result(outcome, message)

    def _interrupted(
        self, outcome: Outcome = Outcome.interrupted, cause: str = "interrupted"
    ) -> RunResult:
        """The samples recorded up to the stop. A row is counted only once it is
        whole, so a stop inside a sample (pure Python) leaves no half row."""
        record = self.recorder.record
        last = self.recorder.count - 1
        active = self.phases[int(record.phase[last]) if last >= 0 else 0]
        t = round(float(record.floats[last, 0]), 9) if last >= 0 else 0.0
        condition = "interrupted" if outcome is Outcome.interrupted else "failed"
        self.transitions.append(Transition(t, active.phase.name, None, condition, math.nan))
        return self._result(outcome, f"{cause} in phase '{active.phase.name}' at t = {t:.6g} s")

    def _loop(self) -> Generator[None, UpdatePlan | None, RunResult]:
        """The run as steps: made (not started) at once, it loads the loop at
        its first ``send(None)``, then runs chunk by chunk (``_chunks``)."""
        m = self.m
        draws = Draws(m.noise_std, m.disturbances, m.seed)
        active = self.phases[0]
        phase = self._enter(active, 0)
        # Load (or compile) the loop and the paths' math before the clock: a
        # zero-sample call. The paths' math first, held: loading it is numba's
        # first load, which imports compiled modules, and a KeyboardInterrupt
        # inside such an import made Python exit by SIGINT (-2) whatever the
        # command returned. A compile takes tens of seconds: a stop ends it at once,
        # and a stop held until here (the command's start, the paths' math) ends
        # the run before it, not after it.
        if any(p.tracks_a_path for p in self.phases):
            with stop_mode(HOLD):
                scalar_math.load()
        _honour_stop()
        with stop_mode(RAISE):
            self._call(phase, active.path_ahead(0, 0), draws.ahead(), 0)
        _honour_stop()
        if jit.loaded() and self.m.max_samples >= LONG_RUN:
            jit.make_runtime()  # the judge's passes need it: made while the pages are in
            give_back_compiler_pages()  # the simulation runs none (memory, docs/performance.md)
        if self.ready is not None:
            self.ready()
        return (yield from self._chunks(active, phase, draws))

    def _chunks(
        self, active: PhaseRun, phase: EnteredPhase, draws: Draws
    ) -> Generator[None, UpdatePlan | None, RunResult]:
        """The chunks of the run, each a call of the compiled loop; paused (a
        yield) where a session asked (``pause_at``), where an update it sends
        takes over."""
        m = self.m
        dt = m.dt
        signals = self.signals
        counters = signals.counters
        if self.plant is not None:
            self.plant.start(signals.state)
        outcome = Outcome.success
        message = "all phases completed"
        budget = m.max_samples * dt
        self._started = (self._returned_ns, int(counters[loop.CLOCK]))
        index = 0
        # The run's first call is short whatever its phase where someone waits
        # for its first samples (the command line's run: ready, progress):
        # they are simulated (and reported) a moment after the run directory
        # is claimed, however long the mission; the chunk then grows to CHUNK.
        # Elsewhere (run_mission alone, a campaign's run) the phase's own
        # first chunk: each call costs the loop's arguments and a path block.
        awaited = self.ready is not None or self.progress is not None
        chunk = FIRST_CHUNK if awaited else active.first_chunk
        ran = 0  # samples run since the chunk last grew
        reactor = None if m.reactions is None else Reactor(m.reactions)
        while True:
            _honour_stop()
            k = int(counters[loop.K])
            if k >= self.pause_at:
                self.active = active
                update = yield
                if update is not None:
                    self._take_over(active, k, update)
                continue
            local = k - active.entry_sample
            watched = reactor is not None and reactor.plan.watches(active.index)
            # At its bound (elapsed or timeout) the phase exits before it steps,
            # so a call that reaches the bound goes on to see it exit; the path
            # is sampled up to the bound, never past it. The loop also stops
            # where the draws drawn so far run out (Draws.ahead), and where a
            # session pauses it.
            stop = k + min(chunk, active.bound - local + 1, self.pause_at - k)
            if self.plans is not None:  # a planner's new path, looked for at every sample
                stop = k + 1
                update = self.plans(k, active.index, active.phase.kind)
                taken = None if update is None else update.for_phase(active.phase.kind)
                if taken is not None:
                    self._take_over(active, k, taken)
            rows = min(chunk, active.bound - local) + 1
            path = active.path_ahead(local, min(rows, self.pause_at - k + 1), rows)
            self.recorder.reserve(2)  # the loop stops early when the recorder is full
            block = draws.ahead()
            started = k
            pending = active.pending
            saved = self._saved() if watched or pending is not None else None
            status = self._call(phase, path, block, stop)
            decision: Decision | None = None
            due = False
            if saved is not None and status in (loop.CHUNK_END, loop.EXITED):
                if pending is not None:
                    due = self._update_due(active, pending, saved, phase, path, block)
                    status = loop.CHUNK_END if due else status
                if watched:
                    assert reactor is not None
                    decision = self._breach(reactor, active, saved, phase, path, block)
                    due = due and decision is None
            draws.used(int(counters[loop.DRAWS]))
            counters[loop.DRAWS] = 0
            k = int(counters[loop.K])
            if due:
                self._take_over(active, k)
                continue
            if decision is not None:
                assert reactor is not None
                ended = self._follow(reactor, decision, active, k, phase)
                if ended is not None:
                    outcome, message = ended
                    break
                active, phase = self._entered(decision, active, k)
                chunk, ran = active.first_chunk, 0
                continue
            if status == loop.CHUNK_END:
                if self.progress is not None:
                    self.progress(k * dt, budget, active.phase.name)
                # A session's pauses cut chunks short: the chunk (and the path
                # sampled ahead) grows once as many samples ran as a run's would.
                ran += k - started
                if stop < self.pause_at or ran >= chunk:
                    chunk, ran = min(4 * chunk, CHUNK), 0
                continue
            if status != loop.EXITED:
                cause = self._divergence_cause(status)
                outcome, message = self._diverged(int(counters[loop.K]), active, cause)
                break
            condition = loop.CONDITIONS[int(counters[loop.CONDITION])]
            value = float(signals.exit_value[0])
            if condition in ("elapsed", "timeout", "mission_time"):
                value = _seconds(int(value), dt)
            if reactor is not None:
                missed = self._missed(reactor, active, k) if condition != "timeout" else []
                if condition == "timeout":
                    decision = reactor.react(active.index, "timeout")
                    why = self._timed_out(active, value, k * dt)
                elif missed:
                    decision = reactor.react(active.index, "verdict")
                    condition, value = "verdict", float(len(missed))
                    why = "missed " + "; ".join(missed)
                else:
                    decision = reactor.completed(active.index)
                    why = None
                ended = self._follow(reactor, decision, active, k, phase, condition, value, why)
                if ended is not None:
                    outcome, message = ended
                    break
                active, phase = self._entered(decision, active, k)
                chunk, ran = active.first_chunk, 0
                continue
            if condition == "timeout" and active.phase.fail_on_timeout:
                active.status = Status.timed_out
                self.transitions.append(
                    Transition(_seconds(k, dt), active.phase.name, None, condition, value)
                )
                outcome = Outcome.timeout
                message = self._timed_out(active, value, k * dt)
                self._close(k, phase)
                break
            active.status = Status.done
            index += 1
            to = self.phases[index] if index < len(self.phases) else None
            self.transitions.append(
                Transition(
                    _seconds(k, dt),
                    active.phase.name,
                    None if to is None else to.phase.name,
                    condition,
                    value,
                    None if to is None else to.phase.lap,
                    *(
                        ("next", self._timed_out(active, value, k * dt))
                        if condition == "timeout"
                        else ()
                    ),
                )
            )
            if to is None:
                self._close(k, phase)
                break
            active = to
            signals.memory[:] = 0.0
            signals.held[:] = math.nan
            phase = self._enter(active, k)
            chunk, ran = active.first_chunk, 0
        return self._result(outcome, message)

    def _timed_out(self, active: PhaseRun, seconds: float, at: float) -> str:
        """A phase's timeout in words, with how far its estimate was from each
        `until` goal it has at the sample it timed out at (what the conditions
        read: the estimate and the last input's speed): a park that timed out
        3 rad short of its heading says so."""
        words = f"phase '{active.phase.name}' timed out after {seconds:.6g} s at t = {at:.6g} s"
        estimate, speed = self.signals.estimate, float(self.signals.u_prev[0])
        x, y, theta = float(estimate[0]), float(estimate[1]), float(estimate[2])
        until, left = active.phase.until, []
        target = active.target_in_force
        if until.settled is not None and target is not None:
            position, heading, still = until.settled
            text = (
                f"{math.hypot(x - target[0], y - target[1]):.3g} m and "
                f"{abs(wrap_angle(theta - target[2])):.3g} rad from its target"
            )
            asked = f"{position:g} m and {heading:g} rad"
            if abs(speed) > still:  # the speed too, where it is what is left
                text += f", its last input {abs(speed):.3g} m/s"
                asked = f"{position:g} m, {heading:g} rad and at most {still:g} m/s"
            left.append(f"{text} (settled asks {asked})")
        region = self.m.context.regions.get(until.reaches) if until.reaches else None
        if region is not None:
            left.append(
                f"{distance_to(region, x, y):.3g} m from the edge of region {until.reaches!r}"
            )
        if until.near is not None:
            px, py, tolerance = until.near
            left.append(
                f"{math.hypot(x - px, y - py):.3g} m from ({px:g}, {py:g}) "
                f"(near asks {tolerance:g} m)"
            )
        if until.heading is not None:
            aim, tolerance = until.heading
            left.append(
                f"{abs(wrap_angle(theta - aim)):.3g} rad from heading {aim:g} "
                f"(heading asks {tolerance:g} rad)"
            )
        if not left:
            return words
        words = f"{words}, its estimate {'; '.join(left)}"
        of_motion = until.near is not None or until.heading is not None or region is not None
        if active.phase.kind == "hold" and of_motion:
            # a hold never moves to meet them: they hold where it was entered, or never
            return f"{words}: a hold keeps the pose it was entered at"
        # why, for the target written (not one an update gave): the band kept round a zone
        why = active.phase.out_of_reach if target == active.phase.target else None
        return words if why is None else f"{words}: {why}"

    def _missed(self, reactor: Reactor, active: PhaseRun, k: int) -> list[str]:
        """The verdicts the phase just ended missed over its samples since it was
        entered, where it reacts to a missed verdict."""
        written = reactor.plan.written
        if written is None or not reactor.plan.judges(active.index):
            return []
        # this entry's samples alone (row i is sample i), as the run's record has them
        floats = self.recorder.record.floats[active.entry_sample : k].copy()
        columns = dict(zip(FLOAT_COLUMNS, floats.T, strict=True))
        p = active.phase
        entry = RunResult(
            mission_name=self.m.name,
            dt=self.m.dt,
            seed=self.m.seed,
            phases=[
                PhaseRecord(
                    p.name,
                    p.kind,
                    self._target(active),
                    p.constraints,
                    near=p.until.near,
                    points=() if p.points is None else tuple(map(tuple, p.points.tolist())),
                    targets=self._targets(active.index, active.entry_sample),
                )
            ],
            **columns,
            phase=np.zeros(len(floats), dtype=np.int64),
            phase2_iterations=np.zeros(len(floats), dtype=np.int64),
            compute_ns=np.zeros(len(floats), dtype=np.int64),
            transitions=[],
            outcome=Outcome.success,
            message="",
            limits=(float(self.m.plant.limits[0]), float(self.m.plant.limits[1])),
            error_bounds=self.m.estimator.error_bounds(self.m.estimator_tuning),  # type: ignore[arg-type]
            regions=dict(self.m.regions),
        )
        return missed_verdicts(entry, written)

    def _update_due(
        self,
        active: PhaseRun,
        update: UpdatePlan,
        saved: tuple[int, list[tuple[FloatArray, FloatArray]]],
        phase: EnteredPhase,
        path: PathBlock,
        block: FloatArray,
    ) -> bool:
        """Whether ``update`` takes over at a sample the last call recorded; if
        so, the call is run again from the state before it up to that sample,
        as the breach's is (the loop is a function of the state it is called with)."""
        recorded, arrays = saved
        count = self.recorder.count
        start = max(active.entry_sample, 0 if update.travelled is not None else recorded)
        estimates = self.recorder.record.floats[start:count, 4:6]  # x_est, y_est: x_{k|k}
        k = update.first(estimates, start, recorded, active.entry_sample, self.m.dt)
        if k < 0:
            return False
        for array, copy in arrays:
            array[...] = copy
        self.recorder.record.rows[0] = recorded
        self._call(phase, path, block, k)
        return True

    def _take_over(self, active: PhaseRun, k: int, update: UpdatePlan | None = None) -> None:
        """``update`` (else the phase's pending one) takes over at sample k;
        transitions.json says so."""
        if update is None:
            update = active.pending
            assert update is not None
            active.fired += 1
        estimate = self.signals.estimate
        active.take_over(k, estimate, update)
        self.updated = True
        self._note_target(active, k)
        name = active.phase.name
        why = (
            f"update {active.reference} ({update.when}): {update.changes} from the estimate "
            f"({estimate[0]:.4g}, {estimate[1]:.4g})"
        )
        self.transitions.append(
            Transition(_seconds(k, self.m.dt), name, name, "update", float(active.reference),
                       active.phase.lap, None, why)
        )  # fmt: skip
        self.references.append((k, active.reference))

    def _saved(self) -> tuple[int, list[tuple[FloatArray, FloatArray]]]:
        """What a call of the loop changes, copied: the recorded rows, and every
        array the loop carries from sample to sample."""
        carried = [*self.signals, *self.estimator_memory, *self.scratch]
        arrays = [a for a in carried if isinstance(a, np.ndarray)]
        return self.recorder.count, [(a, a.copy()) for a in arrays]

    def _breach(
        self,
        reactor: Reactor,
        active: PhaseRun,
        saved: tuple[int, list[tuple[FloatArray, FloatArray]]],
        phase: EnteredPhase,
        path: PathBlock,
        block: FloatArray,
    ) -> Decision | None:
        """The reaction to a breach among the rows the last call recorded, if
        any. The call is then run again from the state before it, up to the
        sample that breached: the reaction fires at the next sample, as if
        the loop had checked the geofence itself (the same samples: the loop
        is a function of the state it is called with)."""
        recorded, arrays = saved
        record = self.recorder.record
        breach = breach_at(reactor.plan, record.floats, recorded, self.recorder.count)
        if breach is None:
            return None
        for array, copy in arrays:
            array[...] = copy
        record.rows[0] = recorded
        start = int(self.signals.counters[loop.K])
        self._call(phase, path, block, start + breach.sample - recorded + 1)
        self._breach_seen: Breach = breach
        return reactor.react(active.index, "breach")

    def _follow(
        self,
        reactor: Reactor,
        decision: Decision,
        active: PhaseRun,
        k: int,
        phase: EnteredPhase,
        condition: str = "breach",
        value: float = math.nan,
        why: str | None = None,
    ) -> tuple[Outcome, str] | None:
        """Record the transition ``decision`` makes; the run's end, if it ends."""
        dt = self.m.dt
        t = _seconds(k, dt)
        if condition == "breach":
            b = self._breach_seen
            value = round(b.depth, 9)
            keep = next(z.keep for z in reactor.plan.zones if z.name == b.zone)
            side = "outside keep-in" if keep == "in" else "inside keep-out"
            why = (
                f"the {b.position} position went {b.depth:.3g} m {side} zone '{b.zone}' "
                f"(margin {reactor.plan.margin:g} m) at t = {b.time:.6g} s"
            )
        to = None if decision.enter is None else self.phases[decision.enter]
        if decision.contingency is not None and why is not None:
            why = f"{why}; contingency '{decision.contingency}'"
        self.transitions.append(
            Transition(
                t,
                active.phase.name,
                None if to is None else to.phase.name,
                condition,
                value,
                None if to is None else to.phase.lap,
                decision.reaction,
                why,
            )
        )
        if to is not None:
            return None
        self._close(k, phase)
        fired = [tr for tr in self.transitions if recovery.fired(tr)]
        if decision.failure is None:
            active.status = Status.done
            if not fired:
                return Outcome.success, "all phases completed"
            return Outcome.success, f"completed, {len(fired)} reaction{'s' * (len(fired) > 1)}"
        active.status = Status.timed_out if decision.failure == "timeout" else Status.done
        outcome = {
            "timeout": Outcome.timeout,
            "breach": Outcome.breached,
            "verdict": Outcome.expect_failed,
        }[decision.failure or "timeout"]
        last = fired[-1] if fired else None
        cause = next(
            (
                tr.why
                for tr in reversed(self.transitions)
                if tr.why is not None and tr.condition in ("timeout", "breach", "verdict")
            ),
            None,
        )
        if cause is None:
            cause = f"phase '{active.phase.name}' failed at t = {t:.6g} s"
        reaction = "" if last is None else f" (reaction: {last.reaction})"
        return outcome, f"{cause}{reaction}"

    def _entered(
        self, decision: Decision, active: PhaseRun, k: int
    ) -> tuple[PhaseRun, EnteredPhase]:
        """Enter the phase ``decision`` names at sample k."""
        assert decision.enter is not None
        if active.status == Status.running:
            active.status = Status.done
        active.left_at = k - active.entry_sample + active.path_shift
        to = self.phases[decision.enter]
        self.signals.memory[:] = 0.0
        self.signals.held[:] = math.nan
        resume = to.left_at if decision.how == "resume" else None
        return to, self._enter(to, k, resume)

    def _enter(self, active: PhaseRun, k: int, resume: int | None = None) -> EnteredPhase:
        """Enter ``active`` at sample k; the reference column notes its reference."""
        entered = active.enter(k, self.signals.estimate, resume)
        self.references.append((k, active.reference))
        self._note_target(active, k)
        return entered

    def _note_target(self, active: PhaseRun, k: int) -> None:
        """A regulate phase's target in force from sample k on."""
        if active.phase.kind == "regulate":
            x, y, theta = (float(v) for v in active.target)
            self.targets.setdefault(active.index, []).append((k, x, y, theta))

    def _targets(self, index: int, since: int = 0) -> tuple[tuple[int, float, float, float], ...]:
        """PhaseRecord.targets of phase ``index`` from sample ``since`` on (as
        samples from there, an entry's first): empty unless an update changed
        its target."""
        changes = self.targets.get(index, [])
        if len({change[1:] for change in changes}) < 2:
            return ()
        return tuple((k - since, x, y, t) for k, x, y, t in changes if k >= since)

    def _close(self, k: int, phase: EnteredPhase) -> None:
        """The row of the sample the run ends at: no step is taken from it."""
        s = self.signals
        _record_sample(
            self.recorder.record, phase, k * self.m.dt, s.state[0], s.state[1], s.state[2],
            s.estimate, s.u_prev, math.nan, math.nan, int(s.counters[loop.ITERATIONS]), s.measured,
        )  # fmt: skip

    def _divergence_cause(self, status: int) -> str:
        s = self.signals
        u = s.u
        if status == loop.DIVERGED_INPUT:
            if math.isfinite(u[0]) and math.isfinite(u[1]):
                return (
                    f"the input ran away (v = {u[0]:.3g} m/s, omega = {u[1]:.3g} rad/s; "
                    f"beyond {self.m.plant.runaway_input:g} is no robot's)"
                )
            return "the input is not finite"
        state, estimate, far = s.state, s.estimate, self.m.plant.runaway_position
        if _within(state, far) and not _within(estimate, far):
            return (  # the estimator's (a plug-in's NaN or 1e12), not the robot's
                f"the estimate ran away (x = {estimate[0]:.3g} m, y = {estimate[1]:.3g} m, "
                f"theta = {estimate[2]:.3g} rad), the state did not (x = {state[0]:.3g} m, "
                f"y = {state[1]:.3g} m)"
            )
        return (
            f"the state ran away (x = {s.state[0]:.3g} m, y = {s.state[1]:.3g} m; "
            f"last input v = {u[0]:.3g} m/s, omega = {u[1]:.3g} rad/s)"
        )

    def _diverged(self, k: int, active: PhaseRun, cause: str) -> tuple[Outcome, str]:
        t = _seconds(k, self.m.dt)
        self.transitions.append(Transition(t, active.phase.name, None, "diverged", math.nan))
        return (
            Outcome.diverged,
            f"diverged in phase '{active.phase.name}' at t = {t:.6g} s: {cause}",
        )

    def _result(self, outcome: Outcome, message: str) -> RunResult:
        started_ns, started_ticks = self._started
        self.loop_ns = time.perf_counter_ns() - started_ns
        ticks = int(self.signals.counters[loop.CLOCK]) - started_ticks
        ns_per_tick = 1.0 if self.ticks_are_ns else (self._returned_ns - started_ns) / max(1, ticks)
        r = self.recorder
        n = r.count
        m = self.m
        record = r.record
        bounds = m.estimator.error_bounds(m.estimator_tuning)
        compute = record.compute[:n]
        if not (self.ticks_are_ns or jit.cycle_counter()):
            # Compiled where no cheap clock can be read inside the loop (not
            # x86-64): each sample gets the whole loop's mean.
            compute[:] = self.loop_ns // max(1, n)
        elif ns_per_tick != 1.0:
            compute[:] = np.rint(compute * ns_per_tick)
        columns = dict(zip(FLOAT_COLUMNS, record.floats[:n].T, strict=True))
        return RunResult(
            mission_name=m.name,
            dt=m.dt,
            seed=m.seed,
            phases=[
                PhaseRecord(
                    p.name,
                    p.kind,
                    self._target(a),
                    p.constraints,
                    near=p.until.near,
                    points=() if p.points is None else tuple(map(tuple, p.points.tolist())),
                    color=p.color,
                    targets=self._targets(a.index),
                )
                for p, a in zip(m.phases, self.phases, strict=True)
            ],
            t=columns["t"],
            x=columns["x"],
            y=columns["y"],
            theta=columns["theta"],
            x_est=columns["x_est"],
            y_est=columns["y_est"],
            theta_est=columns["theta_est"],
            v=columns["v"],
            omega=columns["omega"],
            phase=record.phase[:n],
            x_ref=columns["x_ref"],
            y_ref=columns["y_ref"],
            constraint=columns["constraint"],
            phase2_iterations=record.iterations[:n],
            compute_ns=compute,
            transitions=self.transitions,
            outcome=outcome,
            message=message,
            limits=(float(m.plant.limits[0]), float(m.plant.limits[1])),
            error_bounds=bounds,  # type: ignore[arg-type]
            regions=dict(m.regions),
            constraint_margin=float(m.plant.constraint_margin),
            loop_ns=self.loop_ns,
            loop_compiled=not self.ticks_are_ns,
            x_meas=columns["x_meas"],
            y_meas=columns["y_meas"],
            theta_meas=columns["theta_meas"],
            reference=self._reference_column(n) if self.updated else None,
        )

    def _reference_column(self, n: int) -> IntArray:
        """The number of the reference in force at each of the n samples."""
        column = np.zeros(n, dtype=np.int64)
        for k, number in self.references:
            column[k:] = number  # in sample order: a later change overwrites
        return column

    @staticmethod
    def _target(active: PhaseRun) -> tuple[float, float, float] | None:
        if active.phase.kind == "track" or active.status == Status.pending:
            return active.phase.target
        return (float(active.target[0]), float(active.target[1]), float(active.target[2]))
