"""A planner for tests/test_ros2_plans.py: prints "ready" once it publishes on
'plan'; after the first Twist on cmd_vel, publishes the plans given as
arguments (x1,y1;x2,y2;... in frame odom), one every second, then stops
(exits): a planner that stopped."""

import sys
import threading
import time

import rclpy
from geometry_msgs.msg import PoseStamped, Twist
from nav_msgs.msg import Path
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
node = rclpy.create_node("wmr_mission_test_planner")
reliable = QoSProfile(depth=1, reliability=ReliabilityPolicy.RELIABLE)
publisher = node.create_publisher(Path, "plan", reliable)
started = threading.Event()
node.create_subscription(Twist, "cmd_vel", lambda _: started.set(), QoSProfile(depth=10))
executor = SingleThreadedExecutor()
executor.add_node(node)
spinner = threading.Thread(target=executor.spin, daemon=True)
spinner.start()
print("ready", flush=True)
started.wait(60)
for text in sys.argv[1:]:
    time.sleep(1.0)
    message = Path()
    message.header.frame_id = "odom"
    for pair in text.split(";"):
        pose = PoseStamped()
        pose.header.frame_id = "odom"
        pose.pose.position.x, pose.pose.position.y = (float(v) for v in pair.split(","))
        message.poses.append(pose)
    publisher.publish(message)
    print("published", flush=True)
time.sleep(0.5)  # the last plan delivered before the planner goes
executor.shutdown()
spinner.join()
node.destroy_node()
rclpy.try_shutdown()
