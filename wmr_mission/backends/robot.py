"""``wmr-mission serve-robot``: a stand-in robot over ROS 2.

A node that runs the mission's true plant (eq. (1) with its disturbances:
delay, lag, slip, skid, process noise) and its sensors (noise, bias, period,
dropouts, outliers) in real time at dt, with the kernels of our simulator:
it applies the newest ``geometry_msgs/Twist`` from ``cmd_vel`` and publishes
each measurement as ``nav_msgs/Odometry`` on ``odom`` (the true value where
a state is not measured; nothing when the measurement is lost). A command
older than ``stop_after`` is dropped: the robot stops, as a robot whose
controller went silent should.
"""

from __future__ import annotations

import math
import os
import sys
import time
from typing import Any

import numpy as np

from wmr_mission.backends.realtime import Pace
from wmr_mission.backends.ros2 import Node, messages
from wmr_mission.geometry import paths
from wmr_mission.kernels.disturbances import applied_input, plant_step, sense
from wmr_mission.sim.draws import Draws
from wmr_mission.sim.plan import MissionPlan
from wmr_mission.spec.backend import Backend
from wmr_mission.spec.models import Mission

# A scripted plan's poses: its path sampled every PLAN_STEP seconds of its own
# time over PLAN_HORIZON seconds (fewer where an open route ends).
PLAN_STEP = 0.2
PLAN_HORIZON = 30.0


class ScriptedPlans:
    """``serve-robot --plan-from MISSION``: a stand-in planner. At mission time T
    (from the first command heard) it publishes, as a ``nav_msgs/Path`` on the
    plan topic, the path of each update of MISSION written ``mission_time: T``
    or, in its first phase, ``elapsed: T``, made from the robot's true pose then."""

    def __init__(self, node: Node, planner: Mission, settings: Backend) -> None:
        from nav_msgs.msg import Path

        self.frame = settings.frame_id
        self.context = planner.path_context()
        self.script: list[tuple[float, Any]] = []
        for number, phase in enumerate(planner.phases):
            for update in getattr(phase, "updates", ()):
                when = update.when
                at = when.mission_time if number > 0 else when.mission_time or when.elapsed
                if at is not None and update.path is not None:
                    self.script.append((float(at), update.path))
        self.script.sort(key=lambda item: item[0])
        topic = settings.plan or "plan"
        self._path = Path
        self.publisher = node.node.create_publisher(Path, topic, node.qos("reliable", 1))
        print(
            f"serve-robot: {len(self.script)} plans scripted on '{topic}', at "
            f"{', '.join(f'{t:g}' for t, _ in self.script) or 'no time'} s",
            file=sys.stderr,
        )

    def at(self, t: float, state: Any, stamp: Any) -> None:
        """Publish the plans due by mission time ``t``, from the true pose ``state``."""
        from geometry_msgs.msg import PoseStamped

        while self.script and self.script[0][0] <= t + 1e-9:
            _, path = self.script.pop(0)
            pose = (float(state[0]), float(state[1]), float(state[2]))
            trajectory = paths.trajectory(path, self.context, pose)
            times = np.arange(0.0, PLAN_HORIZON + PLAN_STEP / 2, PLAN_STEP)
            x, y, dx, dy = trajectory.sample(times)
            moving = np.hypot(dx, dy) > 1e-12
            last = int(np.flatnonzero(moving)[-1]) + 2 if moving.any() else 2
            message = self._path()
            message.header.stamp = stamp
            message.header.frame_id = self.frame
            for px, py in zip(x[:last].tolist(), y[:last].tolist(), strict=True):
                point = PoseStamped()
                point.header = message.header
                point.pose.position.x, point.pose.position.y = px, py
                message.poses.append(point)
            self.publisher.publish(message)
            print(f"serve-robot: plan published at t = {t:g} s", file=sys.stderr, flush=True)


class StandInRobot:
    def __init__(
        self, plan: MissionPlan, settings: Backend, planner: Mission | None = None
    ) -> None:
        Twist, Odometry = messages()
        self.plan = plan
        self.settings = settings
        self._odometry = Odometry
        self.ros = Node("wmr_mission_robot")
        node = self.ros.node
        self.publisher = node.create_publisher(Odometry, settings.odom, self.ros.qos("reliable", 5))
        self.command = (0.0, 0.0, -math.inf)  # v, omega, time.perf_counter() at arrival
        node.create_subscription(
            Twist, settings.cmd_vel, self._on_command, self.ros.qos("best_effort", 1)
        )
        self.plans = None if planner is None else ScriptedPlans(self.ros, planner, settings)
        self.first_command = math.inf  # the sample of the first command heard

    def _on_command(self, message: Any) -> None:
        self.command = (message.linear.x, message.angular.z, time.perf_counter())

    def run(self) -> None:
        """Until Ctrl-C or SIGTERM (KeyboardInterrupt)."""
        plan = self.plan
        dt = plan.dt
        actuation, sensing = plan.disturbances.records(dt, plan.measured)
        draws = Draws(plan.noise_std, plan.disturbances, plan.seed)
        state = plan.initial_state.copy()
        commands = np.zeros((actuation.input_delay + 1, 2))
        applied = np.zeros(2)
        burst = np.zeros(1, dtype=np.int64)
        measurement = state.copy()
        u = np.zeros(2)
        self._publish(state, state, applied)
        pace = Pace(dt)
        k = 0
        while True:
            pace.wait()
            v, omega, received = self.command
            fresh = pace.tick - received <= self.settings.stop_after
            u[0], u[1] = (v, omega) if fresh else (0.0, 0.0)
            if self.plans is not None and received > -math.inf:
                self.first_command = min(self.first_command, k)
                now = self.ros.node.get_clock().now().to_msg()
                self.plans.at((k - self.first_command) * dt, state, now)
            row = draws.ahead()[0]
            draws.used(1)
            applied_input(actuation, k, u, commands, applied)
            plant_step(state, applied, dt, actuation, row)
            k += 1
            if sense(state, k, sensing, row, burst, measurement):
                self._publish(state, measurement, applied)

    def _publish(self, state: Any, measurement: Any, applied: Any) -> None:
        measured = self.plan.measured
        x, y, theta = (float(measurement[i] if measured[i] else state[i]) for i in range(3))
        message = self._odometry()
        message.header.stamp = self.ros.node.get_clock().now().to_msg()
        message.header.frame_id = self.settings.frame_id
        message.child_frame_id = self.settings.child_frame_id
        message.pose.pose.position.x = x
        message.pose.pose.position.y = y
        message.pose.pose.orientation.z = math.sin(theta / 2)
        message.pose.pose.orientation.w = math.cos(theta / 2)
        message.twist.twist.linear.x = float(applied[0])
        message.twist.twist.angular.z = float(applied[1])
        self.publisher.publish(message)


def serve(plan: MissionPlan, settings: Backend, planner: Mission | None = None) -> None:
    """The stand-in robot, until Ctrl-C or SIGTERM (raised as KeyboardInterrupt);
    with ``planner``, a stand-in planner too (ScriptedPlans)."""
    robot = StandInRobot(plan, settings, planner)
    try:
        domain = os.environ.get("ROS_DOMAIN_ID", "0")
        print(
            f"serve-robot: mission '{plan.name}' at {1 / plan.dt:g} Hz: listening on "
            f"'{settings.cmd_vel}', publishing '{settings.odom}' (ROS_DOMAIN_ID={domain}); "
            "Ctrl-C stops",
            file=sys.stderr,
            flush=True,
        )
        robot.run()
    finally:
        robot.ros.close()
