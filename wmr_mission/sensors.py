"""Measurements: any subset of ``x, y, theta`` with additive Gaussian noise.

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


class Sensors:
    """Noisy pose measurements from a seeded generator.

    Noise for a whole run is drawn in blocks (one generator call per block, not
    per sample); the sequence depends only on the seed, so a run is repeatable.
    """

    BLOCK = 4096

    def __init__(self, noise_std: NDArray[np.float64], seed: int) -> None:
        self._std = np.asarray(noise_std, dtype=np.float64).copy()
        self._rng = np.random.default_rng(seed)
        self._block = np.zeros((0, 3))
        self._next = 0

    def measure(self, state: NDArray[np.float64], out: NDArray[np.float64]) -> None:
        """Write ``state + noise`` into ``out`` (all three; unmeasured ones are ignored)."""
        if self._next == self._block.shape[0]:
            self._block = self._rng.standard_normal((self.BLOCK, 3)) * self._std
            self._next = 0
        noise = self._block[self._next]
        self._next += 1
        out[0] = state[0] + noise[0]
        out[1] = state[1] + noise[1]
        out[2] = state[2] + noise[2]
