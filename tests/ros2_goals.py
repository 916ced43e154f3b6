"""A planner of goals for tests/test_ros2_plans.py: prints "ready" once it
publishes on 'goal', then publishes the goals given as arguments
(x,y,theta@N, in frame odom), each once it has heard N Twists on cmd_vel,
then stops (exits).

Counted in the run's commands, one a sample, not in seconds: the run is at
its N-th sample or later then, whatever its lateness. A loaded machine's run
falls behind the wall clock (a late sample delays the schedule after it), and
a goal sent 4 s after the first Twist came while the run was still in its
first 3 s."""

import math
import sys
import threading
import time

import rclpy
from geometry_msgs.msg import PoseStamped, Twist
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
node = rclpy.create_node("wmr_mission_test_goals")
reliable = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
publisher = node.create_publisher(PoseStamped, "goal", reliable)
heard = [0]
counted = threading.Condition()


def hear(_: Twist) -> None:
    with counted:
        heard[0] += 1
        counted.notify_all()


node.create_subscription(Twist, "cmd_vel", hear, QoSProfile(depth=10))
executor = SingleThreadedExecutor()
executor.add_node(node)
spinner = threading.Thread(target=executor.spin, daemon=True)
spinner.start()
print("ready", flush=True)
for text in sys.argv[1:]:
    pose_text, at = text.split("@")
    x, y, theta = (float(v) for v in pose_text.split(","))
    with counted:
        counted.wait_for(lambda n=int(at): heard[0] >= n, timeout=60)
    message = PoseStamped()
    message.header.frame_id = "odom"
    message.pose.position.x, message.pose.position.y = x, y
    message.pose.orientation.z = math.sin(theta / 2)
    message.pose.orientation.w = math.cos(theta / 2)
    publisher.publish(message)
    print("published", flush=True)
time.sleep(0.5)  # the last goal delivered before the planner goes
executor.shutdown()
spinner.join()
node.destroy_node()
rclpy.try_shutdown()
