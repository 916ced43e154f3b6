"""One `expect` check as data, and its margin.

A check bounds one metric of a phase (or of the whole run, ``phase`` None)
from above: it is met when the run's value is at most the bound (from below
for ``clearance_min``: at least the bound, its rho ``value - bound``). Its margin
is the quantitative answer the robustness of signal temporal logic gives to
``value <= bound``:

    rho    = bound - value              in the metric's unit, > 0 met, < 0 missed
    margin = rho / |bound| = 1 - value / bound

so that checks of different metrics compare: a margin of 0.5 is a value at
half its bound, 1 a value of 0 (every metric bounded is at least 0), -1 a
value at twice its bound. A bound of 0 admits only a value of 0: its margin
is 1 then, as under any bound (a value at the metric's floor), and -value
(over 1 of the unit) for a miss, its rho. A check without a value (a metric
that is not finite after a divergence) is missed by an unknown amount: its
margin is -inf, written ``null``.

A run's margin is the least of its checks' margins (``run_margin``), and names
the check that sets it; a run that ended otherwise than by completing its
phases (a timeout, a divergence, a breach, ...) has the margin -inf and its
outcome names it. ``summary.json`` writes a check as ``record()`` and a
campaign, a figure or ``view`` reads it back with ``Check.read``: never from
the words of a message.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from typing import Any, Self

__all__ = ["Check", "beside", "margin_fields", "run_margin"]

# The outcomes a run's checks decide; any other (a timeout, a divergence, a
# breach, an error) is a miss that no check measures.
_JUDGED_OUTCOMES = ("success", "expect-failed")


def beside(value: float, bound: float, digits: int) -> tuple[str, str]:
    """``value`` and ``bound`` to ``digits`` significant digits, the value to
    as many more as tell it from the bound (a miss of 3.0000000116 against 3
    read as ``3 (max 3)``)."""
    shown = f"{bound:.{digits}g}"
    for more in range(digits, 18):
        said = f"{value:.{more}g}"
        if value == bound or said != shown:
            return said, shown
    return said, shown


@dataclass(slots=True)  # made ~30 times a run judged
class Check:
    """``metric <= bound`` over ``phase`` (None: the whole run), with the run's
    ``value`` (None when it has none) and the line of advice a known mechanism
    gives for a miss."""

    metric: str
    phase: str | None
    bound: float
    value: float | None
    advice: str | None = None
    # A bound from below (``clearance_min``: at least so many metres): met when
    # the value is at least the bound, its rho ``value - bound``.
    lower: bool = False

    @property
    def met(self) -> bool:
        if self.value is None:
            return False
        return self.value >= self.bound if self.lower else self.value <= self.bound

    @property
    def rho(self) -> float:
        """``bound - value`` (``value - bound`` for a lower bound) in the
        metric's unit; -inf without a value."""
        if self.value is None:
            return -math.inf
        return self.value - self.bound if self.lower else self.bound - self.value

    @property
    def margin(self) -> float:
        """``rho`` over the bound's size: checks of different metrics compare."""
        if self.bound != 0.0:
            return self.rho / abs(self.bound)
        if self.lower:  # at least 0: how far above it, over 1 of the unit
            return self.rho
        # 0 <= 0 is as far within its bound as 0 is within any (1 - 0 / bound)
        return 1.0 if self.value == 0.0 else self.rho

    @property
    def name(self) -> str:
        """``phase: metric``, or the metric of a mission-wide check."""
        return self.metric if self.phase is None else f"{self.phase}: {self.metric}"

    def words(self) -> str:
        """``orbit: turn_rate_at_limit = 0.974 (max 0.01)``: a miss in a message."""
        if self.value is None:
            return f"{self.name} = none ({self.side} {self.bound:.6g})"
        value, bound = beside(self.value, self.bound, 6)
        return f"{self.name} = {value} ({self.side} {bound})"

    @property
    def side(self) -> str:
        """``max``, or ``min`` for a lower bound: the key of its bound in summary.json."""
        return "min" if self.lower else "max"

    def record(self) -> dict[str, Any]:
        """The check as ``summary.json``'s ``expectations`` lists it."""
        record: dict[str, Any] = {
            "metric": self.metric,
            "phase": self.phase,
            self.side: self.bound,
            "value": self.value,
            "met": self.met,
            "rho": _finite(self.rho),
            "margin": _finite(self.margin),
        }
        if self.advice is not None:
            record["advice"] = self.advice
        return record

    @classmethod
    def read(cls, record: Mapping[str, Any]) -> Self:
        """A check of ``summary.json`` (as ``record()`` writes it) read back."""
        value, advice, phase = record.get("value"), record.get("advice"), record.get("phase")
        lower = "max" not in record
        return cls(
            str(record["metric"]),
            None if phase is None else str(phase),
            float(record["min" if lower else "max"]),
            None if value is None else float(value),
            None if advice is None else str(advice),
            lower,
        )


def _finite(value: float) -> float | None:
    return value if math.isfinite(value) else None


def run_margin(checks: Iterable[Check], outcome: str) -> tuple[float, str | None]:
    """The run's margin and what sets it: the least margin of its checks and
    that check's name; -inf and the outcome for a run its checks do not decide
    (a timeout, a divergence, ...); +inf and None for a run without a check."""
    margin, setting = _least(checks, outcome)
    return margin, setting if setting is None or isinstance(setting, str) else setting.name


def _least(checks: Iterable[Check], outcome: str) -> tuple[float, Check | str | None]:
    """The run's margin and the check (or outcome) that sets it (:func:`run_margin`)."""
    if outcome not in _JUDGED_OUTCOMES:
        return -math.inf, outcome
    least: tuple[float, Check | None] = (math.inf, None)
    for check in checks:
        if least[1] is None or check.margin < least[0]:
            least = (check.margin, check)
    return least


def margin_fields(checks: Iterable[Check], outcome: str) -> dict[str, Any]:
    """``summary.json``'s ``margin`` (null for -inf and +inf: see ``margin_check``),
    ``margin_check``, the check that sets it (or the outcome; null: no check), and
    ``margin_metric``, its metric (or the outcome): what a campaign counts the
    runs' margins by, read as data, not from the check's name."""
    margin, setting = _least(checks, outcome)
    if setting is None or isinstance(setting, str):
        return {"margin": _finite(margin), "margin_check": setting, "margin_metric": setting}
    return {
        "margin": _finite(margin),
        "margin_check": setting.name,
        "margin_metric": setting.metric,
    }
