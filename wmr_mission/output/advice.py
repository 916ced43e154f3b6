"""What to try when a verdict fails for a known reason: one line naming the
mechanism and the field that changes it; nothing where no mechanism is known.

Known mechanisms (each measured where docs/controllers.md says):

* ``turn_rate_jitter`` under position noise, with the paper's look-ahead law:
  the tracked point ``l`` ahead of the axle turns a lateral error ``e`` of the
  estimate into a heading error ``e / l``, so the jitter the position noise
  causes falls as ``1 / l`` ("The paper's tracking law under position noise").
  A look-ahead ``l * jitter / (HEADING_SHARE * bound)`` would meet the bound,
  a fifth of it left to what the heading noise adds (the heading's part does
  not fall with ``l``: missions/noisy-observer.yaml with position poles 0.5,
  2.0 rad/s at 0.05 m, 0.27 at 0.39 m against 0.26).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from wmr_mission.output.numbers import MissionNumbers

# The share of a jitter bound the position noise is given; the rest is the
# heading noise's, which a longer look-ahead does not take out.
HEADING_SHARE = 0.8


def _up(value: float) -> float:
    """``value`` rounded up to 2 significant digits."""
    scale = 10.0 ** (math.floor(math.log10(value)) - 1)
    return math.ceil(value / scale - 1e-9) * scale


def advice(check: Mapping[str, Any], numbers: MissionNumbers, controller: str) -> str | None:
    """The line for an unmet ``check`` of a track phase (as
    metrics.check_expectations makes them) whose failure a known mechanism
    explains, else None. ``controller`` is the mission's ``controller.type``."""
    if check["met"] or check["value"] is None:
        return None
    if check["metric"] == "turn_rate_jitter":
        noise, look_ahead = numbers.position_noise, numbers.look_ahead
        if controller != "paper" or noise <= 0.0 or look_ahead <= 0.0 or check["max"] <= 0.0:
            return None
        value, bound = float(check["value"]), float(check["max"])
        needed = _up(look_ahead * value / (HEADING_SHARE * bound))
        return (
            f"turn-rate jitter {value:.2g} rad/s: position noise {noise:g} m over a "
            f"look-ahead of {look_ahead:g} m; `controller.tracking.look_ahead` >= {needed:g} "
            f"would meet {bound:.2g}"
        )
    return None
