"""ros2: a robot over ROS 2, in real time (docs/backends.md).

Each sample: wait for the tick (every dt of wall clock, Pace), take the
newest ``nav_msgs/Odometry`` from ``odom`` as the robot's pose and as the
measurement (a dropout when older than ``stale_after``; the run stops,
failed, when older than ``stop_after``), run the estimator and the controller,
publish ``geometry_msgs/Twist`` on ``cmd_vel``. Whatever ends the run, a zero
command is published first, and summary.json's ``realtime`` says so; its
acknowledgement is waited for once the record is written (``confirm_stop``).

rclpy's own signal handlers are left out (SignalHandlerOptions.NO): they
would shut the context down on Ctrl-C before the zero command could go;
SIGINT and SIGTERM stay the command's (wmr_mission.stopping).
"""

from __future__ import annotations

import contextlib
import math
import sys
import threading
import time
from collections.abc import Callable, Iterator, Mapping
from importlib import metadata
from typing import Any, NamedTuple

from wmr_mission.backends.realtime import Pace
from wmr_mission.backends.registry import BackendError, missing
from wmr_mission.basics import FloatArray, IntArray
from wmr_mission.kernels import disturbances
from wmr_mission.kernels.disturbances import Actuation, Sensing
from wmr_mission.kernels.model import wrap_angle
from wmr_mission.sim.plan import MissionPlan, UpdatePlan, goal, hold_still, planned
from wmr_mission.sim.plant_side import PlantStopped
from wmr_mission.spec.backend import Backend

# Seconds to wait for every reader to acknowledge the zero command: over Fast
# DDS's 3 s heartbeat period, so that a sample a reader missed is resent once.
ZERO_ACK_WAIT = 5.0


class Pose(NamedTuple):
    x: float
    y: float
    theta: float
    received: float  # time.perf_counter() at arrival


