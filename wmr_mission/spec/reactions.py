"""What a mission does when a phase times out, fails or breaches its geofence.

A reaction is written as a text (``fail``, ``next``, or a contingency's name:
``hold``, ``return-home`` or one of the mission's ``contingencies``), or as
a mapping (``{goto: PHASE}``, ``{retry: {times: N}}``). The reactions of a
mission form a graph that ``validate`` proves ends (wmr_mission.spec.graph);
the runner decides between chunks of the loop (wmr_mission.sim.reactions).
"""

from __future__ import annotations

from typing import Annotated, Any, Final, Literal

from pydantic import Discriminator, Field, Strict, Tag

from wmr_mission.fields import Model, NonNegative, RegionName

__all__ = [
    "BUILT_IN_CONTINGENCIES",
    "BUILT_IN_TIMEOUT",
    "EVENTS",
    "FALLBACK_FORMS",
    "Fallback",
    "Geofence",
    "Goto",
    "Reaction",
    "Retry",
    "RetryCount",
    "Then",
    "reaction_text",
]

# The events a phase reacts to, as the keys a mission writes them by.
EVENTS: Final = ("on_timeout", "on_breach", "on_failure")

# Contingencies every mission has without writing them (wmr_mission.sim.plan builds them).
BUILT_IN_CONTINGENCIES: Final = ("hold", "return-home")
# [s] their one phase's timeout: it ends settled, or then.
BUILT_IN_TIMEOUT: Final = 120.0

FALLBACK_FORMS: Final = "fail, next, a contingency's name (hold, return-home, ...) or {goto: PHASE}"
REACTION_FORMS: Final = (
    "fail, next, a contingency's name (hold, return-home, ...), {goto: PHASE} or "
    "{retry: {times: N}}"
)

# A phase's or contingency's name (wmr_mission.spec.models.PHASE_NAME).
_NAME: Final = r"^[A-Za-z0-9][A-Za-z0-9_-]{0,63}$"
ReactionName = Annotated[str, Field(pattern=_NAME)]
RetryCount = Annotated[int, Strict(), Field(ge=1, le=100)]


class Goto(Model):
    """Enter a phase of the mission written at the top of `phases` (not in a repeat)."""

    goto: ReactionName = Field(description="The phase's name.")


def _fallback_form(value: Any) -> str | None:
    if isinstance(value, str):
        return "name"
    if isinstance(value, Goto) or (isinstance(value, dict) and "goto" in value):
        return "goto"
    return None


Fallback = Annotated[
    Annotated[ReactionName, Tag("name")] | Annotated[Goto, Tag("goto")],
    Discriminator(
        _fallback_form,
        custom_error_type="fallback_form",
        custom_error_message=f"a reaction once the retries are spent is {FALLBACK_FORMS}",
    ),
]


class RetrySettings(Model):
    """How many times the phase is entered again, and what follows once they are spent."""

    times: RetryCount = Field(
        description=(
            "Re-entries of the phase in one run, 1..100; counted per run, never reset "
            "(a phase re-entered by a goto keeps its count)."
        )
    )
    then: Fallback = Field(
        default="fail", description=f"Once the retries are spent: {FALLBACK_FORMS}."
    )


class Retry(Model):
    """Enter the phase again from where the robot is, a bounded number of times."""

    retry: RetrySettings = Field(description="The count and what follows it.")


def _reaction_form(value: Any) -> str | None:
    if isinstance(value, Retry) or (isinstance(value, dict) and "retry" in value):
        return "retry"
    return _fallback_form(value)


Reaction = Annotated[
    Annotated[ReactionName, Tag("name")]
    | Annotated[Goto, Tag("goto")]
    | Annotated[Retry, Tag("retry")],
    Discriminator(
        _reaction_form,
        custom_error_type="reaction_form",
        custom_error_message=f"a reaction is {REACTION_FORMS}",
    ),
]


class Geofence(Model):
    """Zones the robot must keep to whatever its phases' constraints say: a breach
    is the true or the estimated position deeper than `margin` on the wrong side."""

    keep_in: tuple[RegionName, ...] = Field(
        default=(), max_length=64, description="Regions the robot must stay inside."
    )
    keep_out: tuple[RegionName, ...] = Field(
        default=(), max_length=64, description="Regions the robot must stay outside."
    )
    margin: NonNegative = Field(
        default=0.0,
        description=(
            "[m] how deep on the wrong side of a zone's boundary the position may go before "
            "it is a breach."
        ),
    )


def reaction_text(reaction: Any) -> str:
    """A reaction as a mission writes it, on one line (transitions.json, messages)."""
    if isinstance(reaction, str):
        return reaction
    if isinstance(reaction, Goto):
        return f"goto: {reaction.goto}"
    if isinstance(reaction, Retry):
        return f"retry: {reaction.retry.times}"
    return str(reaction)


THEN_FORMS: Final = "resume, next, end, fail or {goto: PHASE}"

Then = Annotated[
    Annotated[Literal["resume", "next", "end", "fail"], Tag("name")] | Annotated[Goto, Tag("goto")],
    Discriminator(
        _fallback_form,
        custom_error_type="then_form",
        custom_error_message=f"what follows a contingency is {THEN_FORMS}",
    ),
]
