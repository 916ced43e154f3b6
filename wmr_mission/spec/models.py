"""Typed model of a mission file (format version 1).

Every model forbids unknown keys and is frozen. Defaults reproduce section IV
of "A New On-line Observer-Based Controller for Wheeled Non-holonomic Mobile
Robots". Units are SI, angles in radians.

A *Scalar* field accepts a number or a text holding a constant expression
(``"0.4*pi"``, ``"2*k"`` with ``k`` a declared parameter). The loader passes
the declared parameters and region names in the validation context; the
expression is evaluated once, so a loaded model holds plain floats.
"""

from __future__ import annotations

import math
import re
from typing import Annotated, Any, Final, Literal

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    Strict,
    Tag,
    ValidationInfo,
    WithJsonSchema,
    field_validator,
    model_validator,
)
from pydantic_core import PydanticCustomError

__all__ = [
    "STATES",
    "BoxRegion",
    "CirclePath",
    "CircleRegion",
    "ConstrainedObserver",
    "Constraint",
    "Controller",
    "CoveragePath",
    "Disturbances",
    "Dropout",
    "Ekf",
    "EllipsePath",
    "EllipseRegion",
    "EllipticalSpiralPath",
    "Estimator",
    "Expect",
    "ExpressionPath",
    "HalfPlaneRegion",
    "HeadingCondition",
    "Hold",
    "HoldPhase",
    "Limits",
    "LinePath",
    "Mission",
    "Near",
    "Outliers",
    "PathSpec",
    "Phase",
    "PhaseExpect",
    "Plot",
    "PolygonRegion",
    "PolylinePath",
    "Pose",
    "RegionSpec",
    "Regulate",
    "RegulatePhase",
    "Regulation",
    "Repeat",
    "RepeatPhase",
    "Robot",
    "Sensors",
    "Settled",
    "Slip",
    "SpiralPath",
    "StateName",
    "StateOffset",
    "StatePoles",
    "StateStd",
    "StateThresholds",
    "StateTolerance",
    "StayInside",
    "StayOutside",
    "Step",
    "Threshold",
    "Track",
    "TrackPhase",
    "Tracking",
    "Until",
    "WaypointsPath",
]

STATES: Final = ("x", "y", "theta")
StateName = Literal["x", "y", "theta"]

# Names an expression already gives a meaning to; a parameter may not hide them.
RESERVED_NAMES: Final = frozenset({"t", "pi", "e"})

IDENTIFIER: Final = r"^[A-Za-z_][A-Za-z0-9_]*$"
MISSION_NAME: Final = r"^[a-z0-9][a-z0-9_-]{0,63}$"
PHASE_NAME: Final = r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$"

# Larger magnitudes are typing mistakes, not missions (and would overflow the kernels).
ABSURD: Final = 1e9
# The largest seed (numpy's seeds are 32-bit): the one field whose range goes
# beyond ABSURD, so integers are read up to it and the fields bound them.
LARGEST_SEED: Final = 2**32 - 1
# Plausibility floors: a positive quantity below these is a typing mistake, and
# its square or inverse would underflow or overflow the kernels. Sizes, speeds
# and rates of regions and paths [m, m/s, 1/s]; every other positive quantity
# (limits, standard deviations, weights, tolerances).
SMALLEST_SIZE: Final = 1e-6
SMALLEST_POSITIVE: Final = 1e-9


def _at_least(floor: float) -> AfterValidator:
    def check(value: float) -> float:
        if 0 < value < floor:
            raise PydanticCustomError(
                "implausibly_small",
                "{value} is implausibly small: expected at least {floor}",
                {"value": f"{value:g}", "floor": f"{floor:g}"},
            )
        return value

    return AfterValidator(check)


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


# --- scalars ---------------------------------------------------------------

# Plain numbers: an int or a float, never a bool or a numeric-looking text.
Number = Annotated[float, Strict(), Field(allow_inf_nan=False, ge=-ABSURD, le=ABSURD)]
NonNegative = Annotated[Number, Field(ge=0)]
Positive = Annotated[Number, Field(gt=0), _at_least(SMALLEST_POSITIVE)]
Duration = Annotated[Number, Field(gt=0)]
# true or false only, never a text such as 'yes' or 'off'.
Flag = Annotated[bool, Strict()]

_SCALAR_SCHEMA: Final[dict[str, Any]] = {
    "anyOf": [
        {"type": "number"},
        {"type": "string", "description": "constant expression, e.g. '0.4*pi' or '2*k'"},
    ]
}


def _parameters(info: ValidationInfo) -> dict[str, float]:
    context = info.context
    if isinstance(context, dict):
        parameters = context.get("parameters")
        if isinstance(parameters, dict):
            return parameters
    return {}


def _evaluate_scalar(value: Any, info: ValidationInfo) -> Any:
    """Turn a constant expression into its float; numbers pass through."""
    if isinstance(value, bool):
        raise PydanticCustomError(
            "scalar_type", "expected a number or an expression, got a boolean"
        )
    if isinstance(value, int | float):
        return value
    if not isinstance(value, str):
        raise PydanticCustomError(
            "scalar_type",
            "expected a number or an expression text, got {kind}",
            {"kind": type(value).__name__},
        )
    from wmr_mission.expressions import ExpressionError, parse

    parameters = _parameters(info)
    try:
        result = parse(value, parameters, allow_t=False).constant(parameters)
    except ExpressionError as error:
        raise PydanticCustomError(
            "expression",
            "invalid expression: {message}",
            {"message": error.message, "column": error.column},
        ) from None
    if not math.isfinite(result):
        raise PydanticCustomError(
            "expression", "the expression '{text}' is not a finite number", {"text": value[:60]}
        )
    return result


