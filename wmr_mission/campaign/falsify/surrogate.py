"""A Gaussian-process model of the margin over the box, and its chance of a failure.

A Matern 5/2 kernel with one length scale per axis, a signal variance and a
noise variance (each run has its own sensor noise, which moves its margin),
fitted by maximum likelihood (Rasmussen and Williams, "Gaussian Processes for
Machine Learning", 2006, eq. 2.30 and 5.9). The margins are standardised; the
model's mean is their mean. Points are in the unit box.
"""

from __future__ import annotations

import math
from typing import Final

import numpy as np
from scipy.linalg import cho_solve, cholesky, solve_triangular
from scipy.optimize import minimize

__all__ = ["Gp"]

_ROOT5: Final = math.sqrt(5.0)
# Bounds of the log parameters: length scales from a hundredth of the box to
# twice it; the signal variance of standardised margins; the noise variance,
# from almost none to as much as the signal.
_BOUNDS: Final = {
    "scale": (math.log(1e-2), math.log(2.0)),
    "signal": (math.log(0.05), math.log(20.0)),
    "noise": (math.log(1e-6), math.log(1.0)),
}
_START: Final = {"scale": math.log(0.2), "signal": 0.0, "noise": math.log(1e-2)}
_FIT_STEPS: Final = 30
_JITTER: Final = 1e-9


def _matern(a: np.ndarray, b: np.ndarray, scales: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The kernel's correlation between rows of ``a`` and ``b``, and the scaled
    squared differences per axis (for the gradient)."""
    diff2 = ((a[:, None, :] - b[None, :, :]) / scales) ** 2
    r = np.sqrt(np.sum(diff2, axis=2))
    return (1 + _ROOT5 * r + 5 * r**2 / 3) * np.exp(-_ROOT5 * r), diff2


class Gp:
    """The model of margins ``y`` at unit-box points ``x``, its parameters fitted
    from ``start`` (the last fit's, or a fifth of the box, when None)."""

    def __init__(self, x: np.ndarray, y: np.ndarray, start: np.ndarray | None = None) -> None:
        d = x.shape[1]
        self.offset = float(np.mean(y))
        self.spread = float(np.std(y)) or 1.0
        self.x = x
        self.y = (y - self.offset) / self.spread
        bounds = [_BOUNDS["scale"]] * d + [_BOUNDS["signal"], _BOUNDS["noise"]]
        if start is None:
            start = np.array([_START["scale"]] * d + [_START["signal"], _START["noise"]])
        fit = minimize(
            self._nll,
            start,
            jac=True,
            method="L-BFGS-B",
            bounds=bounds,
            options={"maxiter": _FIT_STEPS},
        )
        self.params = np.asarray(fit.x, dtype=float)
        self._factor()

    def _nll(self, params: np.ndarray) -> tuple[float, np.ndarray]:
        """The negative log likelihood of the margins and its gradient (R&W eq. 5.9)."""
        d = self.x.shape[1]
        scales, signal, noise = np.exp(params[:d]), math.exp(params[d]), math.exp(params[d + 1])
        corr, diff2 = _matern(self.x, self.x, scales)
        k = signal * corr + (noise + _JITTER) * np.eye(len(self.y))
        try:
            lower = cholesky(k, lower=True)
        except np.linalg.LinAlgError:
            return 1e10, np.zeros_like(params)
        alpha = cho_solve((lower, True), self.y)
        nll = 0.5 * self.y @ alpha + np.sum(np.log(np.diag(lower)))
        inner = np.outer(alpha, alpha) - cho_solve((lower, True), np.eye(len(self.y)))
        r = np.sqrt(np.sum(diff2, axis=2))
        # d k / d log(scale_i) = signal * 5/3 (1 + sqrt5 r) exp(-sqrt5 r) * diff2_i
        shared = inner * signal * (5 / 3) * (1 + _ROOT5 * r) * np.exp(-_ROOT5 * r)
        grad = np.empty_like(params)
        grad[:d] = -0.5 * np.einsum("ij,ijk->k", shared, diff2)
        grad[d] = -0.5 * np.sum(inner * signal * corr)
        grad[d + 1] = -0.5 * np.trace(inner) * noise
        return float(nll), grad

    def _factor(self) -> None:
        d = self.x.shape[1]
        self.scales = np.exp(self.params[:d])
        self.signal, self.noise = math.exp(self.params[d]), math.exp(self.params[d + 1])
        corr, _ = _matern(self.x, self.x, self.scales)
        k = self.signal * corr + (self.noise + _JITTER) * np.eye(len(self.y))
        self.lower = cholesky(k, lower=True)
        self.alpha = cho_solve((self.lower, True), self.y)

    def _kernel(self, a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """The kernel between rows of ``a`` and ``b``."""
        kernel: np.ndarray = self.signal * _matern(a, b, self.scales)[0]
        return kernel

    def predict(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The model's margin at ``points`` and its standard deviation (of the
        margin itself, without a run's noise)."""
        mean, var, _ = self._posterior(points)
        return self.offset + self.spread * mean, self.spread * np.sqrt(var)

    def _posterior(self, points: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Standardised mean and variance at ``points``, and L^-1 k(runs, points)."""
        cross = self._kernel(points, self.x)
        v = solve_triangular(self.lower, cross.T, lower=True)
        var = np.maximum(self.signal - np.sum(v**2, axis=0), 1e-12)
        return cross @ self.alpha, var, v

    def most_likely_failures(self, candidates: np.ndarray, count: int) -> list[int]:
        """Indices of ``count`` candidates, each the one of greatest probability of
        a margin below 0, the variance updated after each as if it had been run
        with the model's own margin there (the kriging believer, which leaves the
        mean as it is: R&W eq. 2.24 with one more point)."""
        mean, var, v = self._posterior(candidates)
        zero = -self.offset / self.spread  # a margin of 0, standardised
        chosen: list[int] = []
        believed: list[np.ndarray] = []  # each believed run's share of the covariance
        for _ in range(count):
            # the greatest chance Phi(z) of a margin below 0, ranked by z itself
            # (Phi is 1.0 to the last digit for several likely failures)
            chance = (zero - mean) / np.sqrt(var)
            chance[chosen] = -np.inf  # a likely failure believed is likelier still
            k = int(np.argmax(chance))
            chosen.append(k)
            cov = self._kernel(candidates[k : k + 1], candidates)[0] - v[:, k] @ v
            for share in believed:
                cov -= share * share[k]
            share = cov / math.sqrt(var[k] + self.noise)
            var = np.maximum(var - share**2, 1e-12)
            believed.append(share)
        return chosen
