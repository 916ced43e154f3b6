"""A planner of goals for tests/test_ros2_plans.py: prints "ready" once it
publishes on 'goal'; after the first Twist on cmd_vel, publishes the goals
given as arguments (x,y,theta@seconds, in frame odom, each that long after
the first Twist), then stops (exits)."""

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
started = threading.Event()
node.create_subscription(Twist, "cmd_vel", lambda _: started.set(), QoSProfile(depth=10))
executor = SingleThreadedExecutor()
executor.add_node(node)
spinner = threading.Thread(target=executor.spin, daemon=True)
spinner.start()
print("ready", flush=True)
started.wait(60)
first = time.monotonic()
for text in sys.argv[1:]:
    pose_text, at = text.split("@")
    x, y, theta = (float(v) for v in pose_text.split(","))
    time.sleep(max(0.0, first + float(at) - time.monotonic()))
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