def _scalar_schema(extra: dict[str, Any]) -> WithJsonSchema:
    return WithJsonSchema(
        {"anyOf": [{"type": "number", **extra}, _SCALAR_SCHEMA["anyOf"][1]]}, mode="validation"
    )


Scalar = Annotated[
    float,
    BeforeValidator(_evaluate_scalar),
    Field(allow_inf_nan=False, ge=-ABSURD, le=ABSURD),
    _scalar_schema({}),
]
PositiveScalar = Annotated[
    float,
    BeforeValidator(_evaluate_scalar),
    Field(allow_inf_nan=False, gt=0, le=ABSURD),
    _at_least(SMALLEST_SIZE),
    _scalar_schema({"exclusiveMinimum": 0}),
]


def _nonzero(value: float) -> float:
    if value == 0:
        raise PydanticCustomError("nonzero", "must not be zero")
    return value


NonzeroScalar = Annotated[Scalar, AfterValidator(_nonzero)]


# Disturbance settings accept expressions, so one parameter can scale them all.
NonNegativeScalar = Annotated[
    float,
    BeforeValidator(_evaluate_scalar),
    Field(allow_inf_nan=False, ge=0, le=ABSURD),
    _scalar_schema({"minimum": 0}),
]
ProbabilityScalar = Annotated[
    float,
    BeforeValidator(_evaluate_scalar),
    Field(allow_inf_nan=False, ge=0, le=1),
    _scalar_schema({"minimum": 0, "maximum": 1}),
]
SlipFraction = Annotated[
    float,
    BeforeValidator(_evaluate_scalar),
    Field(allow_inf_nan=False, ge=0, lt=1),
    _scalar_schema({"minimum": 0, "exclusiveMaximum": 1}),
]
BurstLength = Annotated[
    float,
    BeforeValidator(_evaluate_scalar),
    Field(allow_inf_nan=False, ge=1, le=ABSURD),
    _scalar_schema({"minimum": 1}),
]


def _start_angle(value: Any, info: ValidationInfo) -> Any:
    return value if value == "current" else _evaluate_scalar(value, info)


# `current` or a starting angle [rad] on the curve.
StartAngle = Annotated[
    Literal["current"] | float,
    BeforeValidator(_start_angle),
    WithJsonSchema(
        {
            "anyOf": [
                {"type": "number"},
                {"type": "string", "description": "'current' or a constant expression"},
            ]
        },
        mode="validation",
    ),
]

Point = tuple[Scalar, Scalar]


def _known_region(name: str, info: ValidationInfo) -> str:
    """With a loader context, a region reference must name a declared region."""
    context = info.context
    if isinstance(context, dict) and isinstance(context.get("regions"), list | tuple):
        declared: list[str] = list(context["regions"])
        if name not in declared:
            import difflib

            close = difflib.get_close_matches(name, declared, n=1)
            hint = f"; did you mean {close[0]!r}?" if close else ""
            known = ", ".join(repr(n) for n in declared) or "none"
            raise PydanticCustomError(
                "undefined_region",
                "undefined region '{name}'{hint} (declared regions: {known})",
                {"name": name, "hint": hint, "known": known},
            )
    return name


RegionName = Annotated[str, Field(pattern=IDENTIFIER, max_length=64), AfterValidator(_known_region)]


# --- robot -----------------------------------------------------------------


class Pose(_Model):
    """A pose in the world frame."""

    x: Scalar = Field(default=0.0, description="Position x [m].")
    y: Scalar = Field(default=0.0, description="Position y [m].")
    theta: Scalar = Field(default=0.0, description="Heading [rad], counter-clockwise from +x.")


class Limits(_Model):
    """Actuator limits; inputs are saturated to them."""

    v: Positive = Field(default=10.0, description="Largest |v|, linear speed [m/s].")
    omega: Positive = Field(default=20.0, description="Largest |omega|, turn rate [rad/s].")
    v_rate: Positive | None = Field(
        default=None, description="Largest |dv/dt| [m/s^2]; null = unlimited."
    )
    omega_rate: Positive | None = Field(
        default=None, description="Largest |domega/dt| [rad/s^2]; null = unlimited."
    )


class StateStd(_Model):
    """A standard deviation per state."""

    x: NonNegativeScalar = Field(default=0.0, description="Standard deviation of x [m].")
    y: NonNegativeScalar = Field(default=0.0, description="Standard deviation of y [m].")
    theta: NonNegativeScalar = Field(default=0.0, description="Standard deviation of theta [rad].")


class Slip(_Model):
    """Wheel slip of the true plant."""

    longitudinal: SlipFraction = Field(
        default=0.0, description="Fraction of v lost to slip, in [0, 1)."
    )
    lateral_std: NonNegativeScalar = Field(
        default=0.0,
        description="Standard deviation of a sideways skid speed, drawn every sample [m/s].",
    )