class Node:
    """An rclpy node of its own context, spun by a thread."""

    def __init__(self, name: str) -> None:
        try:
            import rclpy
            from rclpy.executors import SingleThreadedExecutor
            from rclpy.signals import SignalHandlerOptions
        except ImportError as error:
            raise missing("ros2", error) from None
        self.rclpy = rclpy
        self.context = rclpy.Context()
        rclpy.init(context=self.context, signal_handler_options=SignalHandlerOptions.NO)
        self.node = rclpy.create_node(name, context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self._spinner = threading.Thread(target=self._spin, name=f"{name}-spin", daemon=True)
        self._spinner.start()

    def _spin(self) -> None:
        with contextlib.suppress(Exception):  # the context shut down under it
            self.executor.spin()

    def qos(self, reliability: str, depth: int) -> Any:
        from rclpy.qos import QoSProfile, ReliabilityPolicy

        policy = ReliabilityPolicy.RELIABLE
        if reliability == "best_effort":
            policy = ReliabilityPolicy.BEST_EFFORT
        return QoSProfile(depth=depth, reliability=policy)

    def close(self) -> None:
        self.executor.shutdown()
        self._spinner.join()  # else the process can abort at exit
        self.node.destroy_node()
        self.rclpy.try_shutdown(context=self.context)


def messages() -> tuple[Any, Any]:
    """geometry_msgs/Twist and nav_msgs/Odometry."""
    try:
        from geometry_msgs.msg import Twist
        from nav_msgs.msg import Odometry
    except ImportError as error:
        raise missing("ros2", error) from None
    return Twist, Odometry


def versions() -> dict[str, str]:
    found = {}
    for package in ("ros-rclpy", "ros-rmw-fastrtps-cpp"):
        with contextlib.suppress(metadata.PackageNotFoundError):
            found[package] = metadata.version(package)
    try:
        from rclpy.utilities import get_rmw_implementation_identifier

        found["rmw"] = get_rmw_implementation_identifier()
    except ImportError:  # pragma: no cover - an rclpy without it
        pass
    return found


class Ros2Plant:
    """A robot behind ``cmd_vel`` and ``odom`` in place of the loop's plant
    and sensors (wmr_mission.sim.plant_side)."""

    def __init__(self, plan: MissionPlan, settings: Backend) -> None:
        Twist, Odometry = messages()
        self.settings = settings
        self.dt = plan.dt
        self.pace = Pace(plan.dt)
        self.latest: Pose | None = None
        self.fresh = False
        self.dropouts = 0
        self.zero_sent = False
        # Whether every reader acknowledged the zero command; None until waited
        # for (confirm_stop, after the record is written).
        self.zero_acknowledged: bool | None = None
        self._twist = Twist
        self.ros = Node("wmr_mission")
        node = self.ros.node
        self.publisher = node.create_publisher(
            Twist, settings.cmd_vel, self.ros.qos(settings.cmd_vel_reliability, 1)
        )
        node.create_subscription(
            Odometry, settings.odom, self._on_odom, self.ros.qos(settings.odom_reliability, 5)
        )
        # A planner's plans (docs/backends.md, "A planner over ROS 2"): the newest
        # not yet taken, and how many were taken or refused.
        self.plans: Callable[[int, int, str], UpdatePlan | None] | None = None
        self._plan: UpdatePlan | None = None
        self._plan_lock = threading.Lock()
        self.plans_taken = 0
        self.plans_refused = 0
        # The sample the last plan or goal was taken at (the run's first before
        # one), and whether the planner is quiet (backend.plan_stale_after):
        # counted in the run's time, as `elapsed` is, so that the record shows it.
        self._heard: int | None = None
        self._dt = plan.dt
        self._quiet = False
        self.plans_stale = 0
        # The last phase held for want of a first plan (docs/backends.md, "No plan yet").
        self._held_phase = -1
        self._context = plan.context
        if settings.plan is not None or settings.goal is not None:
            self.plans = self._next_plan
        if settings.goal is not None:
            from geometry_msgs.msg import PoseStamped

            node.create_subscription(
                PoseStamped,
                settings.goal,
                self._on_goal,
                self.ros.qos(settings.goal_reliability, 1),
            )
            print(
                f"ros2: goals from '{settings.goal}' (geometry_msgs/PoseStamped in frame "
                f"'{settings.frame_id}'); until the first, each phase holds the estimated pose",
                file=sys.stderr,
            )
        if settings.plan is not None:
            from nav_msgs.msg import Path

            node.create_subscription(
                Path, settings.plan, self._on_plan, self.ros.qos(settings.plan_reliability, 1)
            )
            print(
                f"ros2: plans from '{settings.plan}' (nav_msgs/Path in frame "
                f"'{settings.frame_id}'); until the first, each track phase holds the "
                "estimated pose",
                file=sys.stderr,
            )

    def _on_odom(self, message: Any) -> None:
        pose = message.pose.pose
        q = pose.orientation
        theta = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        self.latest = Pose(pose.position.x, pose.position.y, theta, time.perf_counter())

    def _on_plan(self, message: Any) -> None:
        """A plan in the odometry's frame, of two poses or more, at plan_speed;
        another is refused, and said so."""
        frame = message.header.frame_id.lstrip("/")
        points = [[p.pose.position.x, p.pose.position.y] for p in message.poses]
        problem = None
        if frame != self.settings.frame_id.lstrip("/"):
            problem = f"its frame is '{frame}', not '{self.settings.frame_id}'"
        elif len(points) < 2:
            problem = f"it has {len(points)} pose{'s' * (len(points) != 1)}, not 2 or more"
        if problem is not None:
            self.plans_refused += 1
            print(f"ros2: a plan on '{self.settings.plan}' refused: {problem}", file=sys.stderr)
            return
        latest = self.latest
        if latest is not None:
            # Joined past its pose nearest the robot: the poses before it are
            # what the robot has passed since the planner planned.
            nearest = min(range(len(points)), key=lambda i: math.dist(points[i], latest[:2]))
            points = points[min(nearest + 1, len(points) - 2) :]
        route = {"type": "waypoints", "points": points, "speed": self.settings.plan_speed}
        try:
            update = planned(route, self._context, f"plan on '{self.settings.plan}'")
        except ValueError as error:
            self.plans_refused += 1
            print(f"ros2: a plan on '{self.settings.plan}' refused: {error}", file=sys.stderr)
            return
        with self._plan_lock:
            self._plan = update

    def _on_goal(self, message: Any) -> None:
        """A goal pose in the odometry's frame: a regulate phase's target, a
        track phase's straight route to it; another frame is refused."""
        topic = self.settings.goal
        frame = message.header.frame_id.lstrip("/")
        if frame != self.settings.frame_id.lstrip("/"):
            self.plans_refused += 1
            print(
                f"ros2: a goal on '{topic}' refused: its frame is '{frame}', not "
                f"'{self.settings.frame_id}'",
                file=sys.stderr,
            )
            return
        pose = message.pose
        q = pose.orientation
        theta = math.atan2(2.0 * (q.w * q.z + q.x * q.y), 1.0 - 2.0 * (q.y * q.y + q.z * q.z))
        to = (float(pose.position.x), float(pose.position.y), theta)
        latest = self.latest
        via = to[:2] if latest is None else (0.5 * (latest.x + to[0]), 0.5 * (latest.y + to[1]))
        try:
            update = goal(to, via, self.settings.plan_speed, self._context, f"goal on '{topic}'")
        except ValueError as error:
            self.plans_refused += 1
            print(f"ros2: a goal on '{topic}' refused: {error}", file=sys.stderr)
            return
        with self._plan_lock:
            self._plan = update

    def _next_plan(self, k: int, phase: int, kind: str) -> UpdatePlan | None:
        """At sample ``k``, the newest plan or goal not yet taken; before the
        first, a hold of each phase (by its index) of a ``kind`` that takes
        them; else, once the planner has been quiet plan_stale_after seconds,
        what on_plan_stale says."""
        now = k
        with self._plan_lock:
            update, self._plan = self._plan, None
        if self._heard is None:
            self._heard = now
        if update is not None:
            self.plans_taken += 1
            self._heard, self._quiet = now, False
            return update
        if self.plans_taken == 0 and phase != self._held_phase and self._takes(kind):
            # No plan yet: the robot holds where it is rather than drive a path
            # the planner has not confirmed; each phase that takes plans says so.
            self._held_phase = phase
            print(
                f"ros2: no plan yet on {self._topics()}: holding the estimated pose",
                file=sys.stderr,
            )
            return hold_still("no plan yet")
        after = self.settings.plan_stale_after
        if after is None or self._quiet or (now - self._heard) * self._dt < after - 0.5 * self._dt:
            return None
        self._quiet = True
        self.plans_stale += 1
        quiet = f"no plan or goal on {self._topics()} for {after:g} s"
        action = self.settings.on_plan_stale
        if action == "fail":
            raise PlantStopped(f"the planner went quiet: {quiet} (on_plan_stale: fail)")
        what = (
            "keeping the reference in force" if action == "keep" else "holding the estimated pose"
        )
        print(f"ros2: {quiet}: {what}", file=sys.stderr)
        return hold_still(f"planner quiet for {after:g} s") if action == "hold" else None

    def _topics(self) -> str:
        return " or ".join(f"'{t}'" for t in (self.settings.plan, self.settings.goal) if t)

    def _takes(self, kind: str) -> bool:
        """Whether a phase of ``kind`` takes the planner's messages: a track
        phase plans and goals, a regulate phase goals."""
        return kind == "track" or (kind == "regulate" and self.settings.goal is not None)

    def wait_for_robot(self) -> None:
        """Until the first measurement, at most ``wait_for_robot`` seconds."""
        limit = time.perf_counter() + self.settings.wait_for_robot
        while self.latest is None:
            if time.perf_counter() > limit:
                raise BackendError(
                    f"no measurement on '{self.settings.odom}' within "
                    f"{self.settings.wait_for_robot:g} s: is the robot (or `wmr-mission "
                    "serve-robot MISSION`) running, with the same ROS_DOMAIN_ID?"
                )
            time.sleep(0.01)

    # --- wmr_mission.sim.plant_side.PlantSide ----------------------------------------

    def substitutes(self) -> Mapping[Any, Callable[..., Any]]:
        return {
            disturbances.applied_input: self.command,
            disturbances.plant_step: self.next_tick,
            disturbances.sense: self.measure,
        }

    def start(self, state: FloatArray) -> None:
        assert self.latest is not None
        self._take_pose(state, self.latest)
        self.pace.start()

    def stop(self) -> None:
        if self.zero_sent:
            return
        self.publisher.publish(self._twist())  # v = 0, omega = 0
        self.zero_sent = True
        print(f"ros2: zero command published on '{self.settings.cmd_vel}'", file=sys.stderr)

    def confirm_stop(self) -> None:
        """Wait, up to ZERO_ACK_WAIT, for every reader to acknowledge the zero
        command: after the record is written, since a robot killed mid-run is
        a reader its writer keeps until its lease runs out (20 s by default),
        and the whole wait goes by."""
        if not self.zero_sent or self.zero_acknowledged is not None:
            return
        from rclpy.duration import Duration

        # A reliable writer resends until each reader acknowledges: wait for
        # that, or a process that exits at once can take the zero command with
        # it. Fast DDS resends a sample a reader missed at its next heartbeat,
        # every 3 s by default: a loaded machine took 0.6-2.6 s for 5 of 20
        # zero commands (1 s lost one of tests/test_backends.py's signal runs).
        # A best-effort writer, or one with no reader, returns at once.
        self.zero_acknowledged = bool(
            self.publisher.wait_for_all_acked(Duration(seconds=ZERO_ACK_WAIT))
        )
        if not self.zero_acknowledged:
            print(
                f"ros2: the zero command on '{self.settings.cmd_vel}' was not acknowledged "
                f"within {ZERO_ACK_WAIT:g} s: check that the robot stopped",
                file=sys.stderr,
            )

    def report(self) -> dict[str, Any]:
        return {
            **self.pace.record(),
            "dropouts": self.dropouts,
            "zero_command_sent": self.zero_sent,
            "zero_command_acknowledged": self.zero_acknowledged,
            **(
                {
                    "plans_taken": self.plans_taken,
                    "plans_refused": self.plans_refused,
                    "plans_stale": self.plans_stale,
                }
                if self.plans is not None
                else {}
            ),
        }

    def describe(self) -> dict[str, Any]:
        return {
            "type": "ros2",
            "versions": versions(),
            "settings": self.settings.model_dump(mode="json", exclude={"type"}),
        }

    # --- the loop's plant and sensors, replaced ----------------------------------------

    def command(
        self, actuation: Actuation, k: int, u: FloatArray, commands: FloatArray, applied: FloatArray
    ) -> None:
        """u_k published (the robot applies it: its own delay and lag)."""
        message = self._twist()
        message.linear.x = float(u[0])
        message.angular.z = float(u[1])
        self.publisher.publish(message)
        self.pace.commanded()
        applied[0] = u[0]
        applied[1] = u[1]

    def next_tick(
        self,
        state: FloatArray,
        applied: FloatArray,
        dt: float,
        actuation: Actuation,
        draws: FloatArray,
    ) -> None:
        """The next tick; the robot's newest pose as the state recorded."""
        self.pace.wait()
        latest = self.latest
        assert latest is not None
        age = self.pace.tick - latest.received
        if age > self.settings.stop_after:
            raise PlantStopped(
                f"measurements stopped: none on '{self.settings.odom}' for {age:.3g} s "
                f"(stop_after {self.settings.stop_after:g} s)"
            )
        self.fresh = age <= self.settings.stale_after
        self._take_pose(state, latest)

    def measure(
        self,
        state: FloatArray,
        k: int,
        sensing: Sensing,
        draws: FloatArray,
        burst: IntArray,
        measurement: FloatArray,
    ) -> bool:
        """The odometry as the measurement; a stale one is a dropout."""
        if not self.fresh:
            self.dropouts += 1
            return False
        measurement[:] = state
        return True

    @staticmethod
    def _take_pose(state: FloatArray, pose: Pose) -> None:
        state[0] = pose.x
        state[1] = pose.y
        state[2] = state[2] + wrap_angle(pose.theta - state[2])  # ours is not wrapped


@contextlib.contextmanager
def open_plant(plan: MissionPlan, settings: Backend) -> Iterator[Ros2Plant]:
    plant = Ros2Plant(plan, settings)
    try:
        plant.wait_for_robot()
        yield plant
    finally:
        plant.stop()
        plant.confirm_stop()
        plant.ros.close()
