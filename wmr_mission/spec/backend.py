"""The mission's `backend:` section: which plant runs the mission, and how a
robot behind ROS 2 is reached (docs/backends.md)."""

from __future__ import annotations

from typing import Annotated, Literal

from pydantic import Field, model_validator

from wmr_mission.fields import Duration, Model

# A ROS 2 topic or frame name: letters, digits, '_' and '/' (relative or absolute).
ROS_NAME = r"^/?[A-Za-z_][A-Za-z0-9_]*(/[A-Za-z_][A-Za-z0-9_]*)*$"
RosName = Annotated[str, Field(pattern=ROS_NAME, max_length=256)]
Reliability = Literal["reliable", "best_effort"]


class Backend(Model):
    """Where the mission's plant is: our simulator, IR-SIM, or a robot over ROS 2."""

    type: Literal["sim", "irsim", "ros2"] = Field(
        default="sim",
        description=(
            "sim: our simulator (eq. (1), compiled); irsim: IR-SIM's differential-drive "
            "robot as the true plant; ros2: a robot (or `wmr-mission serve-robot`) over ROS 2, "
            "in real time. `run --backend` overrides it."
        ),
    )
    cmd_vel: RosName = Field(
        default="cmd_vel", description="ros2: topic of the commands (geometry_msgs/Twist)."
    )
    odom: RosName = Field(
        default="odom", description="ros2: topic of the measurements (nav_msgs/Odometry)."
    )
    frame_id: RosName = Field(
        default="odom", description="ros2: the odometry's frame (serve-robot publishes it)."
    )
    child_frame_id: RosName = Field(
        default="base_link", description="ros2: the robot's frame (serve-robot publishes it)."
    )
    cmd_vel_reliability: Reliability = Field(
        default="reliable",
        description="ros2: QoS reliability of cmd_vel (reliable reaches either kind of reader).",
    )
    odom_reliability: Reliability = Field(
        default="best_effort",
        description="ros2: QoS reliability of odom (best_effort hears either kind of writer).",
    )
    stale_after: Duration = Field(
        default=0.1, description="[s] ros2: an older measurement counts as a dropout."
    )
    stop_after: Duration = Field(
        default=0.5,
        description="[s] ros2: this long without a measurement, the run stops, failed.",
    )
    plan: RosName | None = Field(
        default=None,
        description=(
            "ros2: topic of a planner's plans (nav_msgs/Path): each new plan replaces the path "
            "of the track phase in force (docs/backends.md, 'A planner over ROS 2')."
        ),
    )
    plan_reliability: Reliability = Field(
        default="reliable", description="ros2: QoS reliability of the plans (depth 1)."
    )
    goal: RosName | None = Field(
        default=None,
        description=(
            "ros2: topic of a planner's goals (geometry_msgs/PoseStamped, in frame_id): a "
            "regulate phase takes each as its new target, a track phase a straight route "
            "from the estimate to it, at plan_speed (docs/backends.md, 'A planner over ROS 2')."
        ),
    )
    goal_reliability: Reliability = Field(
        default="reliable", description="ros2: QoS reliability of the goals (depth 1)."
    )
    plan_speed: Duration = Field(
        default=0.5,
        description="[m/s] ros2: the speed a plan's (or goal's) route is followed at, > 0.",
    )
    plan_stale_after: Duration | None = Field(
        default=None,
        description=(
            "[s] ros2: this long without a new plan or goal (from the run's start, then from "
            "the last taken), the planner counts as quiet and on_plan_stale follows; "
            "null: never."
        ),
    )
    on_plan_stale: Literal["keep", "hold", "fail"] = Field(
        default="keep",
        description=(
            "ros2: when the planner goes quiet: keep the reference in force (and say so), "
            "hold the estimated pose until the next plan or goal, or fail the run."
        ),
    )
    wait_for_robot: Duration = Field(
        default=10.0,
        description="[s] ros2: the longest wait for the first measurement before the run.",
    )

    @model_validator(mode="after")
    def _stop_after_stale(self) -> Backend:
        if self.stop_after <= self.stale_after:
            raise ValueError(
                f"stop_after ({self.stop_after:g} s) must be longer than "
                f"stale_after ({self.stale_after:g} s)"
            )
        if self.on_plan_stale != "keep" and self.plan_stale_after is None:
            raise ValueError(
                f"on_plan_stale: {self.on_plan_stale} needs plan_stale_after, the seconds "
                "without a plan or goal after which the planner counts as quiet"
            )
        return self
