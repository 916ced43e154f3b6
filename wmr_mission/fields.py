"""The building blocks of a mission's models, and the registry of a section's variants.

Every model forbids unknown keys and is frozen (:class:`Model`). Units are SI,
angles in radians.

A *Scalar* field accepts a number or a text holding a constant expression
(``"0.4*pi"``, ``"2*k"`` with ``k`` a declared parameter). The loader passes
the declared parameters and region names in the validation context; the
expression is evaluated once, so a loaded model holds plain floats.

A section a mission writes in several variants (a path, an estimator, a
controller) is a :class:`Registry`: each variant's settings are a model with
``type: Literal[NAME]``, and registering a variant adds it to the
discriminated union the mission validates against (wmr_mission.spec.models
rebuilds itself when a registry changes).
"""

from __future__ import annotations

import math
import typing
from collections.abc import Callable, Iterable, Iterator
from typing import Annotated, Any, Final, Generic, Literal, Protocol, TypeVar

from pydantic import (
    AfterValidator,
    BaseModel,
    BeforeValidator,
    ConfigDict,
    Discriminator,
    Field,
    GetCoreSchemaHandler,
    Strict,
    Tag,
    ValidationInfo,
    WithJsonSchema,
)
from pydantic_core import CoreSchema, PydanticCustomError

IDENTIFIER: Final = r"^[A-Za-z_][A-Za-z0-9_]*$"

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
# The longest temporal `expect` formula, in characters (wmr_mission.spec.temporal).
MAX_FORMULA_LENGTH: Final = 1000


def at_least(floor: float) -> AfterValidator:
    def check(value: float) -> float:
        if 0 < value < floor:
            raise PydanticCustomError(
                "implausibly_small",
                "{value} is implausibly small: expected at least {floor}",
                {"value": f"{value:g}", "floor": f"{floor:g}"},
            )
        return value

    return AfterValidator(check)


_M = TypeVar("_M", bound="Model")


class Model(BaseModel):
    """A part of a mission file: unknown keys refused, frozen once read."""

    # Validators built at first use, not each of the ~70 models' at import:
    # checking a mission builds the mission's (docs/performance.md, Start-up).
    model_config = ConfigDict(extra="forbid", frozen=True, defer_build=True)

    @classmethod
    def defaults(cls: type[_M]) -> _M:
        """The model with every field at its default, as ``cls()`` gives it,
        without building its validator for that (about 1 ms a model): the
        default of a section a mission leaves out. For models with no
        validator of their own, or one that their defaults pass (Backend's)."""
        return typing.cast(_M, cls.model_construct())  # pydantic types it as Model


# --- scalars ---------------------------------------------------------------

# Plain numbers: an int or a float, never a bool or a numeric-looking text.
Number = Annotated[float, Strict(), Field(allow_inf_nan=False, ge=-ABSURD, le=ABSURD)]
NonNegative = Annotated[Number, Field(ge=0)]
Positive = Annotated[Number, Field(gt=0), at_least(SMALLEST_POSITIVE)]
Duration = Annotated[Number, Field(gt=0)]
# true or false only, never a text such as 'yes' or 'off'.
Flag = Annotated[bool, Strict()]

_SCALAR_SCHEMA: Final[dict[str, Any]] = {
    "anyOf": [
        {"type": "number"},
        {"type": "string", "description": "constant expression, e.g. '0.4*pi' or '2*k'"},
    ]
}


def parameters_of(info: ValidationInfo) -> dict[str, float]:
    context = info.context
    if isinstance(context, dict):
        parameters = context.get("parameters")
        if isinstance(parameters, dict):
            return parameters
    return {}


def _evaluate_scalar(value: Any, info: ValidationInfo) -> Any:
    """Turn a constant expression into its float; numbers pass through."""
    if isinstance(value, bool):
        raise PydanticCustomError("scalar_type", "expected a number or an expression")
    if isinstance(value, int | float):
        return value
    if not isinstance(value, str):
        # what it got is said where the error is read (spec/loader.py)
        raise PydanticCustomError("scalar_type", "expected a number or an expression text")
    from wmr_mission.expressions import ExpressionError, parse

    parameters = parameters_of(info)
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
    at_least(SMALLEST_SIZE),
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


def did_you_mean(word: str, names: Iterable[str]) -> str:
    """``; did you mean 'NAME'?`` for the name nearest a misspelt ``word``, else ''."""
    import difflib

    close = difflib.get_close_matches(word, list(names), n=1)
    return f"; did you mean {close[0]!r}?" if close else ""


