"""Units a number may be written with in a mission (`1 cm`, `2 rad/s`,
`90deg`), which a mission does not write: the message that refuses one says
the number to write in the field's unit (wmr_mission.spec.loader) or in a
temporal formula's signal's (wmr_mission.spec.temporal)."""

from __future__ import annotations

import math
import re
from typing import Final

# A unit a number may be written with (`1 cm`, `2 rad/s`, `90deg`): what it
# measures, named by its SI unit, and its size in that unit. A mission writes
# numbers alone, in the field's unit ([m], [s], [rad] in the field's
# description); a unit is refused, and the message says the number to write.
UNITS: Final[dict[str, tuple[str, float]]] = {
    **dict.fromkeys(("m", "meter", "meters", "metre", "metres"), ("m", 1.0)),
    "mm": ("m", 1e-3),
    "cm": ("m", 1e-2),
    "km": ("m", 1e3),
    **dict.fromkeys(("s", "sec", "second", "seconds"), ("s", 1.0)),
    "ms": ("s", 1e-3),
    "min": ("s", 60.0),
    "h": ("s", 3600.0),
    **dict.fromkeys(("rad", "radian", "radians"), ("rad", 1.0)),
    **dict.fromkeys(("deg", "degree", "degrees", "°"), ("rad", math.pi / 180.0)),
    "m/s": ("m/s", 1.0),
    "mm/s": ("m/s", 1e-3),
    "cm/s": ("m/s", 1e-2),
    "km/h": ("m/s", 1.0 / 3.6),
    "rad/s": ("rad/s", 1.0),
    **dict.fromkeys(("deg/s", "°/s"), ("rad/s", math.pi / 180.0)),
    **dict.fromkeys(("m/s^2", "m/s2"), ("m/s^2", 1.0)),
    **dict.fromkeys(("rad/s^2", "rad/s2"), ("rad/s^2", 1.0)),
    **dict.fromkeys(("deg/s^2", "deg/s2", "°/s^2"), ("rad/s^2", math.pi / 180.0)),
    **dict.fromkeys(("1/s", "hz"), ("1/s", 1.0)),
    "1/m": ("1/m", 1.0),
    **dict.fromkeys(("1/m^2", "1/m2"), ("1/m^2", 1.0)),
    "%": ("", 0.01),
}


def unit_of(text: str) -> tuple[str, float] | None:
    """What a unit as written measures and its size (``km / h``, ``m/s²``), or None."""
    return UNITS.get(re.sub(r"\s+", "", text).replace("²", "^2").lower())
