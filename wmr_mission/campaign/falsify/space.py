"""A campaign's axes as a box the search moves in, and a point of it as a run's values.

Each varied path is one coordinate of a point:

* a ``uniform`` or ``normal`` axis, a number ``u`` in [0, 1]: its quantile, so
  that a point drawn uniformly is a draw of the campaign's own distribution
  (a normal axis is cut at the mean +- 4 std that `validate` checks);
* a ``choice`` or ``grid`` axis of ``k`` values, an index in [-0.5, k - 0.5],
  rounded to the nearest value: CMA-ES's mixed-integer handling keeps a least
  step on such coordinates (docs/falsification.md, "Choices").

Uniform random points of the box are thus the campaign's draws, and a region's
share of the box is its probability under the campaign.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from statistics import NormalDist
from typing import Any, Final

from wmr_mission.campaign.models import NORMAL_REACH, Axis, Campaign

__all__ = ["Space"]

_STANDARD: Final = NormalDist()
# The quantiles a normal axis reaches: mean - 4 std .. mean + 4 std.
_NORMAL_LOW: Final = _STANDARD.cdf(-NORMAL_REACH)
_NORMAL_HIGH: Final = _STANDARD.cdf(NORMAL_REACH)
# The largest u < 1: a uniform axis's value stays below its hi, as a draw does.
_BELOW_ONE: Final = math.nextafter(1.0, 0.0)


@dataclass(frozen=True)
class Space:
    """The box of a campaign's axes, in the campaign's order of ``vary``."""

    campaign: Campaign

    @property
    def paths(self) -> list[str]:
        return list(self.campaign.vary)

    @property
    def axes(self) -> list[Axis]:
        return list(self.campaign.vary.values())

    @property
    def dimension(self) -> int:
        return len(self.campaign.vary)

    def counts(self) -> list[int]:
        """Values of each discrete axis, 0 for a continuous one."""
        return [len(_discrete(axis) or ()) for axis in self.axes]

    def discrete(self) -> list[int]:
        """Indices of the choice and grid coordinates."""
        return [i for i, count in enumerate(self.counts()) if count]

    def lower(self) -> list[float]:
        return [-0.5 if count else 0.0 for count in self.counts()]

    def upper(self) -> list[float]:
        return [count - 0.5 if count else 1.0 for count in self.counts()]

    def values(self, point: Sequence[float]) -> dict[str, Any]:
        """The run's value of each varied path at ``point``."""
        if len(point) != self.dimension:
            raise ValueError(f"a point of {self.dimension} coordinates, got {len(point)}")
        return {
            path: _value(axis, float(x))
            for path, axis, x in zip(self.paths, self.axes, point, strict=True)
        }


def _discrete(axis: Axis) -> list[Any] | None:
    return axis.choice if axis.choice is not None else axis.grid


def _value(axis: Axis, x: float) -> Any:
    values = _discrete(axis)
    if values is not None:
        index = min(max(math.floor(x + 0.5), 0), len(values) - 1)
        return values[index]
    u = min(max(x, 0.0), _BELOW_ONE)
    if axis.uniform is not None:
        lo, hi = axis.uniform
        return min(lo + u * (hi - lo), math.nextafter(hi, lo))
    assert axis.normal is not None
    mean, std = axis.normal
    if std == 0:
        return mean
    q = _NORMAL_LOW + u * (_NORMAL_HIGH - _NORMAL_LOW)
    return mean + std * _STANDARD.inv_cdf(q)
