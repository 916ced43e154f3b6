"""Typed model of a mission file (format version 1).

Every model forbids unknown keys and is frozen (wmr_mission.fields). Defaults
reproduce section IV of "A New On-line Observer-Based Controller for Wheeled
Non-holonomic Mobile Robots". Units are SI, angles in radians.

The sections written in several variants are registries
(wmr_mission.fields.Registry): the path of a track phase
(wmr_mission.geometry.paths), the estimator (wmr_mission.estimators) and the
controller (wmr_mission.controllers). A variant registered after this module
is loaded rebuilds the models that embed it, so the mission accepts it.
"""

from __future__ import annotations

import math
import re
from typing import TYPE_CHECKING, Annotated, Any, Final, Literal, NoReturn

import numpy as np
from pydantic import (
    AfterValidator,
    ConfigDict,
    Discriminator,
    Field,
    Strict,
    Tag,
    ValidatorFunctionWrapHandler,
    create_model,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

from wmr_mission.basics import STATES, StateName, measurement_mask
from wmr_mission.controllers import CONTROLLERS, ControllerSettings
from wmr_mission.controllers.paper import PaperController
from wmr_mission.estimators import ESTIMATORS, EstimatorSettings, Measurements
from wmr_mission.estimators.observer import ConstrainedObserver
from wmr_mission.fields import (
    IDENTIFIER,
    LARGEST_SEED,
    MAX_FORMULA_LENGTH,
    SMALLEST_POSITIVE,
    BurstLength,
    Duration,
    Model,
    NonNegative,
    NonNegativeScalar,
    Number,
    Point,
    Pose,
    Positive,
    PositiveScalar,
    ProbabilityScalar,
    RegionName,
    Scalar,
    SlipFraction,
    StateOffset,
    StateStd,
    at_least,
)
from wmr_mission.geometry import paths
from wmr_mission.geometry.paths import PATHS, PathSettings
from wmr_mission.geometry.regions import RegionSpec
from wmr_mission.geometry.routes import ROUTE_ACCELERATION_SHARE
from wmr_mission.spec import catalog
from wmr_mission.spec.backend import Backend
from wmr_mission.spec.reactions import Geofence, Reaction, Then

__all__ = [
    "ACTIONS",
    "Constraint",
    "Contingency",
    "Disturbances",
    "Dropout",
    "Expect",
    "Footprint",
    "HeadingCondition",
    "Hold",
    "HoldPhase",
    "Limits",
    "Mission",
    "Near",
    "Outliers",
    "Phase",
    "PhaseExpect",
    "Plot",
    "PolygonFootprint",
    "Regulate",
    "RegulatePhase",
    "Repeat",
    "RepeatPhase",
    "Robot",
    "RoundFootprint",
    "Sensors",
    "Settled",
    "Slip",
    "StateThresholds",
    "StateTolerance",
    "StayInside",
    "StayOutside",
    "Step",
    "Threshold",
    "Track",
    "TrackPhase",
    "Until",
    "Update",
    "UpdateWhen",
]

# Names an expression already gives a meaning to; a parameter may not hide them.
RESERVED_NAMES: Final = frozenset({"t", "pi", "e"})

MISSION_NAME: Final = r"^[a-z0-9][a-z0-9_-]{0,63}$"
PHASE_NAME: Final = r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$"


# --- robot -----------------------------------------------------------------


class Acceleration(Model):
    """The robot's largest changes of its inputs per second."""

    v: Positive = Field(description="Largest |dv/dt|, linear acceleration [m/s^2].")
    omega: Positive = Field(description="Largest |domega/dt|, turn-rate acceleration [rad/s^2].")


class Limits(Model):
    """Actuator limits; inputs are saturated to them."""

    v: Positive = Field(default=10.0, description="Largest |v|, linear speed [m/s].")
    omega: Positive = Field(default=20.0, description="Largest |omega|, turn rate [rad/s].")
    v_rate: Positive | None = Field(
        default=None, description="Largest |dv/dt| [m/s^2]; null = unlimited."
    )
    omega_rate: Positive | None = Field(
        default=None, description="Largest |domega/dt| [rad/s^2]; null = unlimited."
    )
    acceleration: Acceleration | None = Field(
        default=None,
        description=(
            "The robot's own acceleration limits: the plant applies the commands no faster, "
            "and the controller (its zone filter too) commands no faster (the tighter of "
            "these and v_rate, omega_rate) and plans for them: the regulator its "
            "deceleration, the tracking law its turn and an error's time constant, a "
            "regulate phase's zones the braking distance, a polyline or coverage route "
            "its stops (slowing into them at half the acceleration); null = unlimited."
        ),
    )


class Slip(Model):
    """Wheel slip of the true plant."""

    longitudinal: SlipFraction = Field(
        default=0.0, description="Fraction of v lost to slip, in [0, 1)."
    )
    lateral_std: NonNegativeScalar = Field(
        default=0.0,
        description="Standard deviation of a sideways skid speed, drawn every sample [m/s].",
    )


class Disturbances(Model):
    """The true plant departs from eq. (1): noise, delay, lag and slip."""

    process_noise_std: StateStd = Field(
        default_factory=lambda: StateStd.defaults(),
        description="Gaussian noise added to the true pose every sample [m, m, rad].",
    )
    input_delay: NonNegativeScalar = Field(
        default=0.0,
        description="[s] the plant applies u_{k-d}, d = input_delay / dt (a whole number).",
    )
    actuator_time_constant: NonNegativeScalar = Field(
        default=0.0,
        description="[s] first-order lag of the applied v and omega behind the command; 0 = none.",
    )
    slip: Slip = Field(default_factory=lambda: Slip.defaults(), description="Wheel slip.")


class RoundFootprint(Model):
    """A round robot: a disc about the axle's centre."""

    radius: Positive = Field(description="Radius [m], > 0.")

    def reach(self) -> float:
        """[m] the farthest point of the body from the axle's centre."""
        return float(self.radius)


class PolygonFootprint(Model):
    """A robot whose outline is a convex polygon in its own frame (x ahead, y left,
    the origin at the axle's centre)."""

    polygon: list[Point] = Field(
        min_length=3,
        max_length=100,
        description="At least 3 corners [[x, y], ...] [m] in the robot's frame, convex.",
    )

    @field_validator("polygon")
    @classmethod
    def _convex(cls, polygon: list[tuple[float, float]]) -> list[tuple[float, float]]:
        import shapely  # the geometry library; only a polygon footprint needs it

        outline = shapely.Polygon(polygon)
        scale = max(max(abs(float(x)), abs(float(y))) for x, y in polygon)
        if len(set(polygon)) != len(polygon) or outline.area <= 1e-9 * scale * scale:
            raise PydanticCustomError(
                "degenerate_footprint",
                "a footprint polygon needs distinct corners that enclose an area",
            )
        if not outline.is_valid or outline.convex_hull.area - outline.area > 1e-9 * outline.area:
            raise PydanticCustomError(
                "convex_footprint",
                "a footprint polygon must be convex, its corners in order round it "
                "(the zones are kept by the disc about the axle that holds it)",
            )
        return polygon

    def reach(self) -> float:
        """[m] the farthest corner from the axle's centre: the radius of the disc
        the zones are kept by (docs/paper-notes.md, "The robot's body")."""
        return max(math.hypot(float(x), float(y)) for x, y in self.polygon)


def _footprint_kind(value: Any) -> str | None:
    if isinstance(value, RoundFootprint | PolygonFootprint):
        return "radius" if isinstance(value, RoundFootprint) else "polygon"
    if isinstance(value, dict):
        for key in ("radius", "polygon"):
            if key in value:
                return key
    return None


Footprint = Annotated[
    Annotated[RoundFootprint, Tag("radius")] | Annotated[PolygonFootprint, Tag("polygon")],
    Discriminator(
        _footprint_kind,
        custom_error_type="footprint_kind",
        custom_error_message="a footprint is {radius: R} or {polygon: [[x, y], ...]}",
    ),
]


class Robot(Model):
    """The plant of eq. (1), sampled."""

    dt: Annotated[Number, Field(gt=0, le=1), at_least(SMALLEST_POSITIVE)] = Field(
        default=0.01, description="Sampling period [s], in (0, 1]."
    )
    initial_state: Pose = Field(
        default_factory=Pose, description="True pose at mission start [m, m, rad]."
    )
    limits: Limits = Field(default_factory=Limits, description="Input limits.")
    disturbances: Disturbances = Field(
        default_factory=lambda: Disturbances.defaults(),
        description=(
            "How the true plant departs from eq. (1); the estimator and controller never see "
            "these settings (docs/disturbances.md). Default: none."
        ),
    )
    footprint: Footprint | None = Field(
        default=None,
        description=(
            "The robot's body: {radius: R} or {polygon: [[x, y], ...]} in its own frame [m]. "
            "Zones are kept by the body (a polygon by the disc about the axle that holds it), "
            "and clearance_min is judged on it; null = a point at the axle's centre."
        ),
    )


class Dropout(Model):
    """Measurements lost in bursts (a two-state Markov chain per measurement)."""

    probability: ProbabilityScalar = Field(
        description="Probability that a burst of lost measurements starts at a measurement."
    )
    burst: BurstLength = Field(
        default=1.0,
        description=(
            "Mean burst length in measurements, >= 1; lengths are geometric (a lost "
            "measurement is followed by another with probability 1 - 1/burst)."
        ),
    )


class Outliers(Model):
    """Wild measurements: a large Gaussian error added now and then."""

    probability: ProbabilityScalar = Field(
        description="Probability that a measurement is an outlier."
    )
    std: StateStd = Field(description="Standard deviation of the outlier's error [m, m, rad].")


class Sensors(Model):
    """Which states are measured, how often, and how they err."""

    measure: tuple[StateName, ...] = Field(
        default=STATES,
        min_length=1,
        description="Measured states: a non-empty subset of x, y, theta without repeats.",
        json_schema_extra={"uniqueItems": True},
    )
    noise_std: StateStd = Field(
        default_factory=lambda: StateStd.defaults(),
        description="Additive white Gaussian noise on each measured state [m, m, rad].",
    )
    seed: Annotated[int, Strict(), Field(ge=0, le=LARGEST_SEED)] = Field(
        default=0,
        description=(
            "Seed of every random draw of the run (noise and disturbances), 0 .. 2^32-1; "
            "`run --seed` overrides it."
        ),
    )
    period: PositiveScalar | None = Field(
        default=None,
        description=(
            "[s] time between measurements, a whole multiple of robot.dt; the estimator "
            "predicts on the samples between. null = every sample."
        ),
    )
    bias: StateOffset = Field(
        default_factory=lambda: StateOffset.defaults(),
        description="Constant offset added to each measured state [m, m, rad].",
    )
    dropout: Dropout | None = Field(
        default=None, description="Measurements lost in bursts; null = none lost."
    )
    outliers: Outliers | None = Field(default=None, description="Wild measurements; null = none.")

    @field_validator("measure")
    @classmethod
    def _no_repeats(cls, measure: tuple[str, ...]) -> tuple[str, ...]:
        repeated = sorted({s for s in measure if measure.count(s) > 1})
        if repeated:
            raise PydanticCustomError(
                "repeated_state", "state '{state}' is listed twice", {"state": repeated[0]}
            )
        return measure

    def measured_noise(self) -> dict[str, float]:
        """The standard deviation of each measured state's noise [m or rad], in
        the order ``measure`` lists them: the one reading of ``noise_std``
        (a state not measured has no measurement to be noisy)."""
        return {state: float(getattr(self.noise_std, state)) for state in self.measure}


# --- expectations ----------------------------------------------------------


def _formula(text: str) -> str:
    """A temporal formula, parsed: its grammar (wmr_mission.spec.temporal) is
    imported by the first mission that writes one, not by every check and run
    (docs/performance.md, Start-up)."""
    from wmr_mission.spec.temporal import checked_formula

    return checked_formula(text)


Formula = Annotated[
    str,
    Field(
        min_length=1,
        max_length=MAX_FORMULA_LENGTH,
        description=(
            "A temporal formula over the phase's signals, e.g. "
            "'eventually[0, 10](always(cross_track <= 0.02))' (see Temporal expectations)."
        ),
    ),
    AfterValidator(_formula),
]


class Threshold(Model):
    """An upper bound on a run metric."""

    max: NonNegative = Field(description="Largest accepted value, in the metric's unit.")


class StateThresholds(Model):
    """An upper bound per state, in the state's unit; a state left out is not checked."""

    x: NonNegative | None = Field(default=None, description="[m] bound for x.")
    y: NonNegative | None = Field(default=None, description="[m] bound for y.")
    theta: NonNegative | None = Field(default=None, description="[rad] bound for theta.")


# The paper's "short transient" acceptance, in metres and radians alike.
DEFAULT_CONVERGENCE_TOLERANCE: Final = 0.05


class StateTolerance(Model):
    """A tolerance per state, in the state's unit."""

    x: Positive = Field(
        default=DEFAULT_CONVERGENCE_TOLERANCE, description="[m] tolerance for x, > 0."
    )
    y: Positive = Field(
        default=DEFAULT_CONVERGENCE_TOLERANCE, description="[m] tolerance for y, > 0."
    )
    theta: Positive = Field(
        default=DEFAULT_CONVERGENCE_TOLERANCE, description="[rad] tolerance for theta, > 0."
    )


# A threshold `expect` derives from the mission's own numbers (docs/mission-format.md,
# "Verdicts"); the value used is in summary.json's `expectations`.
Auto = Literal["auto"]


class _PhaseThresholds(Model):
    """Thresholds on one phase's metrics; a key left out (or null) takes the mission's value."""

    settle_time: NonNegative | None = Field(
        default=None,
        description=(
            "[s] the start of the phase that tracking_error_*, *_at_limit and estimation_rms "
            "leave out (the entry transient)."
        ),
    )
    temporal: tuple[Formula, ...] | None = Field(
        default=None,
        max_length=64,
        description=(
            "Temporal formulas over the phase's signals, each a check with its robustness as "
            "margin (see Temporal expectations); a mission-wide one applies to each phase that "
            "measures its signals."
        ),
    )

    def threshold(self, name: str) -> Any:
        """The value of metric ``name``'s key (wmr_mission.spec.catalog): a
        Threshold, `auto`, a number, StateThresholds, or None (not set)."""
        return getattr(self, name)


# The type of a metric's `expect` key, by what it takes (catalog.Metric.expect).
_KEY_TYPES: Final[dict[str, Any]] = {
    "threshold": Threshold | None,
    "auto": Threshold | Auto | None,
    "number": Scalar | None,
    "per-state": StateThresholds | None,
}


def _default(value: Any) -> Any:
    return Threshold(**value) if isinstance(value, dict) else value


def _thresholds(
    name: str, base: type[Model], doc: str, metrics: list[catalog.Metric], defaults: bool
) -> Any:
    """The `expect` model ``name``: ``base`` with a key per metric of the catalog,
    with its default and its words (``defaults``), else null."""
    fields: dict[str, Any] = {}
    for metric in metrics:
        words = f" {metric.default_words}" if defaults and metric.default_words else ""
        default = _default(metric.default) if defaults else None
        fields[metric.name] = (
            _KEY_TYPES[metric.expect],
            Field(default=default, description=f"{metric.description}{words}"),
        )
    return create_model(name, __base__=base, __doc__=doc, __module__=__name__, **fields)


# A phase's own `expect`: a key per metric of a phase in the catalog, null unless written.
if TYPE_CHECKING:
    PhaseExpect = _PhaseThresholds
else:
    PhaseExpect = _thresholds(
        "PhaseExpect",
        _PhaseThresholds,
        _PhaseThresholds.__doc__,
        list(catalog.phase_metrics()),
        defaults=False,
    )


# --- phases ----------------------------------------------------------------


class Near(Model):
    """The estimated position is within tolerance of a point."""

    point: Point = Field(description="Point [x, y] [m].")
    tolerance: Positive = Field(description="Distance [m], > 0.")


class Settled(Model):
    """The estimated pose is at the target and the robot has stopped (regulate/hold only)."""

    position: Positive = Field(description="Position tolerance [m], > 0.")
    heading: Positive = Field(description="Heading tolerance [rad], > 0.")
    speed: Positive = Field(default=0.01, description="Largest |v| [m/s], > 0.")


class HeadingCondition(Model):
    """The estimated heading is within tolerance of a target (wrapped)."""

    target: Scalar = Field(description="Target heading [rad].")
    tolerance: Positive = Field(description="Tolerance [rad], > 0.")


class Until(Model):
    """Exit conditions: the phase ends when ANY given one holds."""

    elapsed: Duration | None = Field(default=None, description="Phase time [s], > 0.")
    mission_time: Duration | None = Field(default=None, description="Mission time [s], > 0.")
    reaches: RegionName | None = Field(
        default=None,
        description="A region whose boundary the estimated position crosses (from either side).",
    )
    near: Near | None = Field(default=None, description="Near a point.")
    settled: Settled | None = Field(default=None, description="Settled at the target.")
    heading: HeadingCondition | None = Field(default=None, description="Heading reached.")


class UpdateWhen(Model):
    """When an update takes over: exactly one of these, checked on the estimate
    at each sample, from the phase's entry (or the update before it)."""

    elapsed: Duration | None = Field(default=None, description="Phase time [s], > 0.")
    mission_time: Duration | None = Field(default=None, description="Mission time [s], > 0.")
    reaches: RegionName | None = Field(
        default=None,
        description="A region the estimated position is inside (or on the boundary of).",
    )
    travelled: Positive | None = Field(
        default=None,
        description="Distance [m] the estimated position has covered since the phase was entered.",
    )
    lap: Annotated[int, Strict(), Field(ge=1, le=10000)] | None = Field(
        default=None,
        description="A phase of a repeat: from its lap N on, at the lap's first sample.",
    )


class Update(Model):
    """A change of the phase's reference while it runs (docs/mission-format.md,
    "References that change on-line"): a new path for a track phase, a new
    target for a regulate phase."""

    when: UpdateWhen = Field(description="When it takes over (exactly one condition).")
    path: Annotated[PathSettings, PATHS] | None = Field(
        default=None,
        description="track: the new path, instantiated from the estimated pose at the update.",
    )
    target: Pose | None = Field(default=None, description="regulate: the new target pose.")
    speed: Positive | None = Field(
        default=None,
        description=(
            "track: the same path from the reference point in force, at this speed: "
            "[m/s] for a path with a speed, [rad/s] (|angular_rate|) for one with an "
            "angular_rate."
        ),
    )
    look_ahead: Positive | None = Field(
        default=None,
        description="track: the controller's look-ahead distance [m] for the rest of the phase.",
    )


class StayInside(Model):
    """Keep the robot inside a region (the corrective control of eqs. (22)-(28))."""

    stay_inside: RegionName = Field(description="Region name.")


class StayOutside(Model):
    """Keep the robot outside a region (any type: ellipse, circle, half-plane, box or polygon)."""

    stay_outside: RegionName = Field(description="Region name.")


def _constraint_kind(value: Any) -> str | None:
    if isinstance(value, dict | StayInside | StayOutside):
        keys = value if isinstance(value, dict) else type(value).model_fields
        for key in ("stay_inside", "stay_outside"):
            if key in keys:
                return key
    return None


Constraint = Annotated[
    Annotated[StayInside, Tag("stay_inside")] | Annotated[StayOutside, Tag("stay_outside")],
    Discriminator(
        _constraint_kind,
        custom_error_type="constraint_kind",
        custom_error_message="a constraint is {stay_inside: REGION} or {stay_outside: REGION}",
    ),
]


class Track(Model):
    """Follow a path (the Case 2 law)."""

    path: Annotated[PathSettings, PATHS] = Field(
        description="The path, instantiated at phase entry."
    )


class Regulate(Model):
    """Drive to a target pose (the Case 1 law)."""

    target: Pose = Field(description="Target pose [m, m, rad].")


class Hold(Model):
    """Regulate to the pose estimated at phase entry."""


_PHASE_DESCRIPTION: Final = "Unique phase name: letters, digits, '-' and '_', at most 64."


class _PhaseCommon(Model):
    name: Annotated[str, Field(pattern=PHASE_NAME)] = Field(description=_PHASE_DESCRIPTION)
    until: Until = Field(default_factory=Until, description="Exit conditions (any of).")
    timeout: Duration | None = Field(
        default=None,
        description="Phase time limit [s], > 0; needed unless until has elapsed or mission_time.",
    )
    on_timeout: Reaction | None = Field(
        default=None,
        description=(
            "At timeout: fail the mission, go on to the next phase, or another reaction "
            "(see Reactions); unset: the mission's on_timeout, else fail."
        ),
    )
    on_breach: Reaction | None = Field(
        default=None,
        description="When the geofence is breached; unset: the mission's on_breach, else fail.",
    )
    on_failure: Reaction | None = Field(
        default=None,
        description="When a verdict of the phase is missed at its end, and at a timeout or breach "
        "without a reaction of its own; unset: the mission's on_failure.",
    )
    constraints: tuple[Constraint, ...] = Field(
        default=(),
        max_length=64,
        description=(
            "Keep-in and keep-out zones (eq. (28)); on a track phase they win over the path."
        ),
    )
    expect: PhaseExpect = Field(
        default_factory=lambda: PhaseExpect.defaults(),
        description="Thresholds on this phase's metrics, overriding the mission's expect.",
    )
    updates: tuple[Update, ...] = Field(
        default=(),
        max_length=64,
        description="Changes of the reference while the phase runs, in order; each fires once.",
    )


class TrackPhase(_PhaseCommon):
    """Track a path."""

    track: Track = Field(description="What to track.")


class RegulatePhase(_PhaseCommon):
    """Regulate to a target pose."""

    regulate: Regulate = Field(description="Where to go.")


class HoldPhase(_PhaseCommon):
    """Hold the pose estimated at phase entry."""

    hold: Hold = Field(description="Nothing to set: an empty mapping {}.")


ACTIONS: Final = ("track", "regulate", "hold")


def _phase_action(value: Any) -> str | None:
    if isinstance(value, dict):
        for key in ACTIONS:
            if key in value:
                return key
        return None
    if isinstance(value, TrackPhase):
        return "track"
    if isinstance(value, RegulatePhase):
        return "regulate"
    if isinstance(value, HoldPhase):
        return "hold"
    return None


Phase = Annotated[
    Annotated[TrackPhase, Tag("track")]
    | Annotated[RegulatePhase, Tag("regulate")]
    | Annotated[HoldPhase, Tag("hold")],
    Discriminator(
        _phase_action,
        custom_error_type="phase_action",
        custom_error_message="a phase needs exactly one action: track, regulate or hold",
    ),
]


# --- repeats: a group of phases run several times ---------------------------


class Repeat(Model):
    """Phases run ``times`` times in order (patrol laps); repeats do not nest."""

    times: Annotated[int, Strict(), Field(ge=1, le=10000)] = Field(
        description="How many times the phases run, 1..10000."
    )
    phases: list[Phase] = Field(
        min_length=1, max_length=1000, description="The phases of one lap, run in order."
    )


class RepeatPhase(Model):
    """A group of phases run several times; each run is a lap (transitions.json)."""

    name: Annotated[str, Field(pattern=PHASE_NAME)] = Field(description=_PHASE_DESCRIPTION)
    repeat: Repeat = Field(description="The phases and how many times they run.")


def _step_action(value: Any) -> str | None:
    if isinstance(value, RepeatPhase) or (isinstance(value, dict) and "repeat" in value):
        return "repeat"
    return _phase_action(value)


Step = Annotated[
    Annotated[TrackPhase, Tag("track")]
    | Annotated[RegulatePhase, Tag("regulate")]
    | Annotated[HoldPhase, Tag("hold")]
    | Annotated[RepeatPhase, Tag("repeat")],
    Discriminator(
        _step_action,
        custom_error_type="phase_action",
        custom_error_message="a phase needs exactly one action: track, regulate, hold or repeat",
    ),
]


class Contingency(Model):
    """Phases a reaction runs, and what follows them."""

    phases: list[Phase] = Field(
        min_length=1, max_length=1000, description="The phases, run in order (no repeats)."
    )
    then: Then = Field(
        default="resume",
        description=(
            "Once its last phase ends: resume (rejoin the phase that called it where its path "
            "passes nearest ahead), next (the phase after that one), end (the mission ends: a "
            "success after recovery), fail, or {goto: PHASE}."
        ),
    )
    times: Annotated[int, Strict(), Field(ge=1, le=100)] = Field(
        default=1,
        description=(
            "How many times it may run in one run, 1..100; a reaction calling it once they are "
            "spent fails the mission."
        ),
    )


# The verdict a run gets unless the mission says otherwise (docs/mission-format.md,
# "Verdicts", says why each is what it is): tracking judged against the timed
# reference, zones held by the true robot, inputs judged by their quality.
DEFAULT_SETTLE_TIME: Final = 1.0


class _MissionThresholds(PhaseExpect):
    """Acceptance thresholds; `run` exits 1 when one is not met.

    The keys settle_time to estimation_rms apply to each phase (a phase's own
    `expect` overrides them); null turns one off for the whole mission; auto
    derives it from the mission's numbers. See "Verdicts" above.
    """

    settle_time: NonNegative = Field(
        default=DEFAULT_SETTLE_TIME,
        description=(
            "[s] the start of each phase that tracking_error_*, *_at_limit and estimation_rms "
            "leave out (the entry transient)."
        ),
    )
    convergence_tolerance: StateTolerance = Field(
        default_factory=lambda: StateTolerance.defaults(),
        description=(
            "|estimation error| per state below which the estimate counts as converged "
            "(estimation_convergence_time) and the floor of the overshoot metric."
        ),
    )


# The mission's `expect`: each phase's metric with its default, then the run's.
if TYPE_CHECKING:
    Expect = _MissionThresholds
else:
    Expect = _thresholds(
        "Expect",
        _MissionThresholds,
        _MissionThresholds.__doc__,
        [*catalog.phase_metrics(), *catalog.run_metrics()],
        defaults=True,
    )
catalog.built()


# --- figures ---------------------------------------------------------------


# The colour names matplotlib knows (CSS4 and its tableau and one-letter colours),
# spelt out so that `validate` never has to import matplotlib.
CSS4_COLORS: Final = frozenset(
    """aliceblue antiquewhite aqua aquamarine azure beige bisque black blanchedalmond blue
    blueviolet brown burlywood cadetblue chartreuse chocolate coral cornflowerblue cornsilk
    crimson cyan darkblue darkcyan darkgoldenrod darkgray darkgreen darkgrey darkkhaki
    darkmagenta darkolivegreen darkorange darkorchid darkred darksalmon darkseagreen
    darkslateblue darkslategray darkslategrey darkturquoise darkviolet deeppink deepskyblue
    dimgray dimgrey dodgerblue firebrick floralwhite forestgreen fuchsia gainsboro ghostwhite
    gold goldenrod gray green greenyellow grey honeydew hotpink indianred indigo ivory khaki
    lavender lavenderblush lawngreen lemonchiffon lightblue lightcoral lightcyan
    lightgoldenrodyellow lightgray lightgreen lightgrey lightpink lightsalmon lightseagreen
    lightskyblue lightslategray lightslategrey lightsteelblue lightyellow lime limegreen linen
    magenta maroon mediumaquamarine mediumblue mediumorchid mediumpurple mediumseagreen
    mediumslateblue mediumspringgreen mediumturquoise mediumvioletred midnightblue mintcream
    mistyrose moccasin navajowhite navy oldlace olive olivedrab orange orangered orchid
    palegoldenrod palegreen paleturquoise palevioletred papayawhip peachpuff peru pink plum
    powderblue purple rebeccapurple red rosybrown royalblue saddlebrown salmon sandybrown
    seagreen seashell sienna silver skyblue slateblue slategray slategrey snow springgreen
    steelblue tan teal thistle tomato turquoise violet wheat white whitesmoke yellow
    yellowgreen""".split()  # noqa: SIM905 - 148 names read better as words than as a list
)
NAMED_COLORS: Final = CSS4_COLORS | {
    *(f"tab:{n}" for n in ("blue", "orange", "green", "red", "purple", "brown", "pink")),
    *(f"tab:{n}" for n in ("gray", "olive", "cyan")),
    *(f"C{i}" for i in range(10)),
    *"bgrcmykw",
}
HEX_COLOR: Final = re.compile(r"^#(?:[0-9a-fA-F]{3,4}|[0-9a-fA-F]{6}|[0-9a-fA-F]{8})$")


def is_color(value: str) -> bool:
    """Whether matplotlib knows ``value`` as a colour (of the forms a mission may use)."""
    return value in NAMED_COLORS or value.lower() in NAMED_COLORS or bool(HEX_COLOR.match(value))


def _color(value: str) -> str:
    if not is_color(value):
        import difflib

        close = difflib.get_close_matches(value.lower(), sorted(NAMED_COLORS), n=1)
        hint = f"; did you mean '{close[0]}'?" if close else ""
        raise PydanticCustomError(
            "color",
            "'{value}' is not a colour (a name such as red or tab:green, '#rrggbb', or "
            "C0..C9){hint}",
            {"value": value[:40], "hint": hint},
        )
    return value


Color = Annotated[str, Field(max_length=64), AfterValidator(_color)]
PhaseNameKey = Annotated[str, Field(pattern=PHASE_NAME)]


class Plot(Model):
    """How the figures of a run look."""

    phase_colors: dict[PhaseNameKey, Color] = Field(
        default_factory=dict,
        max_length=10000,
        description=(
            "Colour of each named phase in the figures: a matplotlib colour (red, tab:green, "
            "'#1f77b4'); phases not listed take a palette whose colours never repeat."
        ),
        json_schema_extra={"additionalProperties": False},
    )


# --- mission ---------------------------------------------------------------


class Parameters(dict[str, float]):
    """A mission's parameters, read-only as the rest of the mission: the
    numbers written with them were computed from them when the mission was
    read, so a change made afterwards would be silently ignored."""

    def _refuse(self, *_: Any, **__: Any) -> NoReturn:
        raise TypeError(
            "a mission's parameters cannot be changed: load the mission again with "
            "them, e.g. load_mission(path, {'parameters.NAME': VALUE})"
        )

    __setitem__ = __delitem__ = __ior__ = _refuse
    clear = pop = popitem = setdefault = update = _refuse

    def __reduce__(self) -> tuple[type[Parameters], tuple[dict[str, float]]]:
        return Parameters, (dict(self),)  # pickled and copied without setting items


def _check_parameter_names(parameters: dict[str, float]) -> dict[str, float]:
    from wmr_mission.expressions import FUNCTIONS

    for name in parameters:
        if name in RESERVED_NAMES or name in FUNCTIONS:
            raise PydanticCustomError(
                "reserved_parameter",
                "parameter name '{name}' is reserved (t, pi, e and function names)",
                {"name": name},
            )
    return Parameters(parameters)


ParameterName = Annotated[str, Field(pattern=IDENTIFIER, max_length=64)]
RegionKey = Annotated[str, Field(pattern=IDENTIFIER, max_length=64)]


class Mission(Model):
    """A mission: a robot, its sensors and estimator, a controller, regions and phases."""

    model_config = ConfigDict(
        extra="forbid",
        frozen=True,
        title="wmr-mission mission",
        json_schema_extra={
            "description": (
                "A declarative mission for a wheeled non-holonomic mobile robot (format "
                "version 1). Units are SI, angles in radians."
            )
        },
    )

    version: Literal[1] = Field(description="Mission format version: 1.")
    name: Annotated[str, Field(pattern=MISSION_NAME)] = Field(
        description=(
            "Mission name: lower-case letters, digits, '-' and '_'; used in run directories."
        )
    )
    description: Annotated[str, Field(max_length=10000)] = Field(
        default="", description="Free text."
    )
    parameters: Annotated[dict[ParameterName, Number], AfterValidator(_check_parameter_names)] = (
        Field(
            default_factory=Parameters,
            max_length=1000,
            description="Named constants [any unit] usable in expressions.",
            json_schema_extra={"additionalProperties": False},
        )
    )
    robot: Robot = Field(default_factory=Robot, description="The robot.")
    sensors: Sensors = Field(default_factory=Sensors, description="Its sensors.")
    estimator: Annotated[EstimatorSettings, ESTIMATORS] = Field(
        default_factory=lambda: ConstrainedObserver(type="constrained-observer"),
        description="State estimator.",
    )
    controller: Annotated[ControllerSettings, CONTROLLERS] = Field(
        default_factory=PaperController, description="The controller."
    )
    regions: dict[RegionKey, RegionSpec] = Field(
        default_factory=dict,
        max_length=1000,
        description="Named regions.",
        json_schema_extra={"additionalProperties": False},
    )
    phases: list[Step] = Field(
        min_length=1, max_length=10000, description="Phases (and repeats of phases), run in order."
    )
    expect: Expect = Field(default_factory=Expect, description="Acceptance thresholds.")
    geofence: Geofence | None = Field(
        default=None, description="Zones watched in every phase (see Reactions)."
    )
    on_timeout: Reaction | None = Field(
        default=None, description="Every phase's on_timeout unless it sets its own."
    )
    on_breach: Reaction | None = Field(
        default=None, description="Every phase's on_breach unless it sets its own."
    )
    on_failure: Reaction | None = Field(
        default=None, description="Every phase's on_failure unless it sets its own."
    )
    contingencies: dict[PhaseNameKey, Contingency] = Field(
        default_factory=dict,
        max_length=100,
        description="Named phase lists a reaction may run (hold and return-home are built in).",
        json_schema_extra={"additionalProperties": False},
    )
    plot: Plot = Field(default_factory=Plot, description="How the figures look.")
    backend: Backend = Field(
        default_factory=lambda: Backend.defaults(),
        description="The plant: our simulator, IR-SIM or ROS 2.",
    )

    def path_context(self) -> paths.Context:
        """What the mission's paths may refer to: its regions and parameters,
        and the speed acceleration a route's stops are planned with: a share
        of the robot's (the tighter of its acceleration and v_rate), the rest
        left to the controller's corrections (docs/paper-notes.md, "A route's
        stops under acceleration limits")."""
        limits = self.robot.limits
        rates = [limits.v_rate, limits.acceleration.v if limits.acceleration else None]
        acceleration = min((float(rate) for rate in rates if rate is not None), default=math.inf)
        return paths.Context(
            regions=self.regions,
            parameters=self.parameters,
            acceleration=ROUTE_ACCELERATION_SHARE * acceleration,
        )

    def measurements(self) -> Measurements:
        """What the sensors tell the estimator: the states they measure, each
        one's noise std (0 for a state not measured), the sampling period."""
        noise = self.sensors.measured_noise()
        return Measurements(
            measurement_mask(self.sensors.measure),
            np.array([noise.get(state, 0.0) for state in STATES]),
            float(self.robot.dt),
        )

    @model_validator(mode="wrap")
    @classmethod
    def _estimator_follows_the_sensors(
        cls, data: Any, handler: ValidatorFunctionWrapHandler
    ) -> Mission:
        """Estimator settings whose defaults follow the sensors and the
        controller (its ``position_noise_budget``), completed by them
        (wmr_mission.estimators.registry.EstimatorSettings.with_sensors)."""
        mission: Mission = handler(data)
        robot = mission.robot

        # A slow estimate lags a robot the model does not hold for: under
        # disturbances the estimator keeps its own defaults (docs/paper-notes.md,
        # "Eqs. (6)-(7) under position noise"). A block of defaults (a campaign's
        # level 0) disturbs nothing, and is none.
        budget = (
            math.inf
            if robot.disturbances != Disturbances.defaults()
            else mission.controller.position_noise_budget(
                float(robot.dt), float(robot.limits.v), float(robot.limits.omega)
            )
        )
        estimator = mission.estimator.with_sensors(mission.sensors.measured_noise(), budget)
        if estimator is mission.estimator:
            return mission
        return mission.model_copy(update={"estimator": estimator})

    @model_validator(mode="after")
    def _body_kept_clear(self) -> Mission:
        """With a footprint, clearance_min is 0 unless the mission sets it: the
        body may not touch a zone (docs/mission-format.md, "Verdicts")."""
        if self.robot.footprint is None or "clearance_min" in self.expect.model_fields_set:
            return self
        expect = self.expect.model_copy(update={"clearance_min": 0.0})
        return self.model_copy(update={"expect": expect})


def _rebuild() -> None:
    """A variant registered after the models were built: rebuild those that
    embed a registry, inner ones first, so the mission accepts it."""
    for model in (Track, TrackPhase, Repeat, RepeatPhase, Contingency, Mission):
        model.model_rebuild(force=True)


for _registry in (PATHS, ESTIMATORS, CONTROLLERS):
    _registry.on_change(_rebuild)