def _known_region(name: str, info: ValidationInfo) -> str:
    """With a loader context, a region reference must name a declared region."""
    context = info.context
    if isinstance(context, dict) and isinstance(context.get("regions"), list | tuple):
        declared: list[str] = list(context["regions"])
        if name not in declared:
            hint = did_you_mean(name, declared)
            known = ", ".join(repr(n) for n in declared) or "none"
            raise PydanticCustomError(
                "undefined_region",
                "undefined region '{name}'{hint} (declared regions: {known})",
                {"name": name, "hint": hint, "known": known},
            )
    return name


RegionName = Annotated[str, Field(pattern=IDENTIFIER, max_length=64), AfterValidator(_known_region)]


# --- values per state --------------------------------------------------------


class Pose(Model):
    """A pose in the world frame."""

    x: Scalar = Field(default=0.0, description="Position x [m].")
    y: Scalar = Field(default=0.0, description="Position y [m].")
    theta: Scalar = Field(default=0.0, description="Heading [rad], counter-clockwise from +x.")


class StateStd(Model):
    """A standard deviation per state."""

    x: NonNegativeScalar = Field(default=0.0, description="Standard deviation of x [m].")
    y: NonNegativeScalar = Field(default=0.0, description="Standard deviation of y [m].")
    theta: NonNegativeScalar = Field(default=0.0, description="Standard deviation of theta [rad].")


class StateOffset(Model):
    """An offset per state."""

    x: Scalar = Field(default=0.0, description="Offset of x [m].")
    y: Scalar = Field(default=0.0, description="Offset of y [m].")
    theta: Scalar = Field(default=0.0, description="Offset of theta [rad].")


# --- sections written in several variants -------------------------------------


class Variant(Protocol):
    """What a registry holds: at least the settings model of the variant."""

    @property
    def settings(self) -> type[Model]: ...


V = TypeVar("V", bound=Variant)


def type_name(settings: type[Model]) -> str:
    """The ``type`` a variant's settings model answers to (its ``Literal``)."""
    field = settings.model_fields.get("type")
    names = () if field is None else typing.get_args(field.annotation)
    if len(names) != 1 or not isinstance(names[0], str):
        raise TypeError(f"{settings.__name__} needs a field `type: Literal[NAME]`")
    return str(names[0])


class Registry(Generic[V]):
    """The variants of one section of a mission, each named by its settings'
    ``type``: a discriminated union that registration fills.

    As an annotation's metadata (``Annotated[Base, REGISTRY]``) it validates
    as the union of the registered settings models, in registration order.
    ``default`` is the type of a section written without ``type``.
    """

    def __init__(self, section: str, default: str | None = None) -> None:
        self.section = section
        self.default = default
        self._variants: dict[str, V] = {}
        self._listeners: list[Callable[[], None]] = []

    def register(self, variant: V) -> V:
        """Add ``variant`` under its settings' ``type``; returns it."""
        name = type_name(variant.settings)
        if name in self._variants:
            raise ValueError(f"a {self.section} of type {name!r} is registered already")
        self._variants[name] = variant
        self._changed()
        return variant

    def unregister(self, name: str) -> None:
        """Remove the variant of type ``name`` (a plug-in's, in tests)."""
        del self._variants[name]
        self._changed()

    def on_change(self, listener: Callable[[], None]) -> None:
        """Call ``listener`` after every change (the models that embed the union rebuild)."""
        self._listeners.append(listener)

    def _changed(self) -> None:
        for listener in self._listeners:
            listener()

    def __getitem__(self, name: str) -> V:
        return self._variants[name]

    def __contains__(self, name: object) -> bool:
        return name in self._variants

    def __iter__(self) -> Iterator[V]:
        return iter(self._variants.values())

    def names(self) -> tuple[str, ...]:
        return tuple(self._variants)

    def of(self, settings: Model) -> V:
        """The variant whose settings ``settings`` are."""
        return self._variants[type_name(type(settings))]

    def settings_for(self, data: Any) -> type[Model] | None:
        """The settings model a written section (a mapping) selects, or None."""
        name = self._type_of(data)
        variant = None if name is None else self._variants.get(name)
        return None if variant is None else variant.settings

    def _type_of(self, value: Any) -> str | None:
        """The discriminator: a section's ``type``, or the default without one."""
        if isinstance(value, dict):
            kind = value.get("type", self.default)
            return kind if isinstance(kind, str) else None
        return getattr(value, "type", None)

    def union(self) -> Any:
        """The registered settings models as one discriminated union."""
        models = [variant.settings for variant in self._variants.values()]
        if len(models) == 1:
            return models[0]
        if self.default is None:
            return Annotated[typing.Union[tuple(models)], Field(discriminator="type")]  # noqa: UP007
        tagged = tuple(Annotated[m, Tag(type_name(m))] for m in models)
        return Annotated[typing.Union[tagged], Discriminator(self._type_of)]  # noqa: UP007

    def __get_pydantic_core_schema__(
        self, source: Any, handler: GetCoreSchemaHandler
    ) -> CoreSchema:
        return handler.generate_schema(self.union())
