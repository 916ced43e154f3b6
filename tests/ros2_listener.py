"""A ROS 2 listener for tests/test_backends.py: prints "ready" once subscribed,
"first" when the first Twist on cmd_vel arrives, "many" at the twentieth, and
at SIGTERM the count of Twists heard and the last one, once those on their way
have arrived (a loaded machine delivers the run's last commands after the run
has exited)."""

import signal
import sys
import threading
import time

import rclpy
from geometry_msgs.msg import Twist
from rclpy.executors import SingleThreadedExecutor
from rclpy.qos import QoSProfile, ReliabilityPolicy
from rclpy.signals import SignalHandlerOptions

# Said once this many have arrived: the run is well under way (its first rows
# recorded), however long its first samples took on a busy machine.
MANY = 20
heard: list[tuple[float, float]] = []
done = threading.Event()
signal.signal(signal.SIGTERM, lambda *_: done.set())
rclpy.init(signal_handler_options=SignalHandlerOptions.NO)
node = rclpy.create_node("wmr_mission_test_listener")
qos = QoSProfile(depth=100, reliability=ReliabilityPolicy.RELIABLE)


def hear(message: Twist) -> None:
    heard.append((message.linear.x, message.angular.z))
    if len(heard) == 1:
        print("first", flush=True)
    if len(heard) == MANY:
        print("many", flush=True)


node.create_subscription(Twist, "cmd_vel", hear, qos)
executor = SingleThreadedExecutor()
executor.add_node(node)
spinner = threading.Thread(target=executor.spin, daemon=True)
spinner.start()
print("ready", flush=True)
done.wait()
# Heard on: until nothing more has arrived for half a second (5 s at most).
give_up = time.monotonic() + 5.0
while time.monotonic() < give_up:
    count = len(heard)
    time.sleep(0.5)
    if len(heard) == count:
        break
executor.shutdown()
spinner.join()
v, omega = heard[-1] if heard else (float("nan"), float("nan"))
print(f"heard {len(heard)} last {v!r} {omega!r}", flush=True)
node.destroy_node()
rclpy.try_shutdown()
sys.exit(0)
