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
from wmr_mission.kernels.disturbances import applied_input, plant_step, sense
from wmr_mission.sim.draws import Draws
from wmr_mission.sim.plan import MissionPlan
from wmr_mission.spec.backend import Backend


class StandInRobot:
    def __init__(self, plan: MissionPlan, settings: Backend) -> None:
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


def serve(plan: MissionPlan, settings: Backend) -> None:
    """The stand-in robot, until Ctrl-C or SIGTERM (raised as KeyboardInterrupt)."""
    robot = StandInRobot(plan, settings)
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
