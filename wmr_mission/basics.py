"""Measurements: any subset of ``x, y, theta`` (noise and the sensors'
disturbances: wmr_mission.kernels.disturbances).

The paper measures ``xi = [x, theta]`` (eq. (1)); the output of eq. (2) here is
the full pose masked by which states are measured, so the kernels keep fixed
3-vectors and a 0/1 mask instead of changing shapes.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np
from numpy.typing import NDArray

STATE_NAMES = ("x", "y", "theta")


def measurement_mask(measured: Iterable[str]) -> NDArray[np.float64]:
    """1.0 for each measured state, in the order x, y, theta."""
    names = set(measured)
    unknown = names - set(STATE_NAMES)
    if unknown:
        raise ValueError(f"unknown state(s) {sorted(unknown)}; expected a subset of x, y, theta")
    return np.array([1.0 if name in names else 0.0 for name in STATE_NAMES])
