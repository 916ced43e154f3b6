"""Typed model of a campaign file (format version 1).

A campaign names a mission file, how many runs to draw, a root seed and, for
each varied mission field (a dotted path, as with ``run --set``), where its
values come from. Every model forbids unknown keys and is frozen.
"""

from __future__ import annotations

from typing import Annotated, Any, Final, Literal

from pydantic import BaseModel, ConfigDict, Field, Strict, model_validator
from pydantic.json_schema import SkipJsonSchema

from wmr_mission.fields import LARGEST_SEED
from wmr_mission.spec.models import MISSION_NAME

__all__ = ["DISTRIBUTIONS", "MAX_RUNS", "Axis", "Campaign", "CampaignExpect", "SuccessRate"]

MAX_RUNS: Final = 10_000_000
"""Most runs a campaign may ask for (draws times grid cells)."""

DISTRIBUTIONS: Final = ("uniform", "normal", "choice", "grid")

NORMAL_REACH: Final = 4.0
"""A normal axis is checked at mean +- 4 std (a draw beyond: about 6 in 100 000)."""

Number = Annotated[float, Field(allow_inf_nan=False)]
Std = Annotated[float, Field(ge=0, allow_inf_nan=False)]
# Values a mission field may take (numbers, texts, lists...): the mission checks each.
Values = Annotated[list[Any], Field(min_length=1, max_length=10_000)]


class _Model(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class Axis(_Model):
    """Where the values of one varied field come from: exactly one of the four keys."""

    model_config = ConfigDict(
        extra="forbid",
        frozen=True,
        json_schema_extra={"minProperties": 1, "maxProperties": 1},
    )

    uniform: tuple[Number, Number] | SkipJsonSchema[None] = Field(
        default=None, description="`[lo, hi]`: drawn uniformly in [lo, hi), lo < hi."
    )
    normal: tuple[Number, Std] | SkipJsonSchema[None] = Field(
        default=None, description="`[mean, std]`: drawn from a normal distribution, std >= 0."
    )
    choice: Values | SkipJsonSchema[None] = Field(
        default=None, description="Values drawn with equal probability."
    )
    grid: Values | SkipJsonSchema[None] = Field(
        default=None,
        description="Every value in turn: `runs` draws for each cell of the grid of grid axes.",
    )

    @model_validator(mode="after")
    def _one_distribution(self) -> Axis:
        given = [name for name in DISTRIBUTIONS if getattr(self, name) is not None]
        if len(given) != 1:
            raise ValueError(
                f"an axis has exactly one of {', '.join(DISTRIBUTIONS)}; "
                + (f"got {', '.join(given)}" if given else "got none")
            )
        if self.uniform is not None and not self.uniform[0] < self.uniform[1]:
            raise ValueError(
                f"uniform [lo, hi] needs lo < hi, got [{self.uniform[0]}, {self.uniform[1]}]"
            )
        return self

    @property
    def kind(self) -> str:
        return next(name for name in DISTRIBUTIONS if getattr(self, name) is not None)

    def extremes(self) -> list[Any]:
        """The values the mission must accept: the ends of a range (4 std for a normal),
        every value of a choice or grid."""
        if self.uniform is not None:
            return list(self.uniform)
        if self.normal is not None:
            mean, std = self.normal
            return [mean - NORMAL_REACH * std, mean + NORMAL_REACH * std] if std else [mean]
        return list(self.choice if self.choice is not None else self.grid or [])

    def within_extremes(self, value: Any) -> bool:
        """Whether a drawn value lies within the extremes `validate` checked: a
        normal draw may fall beyond them, any other draw may not."""
        if self.normal is None:
            return True
        extremes = self.extremes()
        return bool(min(extremes) <= value <= max(extremes))


class SuccessRate(_Model):
    """A lower bound on the fraction of successful runs."""

    min: Annotated[float, Field(ge=0, le=1)] = Field(description="Least success rate, 0 .. 1.")


class CampaignExpect(_Model):
    """What the campaign must show for `sweep` to exit 0."""

    success_rate: SuccessRate | SkipJsonSchema[None] = Field(
        default=None, description="Least fraction of runs whose outcome is success."
    )


class Campaign(_Model):
    """A campaign: one mission run many times with fields varied."""

    model_config = ConfigDict(
        extra="forbid",
        frozen=True,
        title="wmr-mission campaign",
        json_schema_extra={
            "description": (
                "A campaign of runs of one mission with fields varied (format version 1)."
            )
        },
    )

    version: Literal[1] = Field(description="Campaign format version: 1.")
    name: Annotated[str, Field(pattern=MISSION_NAME)] = Field(
        description="Campaign name: lower-case letters, digits, '-' and '_'; names the output."
    )
    description: Annotated[str, Field(max_length=10000)] = Field(
        default="", description="Free text."
    )
    mission: Annotated[str, Field(min_length=1, max_length=4096)] = Field(
        description="The mission file, relative to the campaign file."
    )
    runs: Annotated[int, Strict(), Field(ge=1, le=MAX_RUNS)] = Field(
        description="Random draws; per grid cell when there are grid axes."
    )
    seed: Annotated[int, Strict(), Field(ge=0, le=LARGEST_SEED)] = Field(
        default=0,
        description="Root seed: run i draws its values and its sensor seed from "
        "SeedSequence(seed).spawn(...)[i].",
    )
    vary: Annotated[dict[str, Axis], Field(max_length=100)] = Field(
        default_factory=dict,
        description="Varied mission fields by dotted path (as with `run --set`) and their values.",
    )
    expect: CampaignExpect = Field(
        default_factory=CampaignExpect, description="Thresholds on the campaign's statistics."
    )

    def grid_cells(self) -> int:
        cells = 1
        for axis in self.vary.values():
            if axis.grid is not None:
                cells *= len(axis.grid)
        return cells

    def total_runs(self) -> int:
        return self.runs * self.grid_cells()
