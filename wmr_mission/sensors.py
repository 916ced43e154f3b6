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
    """Noise for pose measurements from a seeded generator.

    Noise is drawn in blocks of ``BLOCK`` rows (one generator call per block);
    the loop adds row j to the j-th measurement. The sequence depends only on
    the seed, however the run is cut into chunks, so a run is repeatable.
    """

    BLOCK = 4096

    def __init__(self, noise_std: NDArray[np.float64], seed: int) -> None:
        self._std = np.asarray(noise_std, dtype=np.float64).copy()
        self._rng = np.random.default_rng(seed)
        self._ahead = np.zeros((0, 3))

    def ahead(self, rows: int) -> NDArray[np.float64]:
        """The next ``rows`` (or more) rows of noise, not yet used."""
        if self._ahead.shape[0] < rows and not self._std.any():
            # Noise-free: zeros, instead of draws scaled by zero.
            self._ahead = np.zeros((max(rows, self.BLOCK), 3))
        if self._ahead.shape[0] < rows:
            blocks = [self._ahead]
            drawn = self._ahead.shape[0]
            while drawn < rows:
                blocks.append(self._rng.standard_normal((self.BLOCK, 3)) * self._std)
                drawn += self.BLOCK
            self._ahead = np.ascontiguousarray(np.concatenate(blocks))
        return self._ahead

    def used(self, rows: int) -> None:
        """Mark the first ``rows`` rows of :meth:`ahead` as used."""
        self._ahead = self._ahead[rows:]
