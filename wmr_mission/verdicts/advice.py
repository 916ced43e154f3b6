"""What to try when a verdict fails for a known reason: one line naming the
mechanism and the field that changes it; nothing where no mechanism is known.

Known mechanisms (each measured where docs/controllers.md says):

* ``turn_rate_jitter`` under position noise, with the paper's look-ahead law:
  the tracked point ``l`` ahead of the axle turns a lateral error ``e`` of the
  estimate into a heading error ``e / l``, so the jitter the position noise
  causes falls as ``1 / l`` ("The paper's tracking law under position noise").
  It explains a miss when the phase's position estimate error (its RMS)
  accounts for a quarter of the jitter or more, as ``JITTER_GAIN rms / (l tau)``.
  A look-ahead ``l * jitter / (HEADING_SHARE * bound)`` would meet the bound,
  a fifth of it left to what the heading noise adds (the heading's part does
  not fall with ``l``: missions/noisy-observer.yaml with position poles 0.5,
  2.0 rad/s at 0.05 m, 0.27 at 0.39 m against 0.26).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

from wmr_mission.spec.numbers import MissionNumbers
from wmr_mission.verdicts.check import Check

# The share of a jitter bound the position noise is given; the rest is the
# heading noise's, which a longer look-ahead does not take out.
HEADING_SHARE = 0.8
# Turn-rate jitter per (position estimate error RMS / (look-ahead time constant)):
# the least measured, 0.33 to 0.84 on missions/patrol-detour.yaml's three track
# phases with poles 0.9 and look-aheads 0.05 to 0.2 m (docs/controllers.md,
# "The paper's tracking law under position noise").
JITTER_GAIN = 0.33
# The mechanism explains a miss when it accounts for at least this share of it.
EXPLAINED = 0.25


def _up(value: float) -> float:
    """``value`` rounded up to 2 significant digits."""
    scale = 10.0 ** (math.floor(math.log10(value)) - 1)
    return math.ceil(value / scale - 1e-9) * scale


def explained_jitter(phase: Mapping[str, Any], numbers: MissionNumbers) -> float:
    """[rad/s] The turn-rate jitter the phase's position estimate error explains:
    ``JITTER_GAIN rms / (l tau)``, 0 where it is not known."""
    rms = (phase.get("estimation") or {}).get("rms") or {}
    errors = [float(rms[s]) for s in ("x", "y") if rms.get(s) is not None]
    if not errors or numbers.look_ahead <= 0.0:
        return 0.0
    return JITTER_GAIN * max(errors) / (numbers.look_ahead * numbers.time_constant)


def advice(
    check: Check, phase: Mapping[str, Any], numbers: MissionNumbers, controller: str
) -> str | None:
    """The line for an unmet ``check`` of the track phase ``phase`` (its
    summary; as metrics.check_expectations makes them) whose failure a known
    mechanism explains, else None. ``controller`` is the mission's
    ``controller.type``."""
    if check.met or check.value is None:
        return None
    if check.metric == "turn_rate_jitter":
        noise, look_ahead = numbers.position_noise, numbers.look_ahead
        if controller != "paper" or noise <= 0.0 or look_ahead <= 0.0 or check.bound <= 0.0:
            return None
        value, bound = check.value, check.bound
        if explained_jitter(phase, numbers) < EXPLAINED * value:
            return None  # something else turns it: a zone, a corner
        needed = _up(look_ahead * value / (HEADING_SHARE * bound))
        return (
            f"turn-rate jitter {value:.2g} rad/s: position noise {noise:g} m over a "
            f"look-ahead of {look_ahead:g} m; `controller.tracking.look_ahead` >= {needed:g} "
            f"would meet {bound:.2g}"
        )
    return None
