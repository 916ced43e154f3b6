"""Tracking inside keep-in and outside keep-out zones: eq. (28) with priority over eq. (27).

The paper treats its two constraint kinds in separate cases: a track phase
(Case 2) holds the equality "tracking output = reference" by eq. (27), and a
regulate phase (Case 1) holds inequality rows by eq. (28). A path drawn
through a keep-out zone needs both at once, and with two inputs both cannot
always hold: the zone must win. So at a track phase with constraints the
tracking input ``u_track`` of eq. (27) is filtered:

* predict ``x_{k+1}`` with ``u_track``;
* if no row of the phase's regions is violated there, ``u = u_track``:
  tracking is untouched;
* otherwise ``u = u_track + du`` with ``du`` of eq. (28) on the violated rows
  (at most the two most violated): the smallest change of the tracking input,
  in the input weighting ``Rw = B^T W B + M`` of eq. (22), that puts the
  predicted position on the rows' bounds. The rows hold (to first order) and
  the input stays as close to tracking as the rows allow: with one active row
  the robot slides along the zone's edge, tracking the path's component along
  it.

Then the actuator limits. docs/paper-notes.md, "Tracking with constraints",
records this departure from the paper's two separate cases.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from wmr_mission._jit import kernel
from wmr_mission.control import Workspace, input_jacobian_into, saturate
from wmr_mission.corrective import corrective_input, row_value
from wmr_mission.model import step

__all__ = ["keep_constraints"]

FloatArray = NDArray[np.float64]
IntArray = NDArray[np.int64]


@kernel
def keep_constraints(
    estimate: FloatArray,
    u_prev: FloatArray,
    row_kinds: IntArray,
    row_params: FloatArray,
    w: FloatArray,
    m: FloatArray,
    limits: FloatArray,
    dt: float,
    work: Workspace,
    u: FloatArray,
) -> bool:
    """Change the tracking input ``u`` in place so that the predicted position
    keeps the constraint rows; True when it had to (eq. (28) with priority)."""
    px, py, _ = step(estimate[0], estimate[1], estimate[2], u[0], u[1], dt)
    d, eta, b = work[0], work[1], work[2]
    count = 0
    for i in range(row_kinds.shape[0]):
        value, gx, gy = row_value(row_kinds[i], row_params[i], px, py)
        if value <= 0.0:
            continue
        # Keep the two most violated rows: two inputs meet at most two.
        slot = count
        if count == 2:
            slot = 0 if eta[0] > eta[1] else 1
            if -value >= eta[slot]:
                continue
        else:
            count += 1
        d[slot, 0] = gx
        d[slot, 1] = gy
        d[slot, 2] = 0.0
        eta[slot] = -value  # saturate to the violated bound
    if count == 0:
        return False
    # eq. (24): sensitivity of x_{k+1} to the input, at the tracking input.
    input_jacobian_into(estimate[2], u[0], u[1], dt, b)
    dv, dw = corrective_input(d, eta, count, b, w, m)
    u[0], u[1] = saturate(u[0] + dv, u[1] + dw, u_prev[0], u_prev[1], limits, dt)
    return True
