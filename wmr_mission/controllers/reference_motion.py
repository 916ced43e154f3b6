"""The reference a tracking law reads from the path, per sample: the pose and
the velocity feed-forward.

The loop hands a controller the path at t_k and t_{k+1} (``aim_now``,
``aim``: x, y, unit tangent x, y; wmr_mission.kernels.loop). The reference
pose at k is the point at t_k heading along its tangent; the feed-forward is
the motion that takes the unicycle of eq. (1) from one to the other over one
sample: speed = distance / dt, turn rate = heading change / dt. A path at rest
gives zero feed-forward (the loop puts the tangent it last moved along in its
tangent).
"""

from __future__ import annotations

import math

from wmr_mission.basics import FloatArray
from wmr_mission.kernels.jit import inlined
from wmr_mission.kernels.model import hypot, wrap_angle


@inlined
def reference_motion(
    aim_now: FloatArray, aim: FloatArray, dt: float
) -> tuple[float, float, float, float, float]:
    """(x_r, y_r, theta_r, v_r, omega_r): the reference pose at t_k and the
    feed-forward speed and turn rate over [t_k, t_{k+1}]."""
    heading_now = math.atan2(aim_now[3], aim_now[2])
    heading_next = math.atan2(aim[3], aim[2])
    speed = hypot(aim[0] - aim_now[0], aim[1] - aim_now[1]) / dt
    turn_rate = wrap_angle(heading_next - heading_now) / dt
    return aim_now[0], aim_now[1], heading_now, speed, turn_rate
