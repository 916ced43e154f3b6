"""What an update may change besides the path or target: the pace of the path
in force and the controller's look-ahead (docs/mission-format.md,
"References that change on-line")."""

from __future__ import annotations

from typing import Any


def path_pace(path: Any) -> float | None:
    """How fast a path runs as written: its speed [m/s], else its
    |angular_rate| [rad/s]; None for a path with neither (an expression)."""
    for name in ("speed", "angular_rate"):
        value = getattr(path, name, None)
        if value is not None:
            return abs(float(value))
    return None


def with_pace(path: Any, pace: float) -> Any:
    """The path's settings at ``pace`` (its speed, else |angular_rate|): each
    of its rates scaled alike, the curve kept, as a speed update runs it (for
    checking it)."""
    ratio = pace / (path_pace(path) or 1.0)
    rates = ("speed", "angular_rate", "growth_rate", "decay_rate", "turn_rate")
    return path.model_copy(
        update={
            name: float(getattr(path, name)) * ratio
            for name in rates
            if getattr(path, name, None) is not None
        }
    )


def with_look_ahead(settings: Any, distance: float) -> Any:
    """The controller's settings with its look-ahead distance replaced
    (``tracking.look_ahead``, or a ``look_ahead`` of its own), or None where
    it has none (the axle law tracks the axle itself)."""
    tracking = getattr(settings, "tracking", None)
    if tracking is not None and "look_ahead" in type(tracking).model_fields:
        if getattr(tracking, "output", None) == "axle":
            return None
        new = tracking.model_copy(update={"look_ahead": distance})
        return settings.model_copy(update={"tracking": new})
    if "look_ahead" in type(settings).model_fields:
        return settings.model_copy(update={"look_ahead": distance})
    return None