class Disturbances(_Model):
    """The true plant departs from eq. (1): noise, delay, lag and slip."""

    process_noise_std: StateStd = Field(
        default_factory=lambda: StateStd(),
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
    slip: Slip = Field(default_factory=lambda: Slip(), description="Wheel slip.")


class Robot(_Model):
    """The plant of eq. (1), sampled."""

    dt: Annotated[Number, Field(gt=0, le=1), _at_least(SMALLEST_POSITIVE)] = Field(
        default=0.01, description="Sampling period [s], in (0, 1]."
    )
    initial_state: Pose = Field(
        default_factory=Pose, description="True pose at mission start [m, m, rad]."
    )
    limits: Limits = Field(default_factory=Limits, description="Input limits.")
    disturbances: Disturbances = Field(
        default_factory=lambda: Disturbances(),
        description=(
            "How the true plant departs from eq. (1); the estimator and controller never see "
            "these settings (docs/disturbances.md). Default: none."
        ),
    )


# --- sensors ---------------------------------------------------------------


class StateOffset(_Model):
    """An offset per state."""

    x: Scalar = Field(default=0.0, description="Offset of x [m].")
    y: Scalar = Field(default=0.0, description="Offset of y [m].")
    theta: Scalar = Field(default=0.0, description="Offset of theta [rad].")


class Dropout(_Model):
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


class Outliers(_Model):
    """Wild measurements: a large Gaussian error added now and then."""

    probability: ProbabilityScalar = Field(
        description="Probability that a measurement is an outlier."
    )
    std: StateStd = Field(description="Standard deviation of the outlier's error [m, m, rad].")


class Sensors(_Model):
    """Which states are measured, how often, and how they err."""

    measure: tuple[StateName, ...] = Field(
        default=STATES,
        min_length=1,
        description="Measured states: a non-empty subset of x, y, theta without repeats.",
        json_schema_extra={"uniqueItems": True},
    )
    noise_std: StateStd = Field(
        default_factory=StateStd,
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
        default_factory=lambda: StateOffset(),
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


# --- estimator -------------------------------------------------------------


def _check_bound(bound: tuple[float, float]) -> tuple[float, float]:
    lower, upper = bound
    if not lower < 0 < upper:
        raise PydanticCustomError(
            "output_error_bound",
            "an output-error bound is [lower, upper] with lower < 0 < upper, "
            "got [{lower}, {upper}]",
            {"lower": lower, "upper": upper},
        )
    return bound


OutputErrorBound = Annotated[tuple[Number, Number], AfterValidator(_check_bound)]
Pole = Annotated[Number, Field(ge=0, lt=1)]


# Default output-error bound of eq. (4) [m or rad]: the larger of this and
# BOUND_NOISE_RATIO times the state's noise std, so that phase II acts on
# estimation errors, not on the noise (docs/paper-notes.md, eq. (4)).
DEFAULT_BOUND = 0.05
BOUND_NOISE_RATIO = 5.0


def _default_bounds() -> dict[StateName, tuple[float, float]]:
    return dict.fromkeys(STATES, (-DEFAULT_BOUND, DEFAULT_BOUND))


def default_bound(noise_std: float) -> float:
    """Half-width of the default output-error bound for a state with this noise."""
    return max(DEFAULT_BOUND, BOUND_NOISE_RATIO * noise_std)


_INITIAL_ESTIMATE = "Estimate at mission start [m, m, rad]; null = robot.initial_state."


class StatePoles(_Model):
    """Eigenvalues of the observer error dynamics (I - L C) A, per state."""

    x: Pole = Field(default=0.9, description="Pole for x, in [0, 1).")
    y: Pole = Field(default=0.9, description="Pole for y, in [0, 1).")
    theta: Pole = Field(default=0.9, description="Pole for theta, in [0, 1).")


class StatePositiveStd(_Model):
    """A strictly positive standard deviation per state."""

    x: Positive = Field(default=1.0, description="Standard deviation of x [m].")
    y: Positive = Field(default=1.0, description="Standard deviation of y [m].")
    theta: Positive = Field(default=0.5, description="Standard deviation of theta [rad].")


class ConstrainedObserver(_Model):
    """The paper's two-phase constrained estimator, eqs. (4)-(12)."""

    type: Literal["constrained-observer"] = Field(
        default="constrained-observer", description="Estimator kind (the default)."
    )
    initial_estimate: Pose | None = Field(default=None, description=_INITIAL_ESTIMATE)
    poles: StatePoles = Field(
        default_factory=StatePoles,
        description=(
            "Observer poles, phase I (eq. 7). With the heading unmeasured, its pole relaxes "
            "towards 1 while the robot moves less per sample than sensors.noise_std of the "
            "measured positions (docs/paper-notes.md, eq. 6-7)."
        ),
    )
    output_error_bounds: dict[StateName, OutputErrorBound] | None = Field(
        default_factory=_default_bounds,
        description=(
            "Eq. (4): [lower, upper] bounds on each measured state's output error "
            "[m or rad], lower < 0 < upper; keys must be measured states; null = no phase II. "
            "Default on every measured state: +-max(0.05, 5 sensors.noise_std)."
        ),
    )
    max_iterations: Annotated[int, Strict(), Field(ge=1, le=1000)] = Field(
        default=10, description="Phase II iterations per sample, 1..1000."
    )


class Ekf(_Model):
    """Baseline extended Kalman filter."""

    type: Literal["ekf"] = Field(description="Estimator kind.")
    initial_estimate: Pose | None = Field(default=None, description=_INITIAL_ESTIMATE)
    initial_std: StatePositiveStd = Field(
        default_factory=lambda: StatePositiveStd(x=1.0, y=1.0, theta=0.5),
        description="Square root of the diagonal of P0 [m, m, rad], > 0.",
    )
    process_std: StateStd = Field(
        default_factory=lambda: StateStd(x=0.001, y=0.001, theta=0.001),
        description="Process noise per sample [m, m, rad], >= 0.",
    )
    measurement_std: dict[StateName, Positive] | None = Field(
        default=None,
        description=(
            "Measurement noise per measured state [m or rad], > 0; "
            "null = sensors.noise_std floored at 0.001."
        ),
    )
    innovation_gate: Positive | None = Field(
        default=None,
        description=(
            "Reject a measurement whose squared Mahalanobis distance r^T S^-1 r exceeds this "
            "(chi-square with as many degrees of freedom as measured states: 16.27 is its "
            "0.999 quantile for 3); a rejected measurement is a prediction-only step. "
            "null = no gating."
        ),
    )


def _estimator_type(value: Any) -> str | None:
    """The estimator's `type`; without one, the paper's estimator."""
    if isinstance(value, dict):
        kind = value.get("type", "constrained-observer")
        return kind if isinstance(kind, str) else None
    return getattr(value, "type", None)


Estimator = Annotated[
    Annotated[ConstrainedObserver, Tag("constrained-observer")] | Annotated[Ekf, Tag("ekf")],
    Discriminator(_estimator_type),
]


# --- controller ------------------------------------------------------------


class Tracking(_Model):
    """Case 2 law: which point of the robot follows the path."""

    output: Literal["look-ahead", "axle"] = Field(
        default="look-ahead",
        description="look-ahead: a point ahead of the axle; axle: the literal eq. (27).",
    )
    look_ahead: Positive | None = Field(
        default=None,
        description=(
            "Distance of the look-ahead point ahead of the axle [m]; "
            "null = max(0.05, robot.limits.v * robot.dt), where the law is well conditioned "
            "at every speed the limits allow."
        ),
    )
    time_constant: NonNegative = Field(
        default=0.1,
        description=(
            "Time constant of the tracking error [s]: each sample leaves exp(-dt / "
            "time_constant) of the output's error, the path's own motion fed forward; "
            "0 = close the whole error in one sample (the literal eq. 27; always so for "
            "output: axle)."
        ),
    )


class Regulation(_Model):
    """Case 1 law: how a target pose is approached."""

    form: Literal["bearing", "deviation", "increment"] = Field(
        default="bearing",
        description=(
            "bearing: drive to the point then turn (parks); deviation: LQR on the pose "
            "error; increment: the literal eq. (19)."
        ),
    )
    align_radius: Positive = Field(
        default=0.01, description="Within this distance the bearing form turns to the target [m]."
    )
    reverse: Flag = Field(default=True, description="The bearing form may drive backwards.")


class Controller(_Model):
    """The two-component controller: gain-scheduled LQR and corrective control."""

    Q: tuple[NonNegative, NonNegative, NonNegative] = Field(
        default=(1.0, 1.0, 1.0), description="Eq. (17) state weights (diagonal), >= 0."
    )
    R: tuple[Positive, Positive] = Field(
        default=(1.0, 1.0), description="Eq. (17) input weights (diagonal), > 0."
    )
    W: tuple[Positive, Positive, Positive] = Field(
        default=(100.0, 100.0, 100.0), description="Eq. (22) constraint weights (diagonal), > 0."
    )
    M: tuple[Positive, Positive] = Field(
        default=(100.0, 100.0), description="Eq. (22) input weights (diagonal), > 0."
    )
    tracking: Tracking = Field(default_factory=Tracking, description="Path tracking output.")
    regulation: Regulation = Field(default_factory=Regulation, description="Regulation form.")


# --- regions ---------------------------------------------------------------


class EllipseRegion(_Model):
    """Inside: ((u/a)^2 + (w/b)^2 <= 1), [u, w] = Rot(-rotation)(p - center); eq. (33)."""

    type: Literal["ellipse"] = Field(description="Region kind.")
    center: Point = Field(default=(0.0, 0.0), description="Centre [x, y] [m].")
    semi_axes: tuple[PositiveScalar, PositiveScalar] = Field(
        description="Semi-axes [a, b] along the rotated x and y axes [m], > 0."
    )
    rotation: Scalar = Field(default=0.0, description="Rotation of the a axis from +x [rad].")


class CircleRegion(_Model):
    """Inside: |p - center| <= radius."""

    type: Literal["circle"] = Field(description="Region kind.")
    center: Point = Field(default=(0.0, 0.0), description="Centre [x, y] [m].")
    radius: PositiveScalar = Field(description="Radius [m], > 0.")


class BoxRegion(_Model):
    """Axis-aligned box: min <= p <= max componentwise."""

    type: Literal["box"] = Field(description="Region kind.")
    min: Point = Field(description="Lower-left corner [x, y] [m].")
    max: Point = Field(description="Upper-right corner [x, y] [m], greater than min.")

    @model_validator(mode="after")
    def _ordered(self) -> BoxRegion:
        if not (self.min[0] < self.max[0] and self.min[1] < self.max[1]):
            raise PydanticCustomError(
                "box_order", "a box needs min < max in both x and y (min is the lower-left corner)"
            )
        return self


class PolygonRegion(_Model):
    """Convex polygon; inside is the interior."""

    type: Literal["polygon"] = Field(description="Region kind.")
    vertices: list[Point] = Field(
        min_length=3,
        max_length=1000,
        description="At least 3 vertices [[x, y], ...] [m], convex, either orientation.",
    )

    @field_validator("vertices")
    @classmethod
    def _distinct(cls, vertices: list[tuple[float, float]]) -> list[tuple[float, float]]:
        if len(set(vertices)) != len(vertices):
            raise PydanticCustomError("repeated_vertex", "a polygon vertex is repeated")
        return vertices


class HalfPlaneRegion(_Model):
    """Inside: normal . p <= offset."""

    type: Literal["half-plane"] = Field(description="Region kind.")
    normal: Point = Field(description="Outward normal [nx, ny], not zero.")
    offset: Scalar = Field(description="Offset c of nx*x + ny*y <= c [m times |normal|].")

    @field_validator("normal")
    @classmethod
    def _nonzero_normal(cls, normal: tuple[float, float]) -> tuple[float, float]:
        if normal == (0.0, 0.0):
            raise PydanticCustomError("zero_normal", "a half-plane normal must not be [0, 0]")
        length = math.hypot(*normal)
        if length < SMALLEST_POSITIVE:  # its square, which scales the offset, would underflow
            raise PydanticCustomError(
                "implausibly_small",
                "a half-plane normal of length {length} is implausibly short: "
                "expected at least {floor}",
                {"length": f"{length:g}", "floor": f"{SMALLEST_POSITIVE:g}"},
            )
        return normal


RegionSpec = Annotated[
    EllipseRegion | CircleRegion | BoxRegion | PolygonRegion | HalfPlaneRegion,
    Field(discriminator="type"),
]


# --- paths -----------------------------------------------------------------


class LinePath(_Model):
    """p(t) = p0 + speed*t*(cos h, sin h)."""

    type: Literal["line"] = Field(description="Path kind.")
    start: Literal["current"] | Point = Field(
        default="current", description="'current' (the robot's position) or [x, y] [m]."
    )
    heading: Scalar | None = Field(
        default=None, description="Direction h [rad]; give heading or towards."
    )
    towards: Point | None = Field(
        default=None, description="A point [x, y] [m] the line heads to; give heading or towards."
    )
    speed: PositiveScalar = Field(description="Speed along the line [m/s], > 0.")

    @model_validator(mode="after")
    def _one_direction(self) -> LinePath:
        if (self.heading is None) == (self.towards is None):
            raise PydanticCustomError(
                "line_direction", "a line path needs exactly one of 'heading' or 'towards'"
            )
        return self


class CirclePath(_Model):
    """p = c + r(cos(wt + phi0), sin(wt + phi0))."""

    type: Literal["circle"] = Field(description="Path kind.")
    center: Point = Field(description="Centre [x, y] [m].")
    radius: PositiveScalar = Field(description="Radius [m], > 0.")
    angular_rate: NonzeroScalar = Field(description="w [rad/s], not zero; > 0 counter-clockwise.")
    start: StartAngle = Field(
        default="current",
        description="'current' (phi0 = polar angle of the robot about the centre) or phi0 [rad].",
    )


class _EllipseGeometry(_Model):
    region: RegionName | None = Field(
        default=None, description="Name of an ellipse or circle region giving the geometry."
    )
    center: Point | None = Field(default=None, description="Centre [x, y] [m], without region.")
    semi_axes: tuple[PositiveScalar, PositiveScalar] | None = Field(
        default=None, description="Semi-axes [a, b] [m], without region."
    )
    rotation: Scalar | None = Field(
        default=None, description="Rotation [rad] (default 0), without region."
    )

    @model_validator(mode="after")
    def _one_geometry(self) -> _EllipseGeometry:
        explicit = self.center is not None or self.semi_axes is not None
        if self.region is not None and (explicit or self.rotation is not None):
            raise PydanticCustomError(
                "ellipse_geometry",
                "give either 'region' or 'center' + 'semi_axes' (+ 'rotation'), not both",
            )
        if self.region is None and (self.center is None or self.semi_axes is None):
            raise PydanticCustomError(
                "ellipse_geometry", "give either 'region' or both 'center' and 'semi_axes'"
            )
        return self


class EllipsePath(_EllipseGeometry):
    """Eq. (31): p = c + Rot(rotation)(a cos(wt + phi0), b sin(wt + phi0))."""

    type: Literal["ellipse"] = Field(description="Path kind.")
    angular_rate: NonzeroScalar = Field(description="w [rad/s], not zero.")
    start: StartAngle = Field(
        default="current",
        description=(
            "'current' (phi0 = atan2(w/b, u/a) of the robot in the ellipse frame) or phi0 [rad]."
        ),
    )


class SpiralPath(_Model):
    """Eq. (30): r = r0 exp(growth_rate t), angle w t + phi0."""

    type: Literal["spiral"] = Field(description="Path kind.")
    center: Point = Field(default=(0.0, 0.0), description="Centre [x, y] [m].")
    initial_radius: PositiveScalar = Field(description="r0 [m], > 0.")
    growth_rate: Scalar = Field(description="Radial growth rate [1/s]; < 0 spirals in.")
    angular_rate: NonzeroScalar = Field(description="w [rad/s], not zero.")
    start: StartAngle = Field(default=0.0, description="'current' or phi0 [rad].")


class EllipticalSpiralPath(_EllipseGeometry):
    """Eq. (32): the ellipse of eq. (31) scaled by exp(-decay_rate t)."""

    type: Literal["elliptical-spiral"] = Field(description="Path kind.")
    decay_rate: PositiveScalar = Field(description="Decay rate [1/s], > 0.")
    angular_rate: NonzeroScalar = Field(description="w [rad/s], not zero.")
    start: StartAngle = Field(
        default="current",
        description=(
            "'current' (phi0 = atan2(w/b, u/a) of the robot in the ellipse frame) or phi0 [rad]."
        ),
    )


class WaypointsPath(_Model):
    """A smooth (C1) curve through the points at constant speed, kept close to their
    convex hull."""

    type: Literal["waypoints"] = Field(description="Path kind.")
    points: list[Point] = Field(
        min_length=2, max_length=10000, description="At least 2 points [[x, y], ...] [m]."
    )
    speed: PositiveScalar = Field(description="Speed along the curve [m/s], > 0.")
    start: Literal["current", "first"] = Field(
        default="current",
        description=(
            "current: an open curve starts at the robot's position, a closed one where it "
            "passes nearest the robot; first: at the first point."
        ),
    )
    closed: Flag = Field(default=False, description="Return to the first point and loop.")


# --- routes drawn through points: polyline and coverage ---------------------


class PolylinePath(_Model):
    """Straight legs through the points at constant speed, corners rounded by arcs
    (or turned in place); never leaves the points' convex hull."""

    type: Literal["polyline"] = Field(description="Path kind.")
    points: list[Point] = Field(
        min_length=1,
        max_length=10000,
        description="At least 1 point [[x, y], ...] [m] (with start: current, the robot's "
        "position comes first).",
    )
    speed: PositiveScalar = Field(description="Speed along legs and arcs [m/s], > 0.")
    corner_radius: NonNegativeScalar = Field(
        default=0.0,
        description=(
            "Radius of the arc joining two legs [m], >= 0, shrunk where it does not fit in "
            "half of either leg; 0 = stop and turn in place."
        ),
    )
    turn_rate: PositiveScalar = Field(
        default=1.0, description="Turn rate of a turn in place [rad/s], > 0."
    )
    start: Literal["current", "first"] = Field(
        default="current",
        description=(
            "current: an open route starts at the robot's position, a closed one where it "
            "passes nearest the robot; first: at the first point."
        ),
    )
    closed: bool = Field(default=False, description="Return to the first point and loop.")


class CoveragePath(_Model):
    """A boustrophedon (lawnmower) over a box or convex polygon region: parallel
    lanes, run alternately back and forth, joined by arcs of the turn radius."""

    type: Literal["coverage"] = Field(description="Path kind.")
    region: RegionName = Field(description="Name of the box or polygon region to cover.")
    spacing: PositiveScalar = Field(
        description=(
            "Largest distance between neighbouring lanes [m], > 0; lanes are spread evenly, "
            "the outer ones half a spacing inside the field."
        )
    )
    direction: Scalar = Field(default=0.0, description="Direction of the lanes [rad] from +x.")
    turn_radius: NonNegativeScalar | None = Field(
        default=None,
        description=(
            "Radius of the turns at the lane ends [m], >= 0; default half the spacing "
            "(a semicircle); 0 = turn in place."
        ),
    )
    turn_rate: PositiveScalar = Field(
        default=1.0, description="Turn rate of a turn in place [rad/s], > 0."
    )
    speed: PositiveScalar = Field(description="Speed along lanes and turns [m/s], > 0.")
    start: Literal["current", "first"] = Field(
        default="current",
        description="current: drive from the robot's position to the first lane; first: start "
        "on the first lane.",
    )


def _number_as_text(value: Any) -> Any:
    """`y: 0` is a constant expression too."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return repr(value)
    return value


ExpressionText = Annotated[
    str,
    BeforeValidator(_number_as_text),
    WithJsonSchema({"type": ["number", "string"]}, mode="validation"),
]


class ExpressionPath(_Model):
    """x(t), y(t) as restricted expressions of phase-local time t [s]."""

    type: Literal["expression"] = Field(description="Path kind.")
    x: ExpressionText = Field(description="x(t) [m], e.g. '2*exp(0.5*t)*cos(0.4*pi*t)'.")
    y: ExpressionText = Field(description="y(t) [m].")
    start: Literal["as-written", "current"] = Field(
        default="as-written",
        description="as-written: as the text says; current: translated so p(0) is the robot.",
    )

    @field_validator("x", "y")
    @classmethod
    def _parses(cls, text: str, info: ValidationInfo) -> str:
        from wmr_mission.expressions import ExpressionError, parse

        try:
            parse(text, _parameters(info), allow_t=True)
        except ExpressionError as error:
            raise PydanticCustomError(
                "expression",
                "invalid expression: {message}",
                {"message": error.message, "column": error.column},
            ) from None
        return text


PathSpec = Annotated[
    LinePath
    | CirclePath
    | EllipsePath
    | SpiralPath
    | EllipticalSpiralPath
    | WaypointsPath
    | ExpressionPath
    | PolylinePath
    | CoveragePath,
    Field(discriminator="type"),
]


# --- expectations ----------------------------------------------------------


class Threshold(_Model):
    """An upper bound on a run metric."""

    max: NonNegative = Field(description="Largest accepted value, in the metric's unit.")


class StateThresholds(_Model):
    """An upper bound per state, in the state's unit; a state left out is not checked."""

    x: NonNegative | None = Field(default=None, description="[m] bound for x.")
    y: NonNegative | None = Field(default=None, description="[m] bound for y.")
    theta: NonNegative | None = Field(default=None, description="[rad] bound for theta.")


# The paper's "short transient" acceptance, in metres and radians alike.
DEFAULT_CONVERGENCE_TOLERANCE: Final = 0.05


class StateTolerance(_Model):
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


class PhaseExpect(_Model):
    """Thresholds on one phase's metrics; a key left out (or null) takes the mission's value."""

    settle_time: NonNegative | None = Field(
        default=None,
        description=(
            "[s] the start of the phase that the tracking, input and estimation-RMS metrics "
            "leave out (the entry transient)."
        ),
    )
    tracking_error_rms: Threshold | None = Field(
        default=None,
        description="[m] RMS distance of the true position from the path after settle_time.",
    )
    tracking_error_max: Threshold | None = Field(
        default=None,
        description="[m] largest distance of the true position from the path after settle_time.",
    )
    speed_at_limit: Threshold | None = Field(
        default=None,
        description="Fraction of the samples after settle_time with |v| at limits.v.",
    )
    turn_rate_at_limit: Threshold | None = Field(
        default=None,
        description="Fraction of the samples after settle_time with |omega| at limits.omega.",
    )
    turn_rate_jitter: Threshold | None = Field(
        default=None,
        description=(
            "[rad/s] RMS of omega about its 25-sample centred moving mean, after settle_time."
        ),
    )
    turn_rate_reversals: Threshold | None = Field(
        default=None, description="Sign changes of omega after settle_time (a count)."
    )
    estimation_rms: StateThresholds | None = Field(
        default=None,
        description="RMS estimation error (true - estimate) per state after settle_time.",
    )


# --- phases ----------------------------------------------------------------


class Near(_Model):
    """The estimated position is within tolerance of a point."""

    point: Point = Field(description="Point [x, y] [m].")
    tolerance: Positive = Field(description="Distance [m], > 0.")


class Settled(_Model):
    """The estimated pose is at the target and the robot has stopped (regulate/hold only)."""

    position: Positive = Field(description="Position tolerance [m], > 0.")
    heading: Positive = Field(description="Heading tolerance [rad], > 0.")
    speed: Positive = Field(default=0.01, description="Largest |v| [m/s], > 0.")


class HeadingCondition(_Model):
    """The estimated heading is within tolerance of a target (wrapped)."""

    target: Scalar = Field(description="Target heading [rad].")
    tolerance: Positive = Field(description="Tolerance [rad], > 0.")


class Until(_Model):
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


class StayInside(_Model):
    """Keep the robot inside a region (the corrective control of eqs. (22)-(28))."""

    stay_inside: RegionName = Field(description="Region name.")


class StayOutside(_Model):
    """Keep the robot outside a region (ellipse, circle or half-plane)."""

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


class Track(_Model):
    """Follow a path (the Case 2 law)."""

    path: PathSpec = Field(description="The path, instantiated at phase entry.")


class Regulate(_Model):
    """Drive to a target pose (the Case 1 law)."""

    target: Pose = Field(description="Target pose [m, m, rad].")


class Hold(_Model):
    """Regulate to the pose estimated at phase entry."""


_PHASE_DESCRIPTION: Final = "Unique phase name: letters, digits, '-' and '_', at most 64."


class _PhaseCommon(_Model):
    name: Annotated[str, Field(pattern=PHASE_NAME)] = Field(description=_PHASE_DESCRIPTION)
    until: Until = Field(default_factory=Until, description="Exit conditions (any of).")
    timeout: Duration | None = Field(
        default=None,
        description="Phase time limit [s], > 0; needed unless until has elapsed or mission_time.",
    )
    on_timeout: Literal["fail", "next"] = Field(
        default="fail", description="At timeout: fail the mission, or go on to the next phase."
    )
    constraints: tuple[Constraint, ...] = Field(
        default=(),
        max_length=64,
        description=(
            "Keep-in and keep-out zones (eq. (28)); on a track phase they win over the path."
        ),
    )
    expect: PhaseExpect = Field(
        default_factory=PhaseExpect,
        description="Thresholds on this phase's metrics, overriding the mission's expect.",
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


class Repeat(_Model):
    """Phases run ``times`` times in order (patrol laps); repeats do not nest."""

    times: Annotated[int, Strict(), Field(ge=1, le=10000)] = Field(
        description="How many times the phases run, 1..10000."
    )
    phases: list[Phase] = Field(
        min_length=1, max_length=1000, description="The phases of one lap, run in order."
    )


class RepeatPhase(_Model):
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


# The verdict a run gets unless the mission says otherwise: its inputs do not sit
# at a limit (the rule of thumb: 1 % of a phase after its first second) and it
# stays near its path. A mission relaxes them by setting its own values.
DEFAULT_SETTLE_TIME: Final = 1.0
DEFAULT_AT_LIMIT: Final = 0.01
DEFAULT_TRACKING_ERROR_MAX: Final = 0.1


class Expect(PhaseExpect):
    """Acceptance thresholds; `run` exits 1 when one is not met.

    The keys settle_time to estimation_rms apply to each phase (a phase's own
    `expect` overrides them); null turns one off for the whole mission. See
    "Verdicts" above.
    """

    settle_time: NonNegative = Field(
        default=DEFAULT_SETTLE_TIME,
        description=(
            "[s] the start of each phase that the tracking, input and estimation-RMS metrics "
            "leave out (the entry transient)."
        ),
    )
    tracking_error_max: Threshold | None = Field(
        default=Threshold(max=DEFAULT_TRACKING_ERROR_MAX),
        description=(
            "[m] largest distance of the true position from the path after settle_time; "
            "{max: 0.1} unless set."
        ),
    )
    speed_at_limit: Threshold | None = Field(
        default=Threshold(max=DEFAULT_AT_LIMIT),
        description=(
            "Fraction of the samples after settle_time with |v| at limits.v; "
            "{max: 0.01} unless set."
        ),
    )
    turn_rate_at_limit: Threshold | None = Field(
        default=Threshold(max=DEFAULT_AT_LIMIT),
        description=(
            "Fraction of the samples after settle_time with |omega| at limits.omega; "
            "{max: 0.01} unless set."
        ),
    )
    convergence_tolerance: StateTolerance = Field(
        default_factory=StateTolerance,
        description=(
            "|estimation error| per state below which the estimate counts as converged "
            "(estimation_convergence_time) and the floor of the overshoot metric."
        ),
    )

    final_position_error: Threshold | None = Field(
        default=None,
        description=(
            "[m] distance of the final true position from the target of the last regulate "
            "phase run, or from the last reference point if a track phase came after it "
            "(hold phases keep their entry pose and are skipped)."
        ),
    )
    final_heading_error: Threshold | None = Field(
        default=None,
        description="[rad] wrapped final heading error to that regulate target.",
    )
    max_constraint_violation: Threshold | None = Field(
        default=None, description="Largest constraint-row value over the run (> 0 = violated)."
    )
    estimation_convergence_time: Threshold | None = Field(
        default=None,
        description=(
            "[s] first time after which every state's |estimation error| stays below its "
            "convergence_tolerance."
        ),
    )
    duration: Threshold | None = Field(default=None, description="[s] mission time.")


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


class Plot(_Model):
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


def _check_parameter_names(parameters: dict[str, float]) -> dict[str, float]:
    from wmr_mission.expressions import FUNCTIONS

    for name in parameters:
        if name in RESERVED_NAMES or name in FUNCTIONS:
            raise PydanticCustomError(
                "reserved_parameter",
                "parameter name '{name}' is reserved (t, pi, e and function names)",
                {"name": name},
            )
    return parameters


ParameterName = Annotated[str, Field(pattern=IDENTIFIER, max_length=64)]
RegionKey = Annotated[str, Field(pattern=IDENTIFIER, max_length=64)]


class Mission(_Model):
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
            default_factory=dict,
            max_length=1000,
            description="Named constants [any unit] usable in expressions.",
            json_schema_extra={"additionalProperties": False},
        )
    )
    robot: Robot = Field(default_factory=Robot, description="The robot.")
    sensors: Sensors = Field(default_factory=Sensors, description="Its sensors.")
    estimator: Estimator = Field(
        default_factory=lambda: ConstrainedObserver(type="constrained-observer"),
        description="State estimator.",
    )
    controller: Controller = Field(default_factory=Controller, description="The controller.")
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
    plot: Plot = Field(default_factory=Plot, description="How the figures look.")

    @model_validator(mode="before")
    @classmethod
    def _default_bounds_on_measured_states(cls, data: Any) -> Any:
        """Default output-error bounds cover the measured states only, each
        wide enough that the state's noise alone rarely leaves it."""
        if not isinstance(data, dict):
            return data
        estimator = data.get("estimator", {"type": "constrained-observer"})
        sensors = data.get("sensors", {})
        if not (isinstance(estimator, dict) and isinstance(sensors, dict)):
            return data
        kind = estimator.get("type", "constrained-observer")
        if kind != "constrained-observer" or "output_error_bounds" in estimator:
            return data
        measure = sensors.get("measure", STATES)
        if not isinstance(measure, list | tuple) or not all(s in STATES for s in measure):
            return data
        noise = sensors.get("noise_std", {})
        bounds = {}
        for state in measure:
            std = noise.get(state, 0.0) if isinstance(noise, dict) else 0.0
            if isinstance(std, bool) or not isinstance(std, int | float) or not std >= 0:
                std = 0.0  # the field's own check reports it
            half_width = default_bound(float(std))
            bounds[state] = (-half_width, half_width)
        return {**data, "estimator": {**estimator, "output_error_bounds": bounds}}
