"""Is a run sound? A judge of a run directory independent of the product's own.

It reads the mission as written (YAML, with pyyaml) and the run's
``trajectory.csv``, and nothing of ``wmr_mission``: every quantity is computed
here from the recorded true pose, inputs and reference. What "sound" means,
criterion by criterion, with each threshold and why: docs/soundness.md.

    python scripts/soundness.py MISSION.yaml RUN_DIR     # prints the verdict; exit 1 if unsound

scripts/judge_generated.py runs the generated set and sets this judge beside
the product's verdict.
"""

from __future__ import annotations

import argparse
import csv
import math
from collections.abc import Mapping
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import yaml

FloatArray = np.ndarray

# --- thresholds (docs/soundness.md says why each is what it is) -------------
TRACKING_TOLERANCE = 0.1  # [m] off the path or behind the reference, noise aside
ZONE_TOLERANCE = 0.005  # [m] of the true position inside a zone it must keep out of
KICK = 1.0  # a one-sample input change above this times the limit: half the range -lim..lim
JITTER_FLOOR = 0.01  # turn-rate jitter always allowed, as a fraction of the limit
REVERSAL_FLOOR = 0.05  # inputs below this fraction of the limit are not counted as reversing
REVERSAL_WINDOW = 10  # time constants: the window in which reversals are counted
MOVING = 0.5  # a detour is driven at least this fraction of the reference's speed
RAMP_SLOPE = 0.5  # [m across / m along] the gentlest way a detour leaves its path
DELIBERATE = 0.5  # a saturated drive turns at least this fraction of the limit into progress
STALL_WINDOW = 20  # time constants without progress (each a 10 % gain) that make a stall
PROGRESS = 0.1
ROBUST_STD = 1.4826  # times the median absolute deviation: the std of a Gaussian
AT_LIMIT = 1e-6  # relative: an input this close to its limit is at it
ESTIMATE_BAND = 0.05  # [m and rad] an estimate this close has converged (noise aside)
DEFAULT_TIME_CONSTANT = 0.1  # [s] controller.tracking.time_constant's default
DEFAULT_SPEED_TOLERANCE = 0.01  # [m/s] until.settled.speed's default
DEFAULT_LIMITS = (10.0, 20.0)  # robot.limits' defaults [m/s, rad/s]
DEFAULT_DT = 0.01


def wrap(angle: FloatArray | float) -> Any:
    """Angles wrapped to [-pi, pi)."""
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float):
        raise ValueError(f"{where}: the judge reads plain numbers, got {value!r}")
    return float(value)


def _get(mapping: Mapping[str, Any] | None, *keys: str, default: Any = None) -> Any:
    value: Any = mapping
    for key in keys:
        if not isinstance(value, Mapping) or value.get(key) is None:
            return default
        value = value[key]
    return value


# --- regions ------------------------------------------------------------------


