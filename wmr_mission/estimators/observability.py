"""Local observability of a measured subset of ``x, y, theta`` along a trajectory.

The model of eq. (1) couples the states only through the heading: A = I + a e3^T
with ``a = (a13, a23, 0)``. So ``x`` and ``y`` enter neither the output nor any
other state's dynamics unless they are measured, and ``theta`` shows in the
positions only while the robot moves. With the paper's ``xi = [x, theta]`` the
state ``y`` is unobservable.
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np
from numpy.typing import NDArray

from wmr_mission.basics import STATES, measurement_mask
from wmr_mission.kernels.model import state_jacobian


def observability_matrix(
    measured: Iterable[str],
    states: Sequence[NDArray[np.float64]],
    inputs: Sequence[NDArray[np.float64]],
    dt: float,
) -> NDArray[np.float64]:
    """Stacked ``C, C A_0, C A_1 A_0, ...`` of the time-varying linearisation."""
    mask = measurement_mask(measured)
    c = np.diag(mask)[mask > 0]
    rows = [c]
    product = np.eye(3)
    for state, u in zip(states, inputs, strict=True):
        product = state_jacobian(state, u, dt) @ product
        rows.append(c @ product)
    return np.vstack(rows)


def unobservable_states(
    measured: Iterable[str],
    states: Sequence[NDArray[np.float64]],
    inputs: Sequence[NDArray[np.float64]],
    dt: float,
) -> list[str]:
    """Names of the states whose direction is not in the row space of the observability matrix."""
    matrix = observability_matrix(measured, states, inputs, dt)
    _, singular, vt = np.linalg.svd(matrix)
    tol = max(matrix.shape) * np.finfo(float).eps * (singular[0] if singular.size else 1.0)
    rank = int(np.sum(singular > tol))
    null_space = vt[rank:]
    hidden = []
    for i, name in enumerate(STATES):
        if null_space.size and np.linalg.norm(null_space[:, i]) > 1e-8:
            hidden.append(name)
    return hidden


def structurally_unobservable(measured: Iterable[str], moving: bool = True) -> list[str]:
    """The same answer from the structure of eq. (1), without a trajectory.

    ``x`` and ``y`` are observable only when measured; ``theta`` when measured,
    or when a position is measured and the robot moves.
    """
    names = set(measured)
    hidden = [name for name in ("x", "y") if name not in names]
    if "theta" not in names and (not moving or not names & {"x", "y"}):
        hidden.append("theta")
    return hidden