@dataclass(frozen=True)
class Region:
    """A region of the mission; ``outside_by`` is its signed distance."""

    spec: Mapping[str, Any]
    name: str

    def outside_by(self, x: FloatArray, y: FloatArray) -> FloatArray:
        """Distance [m] of each point from the region: > 0 outside, < 0 inside
        (minus the distance to the boundary)."""
        kind, s = self.spec["type"], self.spec
        where = f"regions.{self.name}"
        if kind == "circle":
            cx, cy = (_number(v, where) for v in s.get("center", (0, 0)))
            return np.hypot(x - cx, y - cy) - _number(s["radius"], where)
        if kind == "half-plane":
            nx, ny = (_number(v, where) for v in s["normal"])
            norm = math.hypot(nx, ny)
            return (nx * x + ny * y - _number(s["offset"], where)) / norm
        if kind == "box":
            if "center" in s:  # {center, size, heading}: a box turned by heading
                cx, cy = (_number(v, where) for v in s["center"])
                length, width = (_number(v, where) for v in s["size"])
                turn = _number(s.get("heading", 0.0), where)
            else:  # {min, max}
                lo = [_number(v, where) for v in s["min"]]
                hi = [_number(v, where) for v in s["max"]]
                cx, cy = (lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2
                length, width, turn = hi[0] - lo[0], hi[1] - lo[1], 0.0
            c, sn = math.cos(turn), math.sin(turn)
            qx = np.abs((x - cx) * c + (y - cy) * sn) - length / 2
            qy = np.abs(-(x - cx) * sn + (y - cy) * c) - width / 2
            outside = np.hypot(np.maximum(qx, 0), np.maximum(qy, 0))
            return outside + np.minimum(np.maximum(qx, qy), 0)
        if kind == "polygon":
            vertices = np.array([[_number(v, where) for v in p] for p in s["vertices"]])
            return _polygon_outside_by(vertices, x, y)
        if kind == "ellipse":
            return self._ellipse_outside_by(x, y)
        raise ValueError(f"{where}: unknown region type {kind!r}")

    def vertices(self) -> FloatArray | None:
        """The corners of a box or polygon, in order (None for other regions)."""
        kind, s, where = self.spec["type"], self.spec, f"regions.{self.name}"
        if kind == "polygon":
            return np.array([[_number(v, where) for v in p] for p in s["vertices"]])
        if kind != "box":
            return None
        if "center" in s:
            cx, cy = (_number(v, where) for v in s["center"])
            length, width = (_number(v, where) for v in s["size"])
            turn = _number(s.get("heading", 0.0), where)
        else:
            lo = [_number(v, where) for v in s["min"]]
            hi = [_number(v, where) for v in s["max"]]
            cx, cy = (lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2
            length, width, turn = hi[0] - lo[0], hi[1] - lo[1], 0.0
        u = np.array([[1, 1], [-1, 1], [-1, -1], [1, -1]]) * [length / 2, width / 2]
        c, sn = math.cos(turn), math.sin(turn)
        return np.column_stack((cx + u[:, 0] * c - u[:, 1] * sn, cy + u[:, 0] * sn + u[:, 1] * c))

    def _ellipse_outside_by(self, x: FloatArray, y: FloatArray) -> FloatArray:
        s, where = self.spec, f"regions.{self.name}"
        cx, cy = (_number(v, where) for v in s.get("center", (0, 0)))
        a, b = (_number(v, where) for v in s["semi_axes"])
        rotation = _number(s.get("rotation", 0.0), where)
        c, sn = math.cos(rotation), math.sin(rotation)
        # The boundary as a fine polygon: its distance is within a few um of the ellipse's.
        angle = np.linspace(0, 2 * np.pi, 2048, endpoint=False)
        u, w = a * np.cos(angle), b * np.sin(angle)
        boundary = np.column_stack((cx + u * c - w * sn, cy + u * sn + w * c))
        distance = _distance_to_closed_polyline(boundary, x, y)
        du, dw = (x - cx) * c + (y - cy) * sn, -(x - cx) * sn + (y - cy) * c
        inside = (du / a) ** 2 + (dw / b) ** 2 <= 1.0
        return np.where(inside, -distance, distance)


def _distance_to_closed_polyline(points: FloatArray, x: FloatArray, y: FloatArray) -> FloatArray:
    ax, ay = points[:, 0], points[:, 1]
    bx, by = np.roll(ax, -1), np.roll(ay, -1)
    found = np.empty(x.shape)
    for start in range(0, x.size, 512):  # bounded memory
        px, py = x[start : start + 512, None], y[start : start + 512, None]
        found[start : start + 512] = _to_segments(ax, ay, bx, by, px, py).min(axis=1)
    return found


def _to_segments(
    ax: FloatArray, ay: FloatArray, bx: FloatArray, by: FloatArray, px: FloatArray, py: FloatArray
) -> FloatArray:
    """Distance of each point (rows) from each segment a-b (columns)."""
    sx, sy = bx - ax, by - ay
    length2 = sx * sx + sy * sy
    along = ((px - ax) * sx + (py - ay) * sy) / np.where(length2 > 0, length2, 1.0)
    along = np.clip(along, 0.0, 1.0)
    return np.hypot(px - ax - along * sx, py - ay - along * sy)


def _polygon_outside_by(vertices: FloatArray, x: FloatArray, y: FloatArray) -> FloatArray:
    distance = _distance_to_closed_polyline(vertices, x, y)
    ax, ay = vertices[:, 0], vertices[:, 1]
    bx, by = np.roll(ax, -1), np.roll(ay, -1)
    cross = (bx - ax) * (y[:, None] - ay) - (by - ay) * (x[:, None] - ax)
    inside = np.all(cross >= 0, axis=1) | np.all(cross <= 0, axis=1)  # convex
    return np.where(inside, -distance, distance)


@dataclass(frozen=True)
class Zone:
    """A constraint of a phase: keep inside or keep outside a region."""

    region: Region
    keep_inside: bool

    def depth(self, x: FloatArray, y: FloatArray) -> FloatArray:
        """How far [m] each point is on the forbidden side (< 0: allowed, that far from it)."""
        outside = self.region.outside_by(x, y)
        return outside if self.keep_inside else -outside

    def reach(self, rx: FloatArray, ry: FloatArray) -> float:
        """How far [m] the zone reaches into the path through (rx, ry): the
        deepest point's depth, or for a keep-out box or polygon the way out a
        robot on the path has, square to the path (the shorter side): round a
        turned box that is farther than its nearest edge."""
        return float(self.reaches(rx, ry).max())

    def reaches(self, rx: FloatArray, ry: FloatArray) -> FloatArray:
        """How far [m] the zone reaches into the path at each point (rx, ry): its
        depth, or inside a keep-out box or polygon the way out square to the path."""
        depth = self.depth(rx, ry)
        corners = None if self.keep_inside else self.region.vertices()
        if corners is None or rx.size < 2:
            return depth
        inside = np.flatnonzero(depth > 0)
        tx, ty = np.gradient(rx)[inside], np.gradient(ry)[inside]
        norm = np.hypot(tx, ty)
        moving = norm > 0
        inside, nx, ny = inside[moving], -ty[moving] / norm[moving], tx[moving] / norm[moving]
        if inside.size == 0:
            return depth
        side = (corners[:, 0] - rx[inside, None]) * nx[:, None] + (
            corners[:, 1] - ry[inside, None]
        ) * ny[:, None]
        reaches = depth.copy()
        reaches[inside] = np.maximum(depth[inside], np.minimum(side.max(axis=1), -side.min(axis=1)))
        return reaches

    def __str__(self) -> str:
        return f"{'inside' if self.keep_inside else 'outside'} {self.region.name}"


# --- the mission as the judge reads it -------------------------------------------


@dataclass(frozen=True)
class PhaseSpec:
    name: str
    kind: str  # track, regulate or hold
    until: Mapping[str, Any]
    on_timeout: str
    zones: tuple[Zone, ...]
    target: tuple[float, float, float] | None  # regulate
    timeout: float | None


@dataclass(frozen=True)
class MissionSpec:
    dt: float
    v_limit: float
    omega_limit: float
    position_noise: float  # [m] the larger of x and y
    heading_noise: float  # [rad]
    time_constant: float  # [s] the design's time scale
    look_ahead: float  # [m]
    body: float  # [m] how far the robot's outline reaches from its axle's centre (0: a point)
    phases: dict[str, PhaseSpec]  # by the name trajectory.csv gives them
    regions: dict[str, Region]
    # [m/s^2, rad/s^2] the tighter of limits.acceleration and limits.*_rate (inf: none)
    accelerations: tuple[float, float] = (math.inf, math.inf)


def read_mission(source: str | Path | Mapping[str, Any]) -> MissionSpec:
    """The numbers of a mission (a file, or the mapping ``yaml.safe_load`` gives)
    that the judge needs, with the documented defaults."""
    mission = source if isinstance(source, Mapping) else yaml.safe_load(Path(source).read_text())
    robot = _get(mission, "robot", default={})
    dt = _number(_get(robot, "dt", default=DEFAULT_DT), "robot.dt")
    v_limit = _number(_get(robot, "limits", "v", default=DEFAULT_LIMITS[0]), "robot.limits.v")
    omega_limit = _number(
        _get(robot, "limits", "omega", default=DEFAULT_LIMITS[1]), "robot.limits.omega"
    )
    noise = _get(mission, "sensors", "noise_std", default={})
    measured = _get(mission, "sensors", "measure", default=["x", "y", "theta"])
    sigma = {s: _number(noise.get(s, 0.0), f"sensors.noise_std.{s}") for s in ("x", "y", "theta")}
    tracking = _get(mission, "controller", "tracking", default={})
    time_constant = _number(tracking.get("time_constant", DEFAULT_TIME_CONSTANT), "time_constant")
    look_ahead = tracking.get("look_ahead")
    regions = {
        name: Region(spec, name) for name, spec in (_get(mission, "regions", default={})).items()
    }
    phases: dict[str, PhaseSpec] = {}
    for step in mission["phases"]:
        repeat = step.get("repeat")
        if repeat is None:
            phases[step["name"]] = _phase(step, step["name"], regions)
            continue
        for lap in range(1, int(repeat["times"]) + 1):
            for inner in repeat["phases"]:
                name = f"{inner['name']}#{lap}"
                phases[name] = _phase(inner, name, regions)
    return MissionSpec(
        dt=dt,
        v_limit=v_limit,
        omega_limit=omega_limit,
        position_noise=max(sigma["x"] * ("x" in measured), sigma["y"] * ("y" in measured)),
        heading_noise=sigma["theta"] * ("theta" in measured),
        time_constant=max(time_constant, dt),
        look_ahead=(
            _number(look_ahead, "look_ahead") if look_ahead is not None else max(0.05, v_limit * dt)
        ),
        body=_body(robot),
        phases=phases,
        regions=regions,
        accelerations=_accelerations(robot),
    )


def _body(robot: Mapping[str, Any]) -> float:
    """[m] how far robot.footprint reaches from the axle's centre: its radius, or
    its polygon's farthest corner; 0 without one (the robot is a point)."""
    footprint = _get(robot, "footprint", default={}) or {}
    if "radius" in footprint:
        return _number(footprint["radius"], "robot.footprint.radius")
    corners = footprint.get("polygon") or [[0.0, 0.0]]
    return max(math.hypot(float(x), float(y)) for x, y in corners)


def _accelerations(robot: Mapping[str, Any]) -> tuple[float, float]:
    """The robot's acceleration limits [m/s^2, rad/s^2]: the tighter of
    limits.acceleration and limits.v_rate / omega_rate; inf where none is set."""
    found = []
    for state, rate in (("v", "v_rate"), ("omega", "omega_rate")):
        values = [
            _number(value, f"robot.limits.{where}")
            for where, value in (
                (f"acceleration.{state}", _get(robot, "limits", "acceleration", state)),
                (rate, _get(robot, "limits", rate)),
            )
            if value is not None
        ]
        found.append(min(values, default=math.inf))
    return found[0], found[1]


def _phase(step: Mapping[str, Any], name: str, regions: Mapping[str, Region]) -> PhaseSpec:
    kind = next(k for k in ("track", "regulate", "hold") if k in step)
    zones = []
    for constraint in step.get("constraints") or []:
        inside = "stay_inside" in constraint
        region = regions[constraint["stay_inside" if inside else "stay_outside"]]
        zones.append(Zone(region, inside))
    target = None
    if kind == "regulate":
        pose = step["regulate"]["target"]
        target = tuple(_number(pose.get(s, 0.0), f"{name}.target.{s}") for s in ("x", "y", "theta"))
    return PhaseSpec(
        name=name,
        kind=kind,
        until=step.get("until") or {},
        on_timeout=step.get("on_timeout", "fail"),
        zones=tuple(zones),
        target=target,  # type: ignore[arg-type]
        timeout=_number(step["timeout"], f"{name}.timeout") if "timeout" in step else None,
    )


# --- the run as recorded -----------------------------------------------------------


@dataclass
class Trajectory:
    columns: dict[str, FloatArray]
    phase: list[str]

    def __getitem__(self, name: str) -> FloatArray:
        return self.columns[name]


def read_trajectory(path: str | Path) -> Trajectory:
    with open(path, newline="") as stream:
        rows = csv.reader(stream)
        header = next(rows)
        records = list(rows)
    at = header.index("phase")
    columns = {
        name: np.array([float(r[i]) for r in records]) for i, name in enumerate(header) if i != at
    }
    return Trajectory(columns, [r[at] for r in records])


# --- the verdict ---------------------------------------------------------------------


@dataclass
class PhaseVerdict:
    name: str
    kind: str
    problems: list[str] = field(default_factory=list)
    metrics: dict[str, float | int | None] = field(default_factory=dict)


@dataclass
class Verdict:
    phases: list[PhaseVerdict]

    @property
    def sound(self) -> bool:
        return not self.problems

    @property
    def problems(self) -> list[str]:
        return [f"{p.name}: {problem}" for p in self.phases for problem in p.problems]


def judge(mission: str | Path | Mapping[str, Any], run_dir: str | Path) -> Verdict:
    """The verdict on a run directory of ``mission``."""
    spec = read_mission(mission)
    trajectory = read_trajectory(Path(run_dir) / "trajectory.csv")
    converged = estimate_converged(spec, trajectory)
    verdicts = []
    for name, start, end in _segments(trajectory.phase):
        phase = spec.phases[name]
        verdicts.append(_PhaseJudge(spec, phase, trajectory, start, end, converged).verdict())
    return Verdict(verdicts)


def estimate_converged(spec: MissionSpec, trajectory: Trajectory) -> float:
    """[s] when the estimate first comes within ESTIMATE_BAND (and three noise
    standard deviations) of the true pose: before, the law acts on an initial
    estimate the estimator is still correcting."""
    position = np.hypot(
        trajectory["x"] - trajectory["x_est"], trajectory["y"] - trajectory["y_est"]
    )
    heading = np.abs(wrap(trajectory["theta"] - trajectory["theta_est"]))
    within = (position <= ESTIMATE_BAND + 3 * spec.position_noise) & (
        heading <= ESTIMATE_BAND + 3 * spec.heading_noise
    )
    found = np.flatnonzero(within)
    return float(trajectory["t"][found[0]]) if found.size else math.inf


def _segments(names: list[str]) -> list[tuple[str, int, int]]:
    """(phase name, first sample, one past the last) of each stretch, in run order."""
    found = []
    start = 0
    for k in range(1, len(names) + 1):
        if k == len(names) or names[k] != names[start]:
            found.append((names[start], start, k))
            start = k
    return found


def recovery_time(spec: MissionSpec, error: float, reference_speed: float) -> float:
    """[s] the least time to take out a position error: turn round (at most half a
    turn at the turn-rate limit, reached at the turn-rate acceleration limit),
    reach the reference's speed at the acceleration limit, close the gap and the
    distance the reference gains in the time the acceleration limits add at the
    speed left over the reference's (at least a tenth of the limit), and settle
    in five time constants. Without acceleration limits the turn is
    pi / omega_max and nothing more is lost."""
    a_v, a_omega = spec.accelerations
    closing = max(spec.v_limit - reference_speed, 0.1 * spec.v_limit)
    if math.pi * a_omega < spec.omega_limit**2:  # half a turn before the rate limit is reached
        turn = 2 * math.sqrt(math.pi / a_omega)
    else:
        turn = math.pi / spec.omega_limit + spec.omega_limit / a_omega
    # the reference's gain in the time the limits add: the slower turn, and half of
    # the time from rest to v_ref (the robot covers the other half)
    lost = reference_speed * ((turn - math.pi / spec.omega_limit) + reference_speed / (2 * a_v))
    return (error + lost) / closing + turn + reference_speed / a_v + 5 * spec.time_constant


def _windows_where(flags: FloatArray, samples: int) -> FloatArray:
    """For each window start, whether every sample of the window holds."""
    counts = np.convolve(flags.astype(float), np.ones(samples), mode="valid")
    return counts >= samples - 0.5


class _PhaseJudge:
    """Every criterion on one phase's stretch of the run."""

    def __init__(
        self,
        spec: MissionSpec,
        phase: PhaseSpec,
        trajectory: Trajectory,
        start: int,
        end: int,
        converged: float,
    ) -> None:
        self.spec, self.phase = spec, phase
        self.regions = spec.regions
        self.converged = converged
        w = slice(start, end)
        self.t = trajectory["t"][w]
        self.x, self.y, self.theta = trajectory["x"][w], trajectory["y"][w], trajectory["theta"][w]
        self.v, self.omega = trajectory["v"][w], trajectory["omega"][w]
        self.x_ref, self.y_ref = trajectory["x_ref"][w], trajectory["y_ref"][w]
        self.x_est, self.y_est = trajectory["x_est"][w], trajectory["y_est"][w]
        self.theta_est = trajectory["theta_est"][w]
        # The sample at which a phase's `until` fires is the next phase's first.
        last = slice(start, min(end + 1, len(trajectory.phase)))
        self.at_end = {name: trajectory[name][last] for name in ("x", "y", "theta", "v")}
        self.result = PhaseVerdict(phase.name, phase.kind)
        self.dt = spec.dt
        self.tau = spec.time_constant
        # What the raw heading noise, corrected within the design time constant, makes
        # of the turn rate: a law that turns more on noise than that amplifies it.
        self.noise_turn_rate = spec.heading_noise / self.tau
        self.noise_speed = spec.position_noise / self.tau
        # The samples a track phase's tracking is judged at (all of a regulate phase's).
        self.tracked = np.ones(self.t.size, dtype=bool)

    def problem(self, text: str) -> None:
        self.result.problems.append(text)

    def verdict(self) -> PhaseVerdict:
        finite = np.isfinite(self.x) & np.isfinite(self.y) & np.isfinite(self.theta)
        finite &= np.isfinite(self.v) & np.isfinite(self.omega)
        if not finite.all():
            k = int(np.flatnonzero(~finite)[0])
            self.problem(f"diverged: the pose or input is not finite from t = {self.t[k]:.3f} s")
            return self.result
        if self.phase.kind == "track":
            self.tracking()
        else:
            self.regulation()
        self.goal()
        self.zones()
        self.accelerations()
        self.inputs()
        return self.result

    # --- the acceleration limits ---------------------------------------------------------

    def accelerations(self) -> None:
        """No input changes faster than the robot accelerates: the commands the
        run recorded change by at most the acceleration limit times dt a sample."""
        for name, u, rate in (
            ("v", self.v, self.spec.accelerations[0]),
            ("omega", self.omega, self.spec.accelerations[1]),
        ):
            if not math.isfinite(rate) or u.size < 2:
                continue
            change = np.abs(np.diff(u)) / self.dt
            self.result.metrics[f"{name}_acceleration_max"] = float(change.max())
            beyond = np.flatnonzero(change > rate * (1.0 + 1e-6))
            if beyond.size:
                k = int(beyond[0])
                self.problem(
                    f"{name} changes at {change[k]:.3g} per second at t = {self.t[k + 1]:.2f} s, "
                    f"beyond the acceleration limit {rate:g}"
                )

    # --- the phase's goal -------------------------------------------------------

    def goal(self) -> None:
        """The `until` condition that names a goal, met by the true pose: at the
        phase's end, or, when the phase ran out of time, at some sample of it."""
        until, spec = self.phase.until, self.spec
        if not until or self.phase.on_timeout != "fail":
            return
        x, y, theta, v = (self.at_end[name] for name in ("x", "y", "theta", "v"))
        met = np.zeros(x.size, dtype=bool)
        goals = []
        if "settled" in until:
            settled = until["settled"]
            aim = self.aim()
            position = np.hypot(x - aim[0], y - aim[1])
            heading = np.abs(wrap(theta - aim[2]))
            speed = settled.get("speed", DEFAULT_SPEED_TOLERANCE) + self.noise_speed
            met |= (
                (position <= settled["position"] + spec.position_noise)
                & (heading <= settled["heading"] + spec.heading_noise)
                & (np.abs(v) <= speed)
            )
            goals.append("settled")
            self.result.metrics["final_position_error"] = float(position[-1])
            self.result.metrics["final_heading_error"] = float(heading[-1])
        if "near" in until:
            px, py = until["near"]["point"]
            distance = np.hypot(x - px, y - py)
            met |= distance <= until["near"]["tolerance"] + spec.position_noise
            goals.append("near")
        if "reaches" in until:
            outside_by = self.regions[until["reaches"]].outside_by(x, y)
            side = outside_by > 0
            met |= (side != side[0]) | (np.abs(outside_by) <= spec.position_noise)
            goals.append("reaches")
        if "heading" in until:
            error = np.abs(wrap(theta - until["heading"]["target"]))
            met |= error <= until["heading"]["tolerance"] + spec.heading_noise
            goals.append("heading")
        if not goals:
            return  # elapsed, mission_time: no place to reach
        timed_out = self.is_last_sample_of_a_timeout()
        if met[-1] or (timed_out and met.any()):
            return
        self.problem(f"never reached its goal ({', '.join(goals)}) in truth")

    def is_last_sample_of_a_timeout(self) -> bool:
        timeout = self.phase.timeout
        return timeout is not None and self.t[-1] - self.t[0] >= timeout - 1.5 * self.dt

    def aim(self) -> tuple[float, float, float]:
        """The pose a regulate phase drives to; a hold phase's is its pose at entry."""
        if self.phase.target is not None:
            return self.phase.target
        return float(self.x_est[0]), float(self.y_est[0]), float(self.theta_est[0])

    # --- keeping up with the timed reference ----------------------------------------

    def tracking(self) -> None:
        spec, tau = self.spec, self.tau
        known = np.isfinite(self.x_ref) & np.isfinite(self.y_ref)
        if known.sum() < 2:
            return
        rx, ry = self.x_ref[known], self.y_ref[known]
        px, py = self.x[known], self.y[known]
        t = self.t[known]
        cross, lag = along_and_across(rx, ry, px, py)
        speed_ref = _speed(rx, ry, self.dt)
        speed = _speed(px, py, self.dt)
        tolerance = TRACKING_TOLERANCE + spec.position_noise
        lag_tolerance = tolerance + 3 * tau * speed_ref
        off = (cross > tolerance) | (np.abs(lag) > lag_tolerance)

        excused = np.zeros(t.size, dtype=bool)
        # The entry transient: the least time to take out the error the phase starts with.
        gap = math.hypot(px[0] - rx[0], py[0] - ry[0])
        entry = recovery_time(spec, gap, float(speed_ref[0]))
        entering = t - t[0] < entry
        # ... or less: it ends once the robot has kept up with its reference for 5 tau.
        kept_up = self.kept_up(px, py, rx, ry, tolerance)
        back = np.flatnonzero(entering & kept_up)
        if back.size:
            entering &= t < t[back[0]]
        excused |= entering
        # A phase that runs for a set time and ends in its entry was too short for the
        # limits to join its path, yet tracking it was all it was for: its end is judged.
        timed = bool(self.phase.until) and set(self.phase.until) <= {"elapsed", "mission_time"}
        ended_in_entry = bool(entering[-1]) and timed
        # A detour a zone forces: the way from the robot to its reference is blocked,
        # or the path runs into a zone within the time a turn and settling take (a
        # smooth detour starts that early), and the robot keeps moving; then the time
        # to take out what the detour left.
        blocked = self.blocked(px, py, rx, ry)
        ahead = round((math.pi / spec.omega_limit + 5 * tau) / self.dt)
        blocked |= _any_ahead(self.path_in_a_zone(rx, ry), ahead)
        # ... or the robot is on the gentle ramp, 1 across in 2 along, that leaves
        # the path before a zone and comes back after it: a slow robot's turn
        # covers less ground than that ramp.
        arc = np.r_[0.0, np.cumsum(np.hypot(np.diff(rx), np.diff(ry)))]
        blocked |= self.on_a_ramp(rx, ry, arc)
        window = max(1, round(REVERSAL_WINDOW * tau / self.dt))
        moving = _centred_mean(speed, window) >= MOVING * _centred_mean(speed_ref, window)
        detour = blocked & moving
        excused |= detour
        # A robot slowed where a zone blocks its way is stalled: its lag is
        # judged (it falls behind), its distance off the path is the detour's.
        stalled = blocked & ~moving
        off = (off & ~stalled) | (np.abs(lag) > lag_tolerance)
        # No farther from the path than the zones reach into it, plus the look-ahead
        # the law keeps and the tolerance: a detour no longer than needed, the whole
        # of it, in the entry too while the robot tracks its path (below);
        # otherwise the gap the phase starts with is the entry's.
        # The controller keeps off a zone by what its estimate may be out (section 3
        # allows the true robot no noise): three noise std; and by its body's reach.
        reach = max([z.reach(rx, ry) for z in self.phase.zones] + [0.0])
        detour_allowance = reach + spec.body + 3 * spec.position_noise + spec.look_ahead + tolerance
        # In the entry, while the robot tracks its path with its reference point
        # straight ahead: a robot behind its reference heads for it, and cuts a bend
        # between the two by at most how far the path strays from the chord there,
        # the entry's to excuse until it is back on its path.
        on_it = self.on_its_path(px, py, arc, rx, ry, lag, cross, speed_ref, tolerance)
        counted = ~entering
        tracks, cut = False, math.inf
        for k in np.flatnonzero(entering & detour.any()):
            bend = chase_bend(arc, rx, ry, k, float(lag[k]))
            if bend > tolerance:
                tracks, cut = False, max(cut, bend)
            elif on_it[k]:
                tracks, cut = True, 0.0
            counted[k] = tracks or cross[k] > cut + tolerance
        wide = (detour | stalled) & counted & (cross > detour_allowance)
        if wide.any():
            k = int(np.flatnonzero(wide)[0])
            self.problem(
                f"a detour wider than the zone needs: {cross[wide].max():.3g} m off the path "
                f"(the zones reach {reach:.3g} m into it; at most {detour_allowance:.3g} m), "
                f"first at t = {t[k]:.2f} s"
            )
        # After a detour (a stretch the robot went round in), the rejoining; it
        # ends once the robot has kept up with its reference for 5 tau.
        edges = np.flatnonzero(np.diff(blocked, prepend=False, append=False))
        for start, k in zip(edges[::2], edges[1::2], strict=True):
            if k >= t.size or not detour[start:k].any():
                continue
            error = math.hypot(px[k] - rx[k], py[k] - ry[k])
            rejoining = (t >= t[k]) & (t - t[k] < recovery_time(spec, error, float(speed_ref[k])))
            back = np.flatnonzero(rejoining & kept_up)
            excused |= rejoining & ((t < t[back[0]]) if back.size else True)
        judged = ~excused
        judged[-1] |= ended_in_entry
        self.tracked = np.zeros(self.t.size, dtype=bool)
        self.tracked[known] = judged
        m = self.result.metrics
        m["entry_time"] = entry
        crossed = judged & ~stalled
        m["cross_track_max"] = float(cross[crossed].max()) if crossed.any() else None
        m["lag_max"] = float(np.abs(lag[judged]).max()) if judged.any() else None
        m["detour_time"] = float(detour.sum() * self.dt)
        measured = (detour | stalled) & counted
        m["detour_cross_max"] = float(cross[measured].max()) if measured.any() else None
        bad = off & judged
        if bad.any():
            k = int(np.flatnonzero(bad)[0])
            if cross[k] > tolerance and not stalled[k]:
                what = f"{cross[k]:.3g} m off the path (tolerance {tolerance:.3g} m)"
            else:
                what = f"{lag[k]:.3g} m behind its reference (tolerance {lag_tolerance[k]:.3g} m)"
            self.problem(
                f"{'stalled at a zone: ' if stalled[k] else ''}{what} at t = {t[k]:.2f} s; "
                f"worst {cross[bad].max():.3g} m off, {lag[bad].max():.3g} m behind"
            )

    def kept_up(
        self, px: FloatArray, py: FloatArray, rx: FloatArray, ry: FloatArray, tolerance: float
    ) -> FloatArray:
        """Whether the robot has kept up with its reference point for 5 tau by each
        sample: at each sample of the last 5 tau within the tolerance of it, their
        velocities (from the sample before; none before the first) apart by at most
        the tolerance over 5 tau and by no more than half the reference's speed (a
        robot at rest does not keep up with a slow reference)."""
        ex, ey = px - rx, py - ry
        apart = np.r_[0.0, np.hypot(np.diff(ex), np.diff(ey))] / self.dt
        reference = np.r_[0.0, np.hypot(np.diff(rx), np.diff(ry))] / self.dt
        most = np.minimum(tolerance / (5 * self.tau), MOVING * reference)
        with_it = (np.hypot(ex, ey) <= tolerance) & (apart <= most)
        held = max(1, round(5 * self.tau / self.dt))
        return np.convolve(with_it, np.ones(held), "full")[: px.size] >= held

    def on_its_path(
        self,
        px: FloatArray,
        py: FloatArray,
        arc: FloatArray,
        rx: FloatArray,
        ry: FloatArray,
        lag: FloatArray,
        cross: FloatArray,
        speed_ref: FloatArray,
        tolerance: float,
    ) -> FloatArray:
        """Whether the robot is on its path at each sample: within the tolerance of
        it, its velocity across the path's direction there at most the tolerance
        over the settling time (5 tau), along it at least half the reference's
        speed. Its lag may still be closing: the detour's width is across the path.
        ``arc``: the reference's arc length at each point."""
        place = arc - lag
        step = 1e-3  # [m] the path's direction at the place, from points either side
        dx = np.interp(place + step, arc, rx) - np.interp(place - step, arc, rx)
        dy = np.interp(place + step, arc, ry) - np.interp(place - step, arc, ry)
        size = np.hypot(dx, dy)
        ux, uy = dx / np.where(size > 0, size, 1.0), dy / np.where(size > 0, size, 1.0)
        # the robot's velocity from the sample before
        vx, vy = np.r_[0.0, np.diff(px)] / self.dt, np.r_[0.0, np.diff(py)] / self.dt
        on_it = (
            (cross <= tolerance)
            & (np.abs(vx * uy - vy * ux) <= tolerance / (5 * self.tau))
            & (vx * ux + vy * uy >= MOVING * speed_ref)
        )
        return on_it

    def path_in_a_zone(self, rx: FloatArray, ry: FloatArray) -> FloatArray:
        """Whether each reference point is in a zone, or within the look-ahead and the
        tracking tolerance of it."""
        near = np.zeros(rx.size, dtype=bool)
        for zone in self.phase.zones:
            near |= zone.depth(rx, ry) > -self.clearance()
        return near

    def clearance(self) -> float:
        """[m] how near a zone the law may not bring the robot's axle: its look-ahead,
        the tracking tolerance and the body's reach."""
        return self.spec.look_ahead + TRACKING_TOLERANCE + self.spec.body

    def on_a_ramp(self, rx: FloatArray, ry: FloatArray, arc: FloatArray) -> FloatArray:
        """Whether each reference point is on the ramp of RAMP_SLOPE that takes a
        robot round the stretch of path in or near a keep-out zone and back: within
        (the zone's reach into the path + the clearance) / RAMP_SLOPE along the
        path (``arc``: the distance along it) of a point of that stretch."""
        ramp = np.zeros(rx.size, dtype=bool)
        for zone in self.phase.zones:
            if zone.keep_inside or zone.region.spec["type"] == "half-plane":
                continue  # no way round it
            near = np.r_[False, zone.depth(rx, ry) > -self.clearance(), False]
            edges = np.flatnonzero(near[1:] != near[:-1])
            # each point of a stretch near the zone needs its own ramp, as long
            # as it takes to go across what the zone reaches into the path there
            length = np.maximum(zone.reaches(rx, ry) + self.clearance(), 0.0) / RAMP_SLOPE
            for start, stop in zip(edges[::2], edges[1::2], strict=True):
                first = (arc[start:stop] - length[start:stop]).min()
                last = (arc[start:stop] + length[start:stop]).max()
                ramp |= (arc >= first) & (arc <= last)
        return ramp

    def blocked(self, px: FloatArray, py: FloatArray, rx: FloatArray, ry: FloatArray) -> FloatArray:
        """Whether a zone lies across the way from the robot to its reference point
        (or holds the point): on the forbidden side, or within the look-ahead and the
        tracking tolerance of it, where the law cannot bring the robot."""
        blocked = np.zeros(px.size, dtype=bool)
        clearance = self.clearance()
        for fraction in np.linspace(0.0, 1.0, 9)[1:]:
            qx, qy = px + fraction * (rx - px), py + fraction * (ry - py)
            for zone in self.phase.zones:
                blocked |= zone.depth(qx, qy) > -clearance
        return blocked

    # --- regulation: progress to the target -------------------------------------------

    def regulation(self) -> None:
        """A regulate phase makes progress until it is at its goal: no stall, no
        limit cycle. Progress over a window is 10 % of the position error (or of
        what the speed limit covers in the window) or of the heading error."""
        if self.phase.kind != "regulate":
            aim = self.aim()
            drift = np.hypot(self.x - aim[0], self.y - aim[1])
            allowed = TRACKING_TOLERANCE + self.spec.position_noise
            self.result.metrics["hold_drift_max"] = float(drift.max())
            if drift.max() > allowed:
                self.problem(f"drifted {drift.max():.3g} m from the pose it holds ({allowed:.3g})")
            return
        spec = self.spec
        aim = self.aim()
        if any(
            zone.depth(np.array([aim[0]]), np.array([aim[1]]))[0] > 0 for zone in self.phase.zones
        ):
            return  # a target beyond a zone: the robot stops as near as the zone allows
        settled = self.phase.until.get("settled") or {}
        position_tolerance = settled.get("position", TRACKING_TOLERANCE) + spec.position_noise
        heading_tolerance = settled.get("heading", 0.05) + spec.heading_noise
        position = np.hypot(self.x - aim[0], self.y - aim[1])
        heading = np.abs(wrap(self.theta - aim[2]))
        at_goal = (position <= position_tolerance) & (heading <= heading_tolerance)
        window = max(round(STALL_WINDOW * self.tau / self.dt), 2)
        window = max(window, round((math.pi / spec.omega_limit + 10 * self.tau) / self.dt))
        if position.size <= window:
            return
        first, last = position[:-window], position[window:]
        gained = first - last >= PROGRESS * np.minimum(first, spec.v_limit * window * self.dt)
        h_first, h_last = heading[:-window], heading[window:]
        turned = h_first - h_last >= PROGRESS * np.minimum(
            h_first, spec.omega_limit * window * self.dt
        )
        self.overshoot(aim, position, position_tolerance)
        away = ~_any_in_windows(at_goal, window + 1)
        stuck = away & ~gained & ~turned
        self.result.metrics["stall_time"] = float(stuck.sum() * self.dt)
        if stuck.any():
            k = int(np.flatnonzero(stuck)[0])
            moved = math.hypot(self.x[k + window] - self.x[k], self.y[k + window] - self.y[k])
            self.problem(
                f"stalled: from t = {self.t[k]:.2f} s, {window * self.dt:.2f} s without progress "
                f"({position[k]:.3g} m and {heading[k]:.3g} rad from the target, moved "
                f"{moved:.3g} m)"
            )

    def overshoot(
        self, aim: tuple[float, float, float], position: FloatArray, tolerance: float
    ) -> None:
        """A park stops at its target: the true position goes no further past it,
        along the way in (from where the phase started to the target), than the
        goal's position tolerance. A phase started within its goal has no way in."""
        if position[0] <= tolerance:
            return
        way_x, way_y = (aim[0] - self.x[0]) / position[0], (aim[1] - self.y[0]) / position[0]
        beyond = float(((self.x - aim[0]) * way_x + (self.y - aim[1]) * way_y).max())
        self.result.metrics["overshoot"] = max(beyond, 0.0)
        if beyond > tolerance:
            k = int(np.argmax((self.x - aim[0]) * way_x + (self.y - aim[1]) * way_y))
            self.problem(
                f"overshot: {beyond:.3g} m past the target at t = {self.t[k]:.2f} s "
                f"(goal {tolerance:.3g} m)"
            )

    # --- zones --------------------------------------------------------------------------

    def zones(self) -> None:
        """No true position beyond a zone's edge by more than ZONE_TOLERANCE. A
        phase that starts beyond it has the time to leave by the shortest way."""
        for zone in self.phase.zones:
            depth = zone.depth(self.x, self.y)
            inside = depth > ZONE_TOLERANCE
            key = f"zone_depth_max[{zone}]"
            self.result.metrics[key] = float(depth.max())
            if not inside.any():
                continue
            excused = np.zeros(depth.size, dtype=bool)
            if inside[0]:
                out = np.flatnonzero(~inside)
                left = int(out[0]) if out.size else depth.size
                allowed = recovery_time(self.spec, float(depth[0]), 0.0)
                if left * self.dt > allowed:
                    self.problem(
                        f"started {depth[0]:.3g} m beyond the zone ({zone}) and did not leave "
                        f"within {allowed:.2f} s"
                    )
                    continue
                excused[:left] = True
            bad = inside & ~excused
            if bad.any():
                k = int(np.flatnonzero(bad)[0])
                self.problem(
                    f"true position {depth[bad].max():.3g} m beyond the zone ({zone}), first at "
                    f"t = {self.t[k]:.2f} s"
                )

    # --- input quality ------------------------------------------------------------------

    def inputs(self) -> None:
        """Kicks, chatter, fights at the limit and jitter, once the estimate has converged."""
        spec, m = self.spec, self.result.metrics
        first = int(np.searchsorted(self.t, self.converged - 0.5 * self.dt))
        if first >= self.t.size:
            return
        self.t, self.v, self.omega = self.t[first:], self.v[first:], self.omega[first:]
        self.x, self.y = self.x[first:], self.y[first:]
        self.x_ref, self.y_ref = self.x_ref[first:], self.y_ref[first:]
        self.tracked = self.tracked[first:]
        for name, u, limit in (
            ("v", self.v, spec.v_limit),
            ("omega", self.omega, spec.omega_limit),
        ):
            jumps = np.abs(np.diff(u))
            kicks = np.flatnonzero(jumps > KICK * limit)
            m[f"{name}_kicks"] = int(kicks.size)
            if kicks.size:
                k = int(kicks[0])
                self.problem(
                    f"kick: {name} jumps from {u[k]:.3g} to {u[k + 1]:.3g} in one sample at "
                    f"t = {self.t[k + 1]:.2f} s ({kicks.size} such jumps; limit {limit:g})"
                )
            self.reversals(name, u, limit)
            self.saturation(name, u, limit)
        self.jitter()

    def reversals(self, name: str, u: FloatArray, limit: float) -> None:
        """Chatter: more sign reversals in REVERSAL_WINDOW time constants than an
        oscillation at the design's own rate (period 2 pi tau) makes."""
        floor = REVERSAL_FLOOR * limit + (3 * self.noise_turn_rate if name == "omega" else 0.0)
        counted = np.flatnonzero(np.abs(u) > floor)
        signs = np.sign(u[counted])
        flips = counted[1:][signs[1:] != signs[:-1]]  # the sample each reversal arrives at
        window = REVERSAL_WINDOW * self.tau
        allowed = math.floor(window / (math.pi * self.tau))
        most = 0
        at = None
        times = self.t[flips]
        for i in range(times.size):
            count = int(np.searchsorted(times, times[i] + window) - i)
            if count > most:
                most, at = count, times[i]
        self.result.metrics[f"{name}_reversals_most"] = most
        if most > allowed:
            self.problem(
                f"chatter: {name} reverses {most} times within {window:.2f} s from t = {at:.2f} s "
                f"(at most {allowed})"
            )

    def saturation(self, name: str, u: FloatArray, limit: float) -> None:
        """Sustained saturation (at least one time constant) is a fight at the limit
        unless deliberate: one sign, and, for the speed, most of it spent on
        progress (towards the target; along the path); for the turn rate, no more
        than half a turn."""
        at_limit = np.abs(u) >= limit * (1 - AT_LIMIT)
        shortest = max(2, round(self.tau / self.dt))
        edges = np.flatnonzero(np.diff(np.r_[0, at_limit.astype(int), 0]))
        fights = 0
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if b - a < shortest:
                continue
            span = (b - a) * self.dt
            one_sign = abs(np.sign(u[a:b]).sum()) == b - a
            deliberate = one_sign and (
                self.progress_at_speed(a, b) >= DELIBERATE * limit * span
                if name == "v"
                else span * limit <= math.pi + 2 * limit * self.dt
            )
            if not deliberate:
                fights += 1
                if fights == 1:
                    self.problem(
                        f"fight at the limit: {name} at its limit ({limit:g}) for {span:.2f} s "
                        f"from t = {self.t[a]:.2f} s" + ("" if one_sign else ", both ways")
                    )
        self.result.metrics[f"{name}_fights"] = fights

    def progress_at_speed(self, a: int, b: int) -> float:
        """[m] progress made over samples a..b: towards the target; on a path, along
        it or towards the reference point, whichever is more (catching up)."""
        end = min(b, self.t.size - 1)
        if self.phase.kind == "track":
            x, y = self.x[a : end + 1], self.y[a : end + 1]
            rx, ry = self.x_ref[a : end + 1], self.y_ref[a : end + 1]
            if x.size < 2:
                return 0.0
            return max(
                _travel_along(x, y, np.gradient(rx), np.gradient(ry)),
                _travel_along(x, y, rx - x, ry - y),
            )
        aim = self.aim()
        before = math.hypot(self.x[a] - aim[0], self.y[a] - aim[1])
        after = math.hypot(self.x[end] - aim[0], self.y[end] - aim[1])
        return before - after

    def jitter(self) -> None:
        """Turn-rate jitter: the spread of omega about its centred moving mean over two
        time constants (robust: 1.4826 times the median absolute deviation, so a
        manoeuvre's few steps, judged as kicks, do not count), beyond JITTER_FLOOR of
        the limit plus what the heading noise explains (noise_turn_rate); on a path,
        over the samples its tracking is judged at (the entry and a detour are
        manoeuvres, each step of the turn rate in them deviating from the moving
        mean for two time constants), or all if none is."""
        half = max(2, round(self.tau / self.dt))
        window = 2 * half + 1
        skip = round(REVERSAL_WINDOW * self.tau / self.dt)  # the law's switch at entry
        if self.omega.size < window + skip:
            return
        mean = np.convolve(self.omega, np.ones(window) / window, mode="valid")
        deviation = self.omega[half:-half] - mean
        deviation = deviation[max(0, skip - half) :]
        first = half + max(0, skip - half)
        tracked = self.tracked[first : first + deviation.size]
        if tracked.any():
            deviation = deviation[tracked]
        value = float(ROBUST_STD * np.median(np.abs(deviation)))
        allowed = JITTER_FLOOR * self.spec.omega_limit + self.noise_turn_rate
        self.result.metrics["turn_rate_jitter"] = value
        if value > allowed:
            self.problem(f"turn-rate jitter {value:.3g} rad/s (at most {allowed:.3g})")


def _travel_along(x: FloatArray, y: FloatArray, ux: FloatArray, uy: FloatArray) -> float:
    """[m] the robot's travel x, y projected on the directions (ux, uy) of its samples."""
    norm = np.hypot(ux, uy)[:-1]
    ok = np.isfinite(norm) & (norm > 0)
    dx, dy = np.diff(x)[ok], np.diff(y)[ok]
    return float(((dx * ux[:-1][ok] + dy * uy[:-1][ok]) / norm[ok]).sum())


def _any_ahead(flags: FloatArray, samples: int) -> FloatArray:
    """Whether any of each sample and the ``samples`` after it holds."""
    counts = np.convolve(flags[::-1].astype(float), np.ones(samples + 1))[: flags.size][::-1]
    return counts > 0.5


def _any_in_windows(flags: FloatArray, samples: int) -> FloatArray:
    counts = np.convolve(flags.astype(float), np.ones(samples), mode="valid")
    return counts > 0.5


def _speed(x: FloatArray, y: FloatArray, dt: float) -> FloatArray:
    """Speed [m/s] at each sample, from the positions (centred differences)."""
    if x.size < 2:
        return np.zeros(x.size)
    return np.hypot(np.gradient(x, dt), np.gradient(y, dt))


def _centred_mean(values: FloatArray, samples: int) -> FloatArray:
    """Mean over a centred window of ``samples`` (fewer at the ends, and in a short stretch)."""
    samples = max(1, min(samples, values.size))
    kernel = np.ones(samples)
    total = np.convolve(values, kernel, mode="same")
    counts = np.convolve(np.ones(values.size), kernel, mode="same")
    return total / counts


def chase_bend(arc: FloatArray, rx: FloatArray, ry: FloatArray, k: int, lag: float) -> float:
    """[m] the farthest the reference's polyline (``arc``: its arc length at each
    point) strays, between the point ``lag`` behind point ``k`` along it and point
    ``k``, from the chord between those two points."""
    at = arc[k] - lag
    between = (arc > min(at, arc[k])) & (arc < max(at, arc[k]))
    if not between.any():
        return 0.0
    ax, ay = np.interp(at, arc, rx), np.interp(at, arc, ry)
    cx, cy = rx[k] - ax, ry[k] - ay
    size = math.hypot(cx, cy)
    if size == 0.0:
        return 0.0
    return float(np.abs(cx * (ry[between] - ay) - cy * (rx[between] - ax)).max() / size)


def along_and_across(
    rx: FloatArray, ry: FloatArray, px: FloatArray, py: FloatArray
) -> tuple[FloatArray, FloatArray]:
    """Cross-track error [m] and along-track lag [m, > 0 behind] of each position
    against the timed reference: the nearest point of the reference's polyline
    (among near-equally near points, the one nearest in arc length to the
    sample's own reference point), and the arc length from it to that point."""
    steps = np.hypot(np.diff(rx), np.diff(ry))
    arc = np.r_[0.0, np.cumsum(steps)]
    ax, ay, bx, by = rx[:-1], ry[:-1], rx[1:], ry[1:]
    sx, sy = bx - ax, by - ay
    length2 = sx * sx + sy * sy
    safe = np.where(length2 > 0, length2, 1.0)
    cross = np.empty(px.size)
    lag = np.empty(px.size)
    for start in range(0, px.size, 256):
        part = slice(start, start + 256)
        qx, qy = px[part, None], py[part, None]
        along = np.clip(((qx - ax) * sx + (qy - ay) * sy) / safe, 0.0, 1.0)
        distance = np.hypot(qx - ax - along * sx, qy - ay - along * sy)
        position = arc[:-1] + along * steps  # arc length of each segment's nearest point
        own = arc[np.arange(px.size)[part]][:, None]
        # Ties (a closed path run round again, a path back over itself): the nearest in
        # time, among the path's stretches each nearest where it is (a local minimum
        # along the path: not a point just ahead, slightly farther, on the same line).
        padded = np.pad(distance, ((0, 0), (1, 1)), constant_values=np.inf)
        local = (distance <= padded[:, :-2]) & (distance <= padded[:, 2:])
        near = local & (distance <= distance.min(axis=1, keepdims=True) + 0.01)
        choice = np.where(near, np.abs(position - own), np.inf).argmin(axis=1)
        rows = np.arange(choice.size)
        cross[part] = distance[rows, choice]
        lag[part] = own[:, 0] - position[rows, choice]
    return cross, lag


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("mission", type=Path)
    parser.add_argument("run_dir", type=Path)
    args = parser.parse_args(argv)
    verdict = judge(args.mission, args.run_dir)
    for phase in verdict.phases:
        shown = ", ".join(
            f"{k} {v:.3g}" if isinstance(v, float) else f"{k} {v}" for k, v in phase.metrics.items()
        )
        print(f"{phase.name} ({phase.kind}): {shown}")
    print("sound" if verdict.sound else "unsound:\n  " + "\n  ".join(verdict.problems))
    return 0 if verdict.sound else 1


if __name__ == "__main__":
    raise SystemExit(main())
