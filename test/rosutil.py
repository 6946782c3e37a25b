"""Running the node for real over DDS inside a test: own ROS domain, own executor thread."""
import os
import threading
import time
from contextlib import contextmanager

import rclpy
from rclpy.executors import MultiThreadedExecutor

# a domain of our own, so parallel runs and other ROS processes on the machine stay apart
os.environ.setdefault("ROS_DOMAIN_ID", str(100 + os.getpid() % 100))
os.environ.setdefault("ROS_LOCALHOST_ONLY", "1")


@contextmanager
def ros_context():
    ctx = rclpy.context.Context()
    rclpy.init(context=ctx)
    try:
        yield ctx
    finally:
        rclpy.try_shutdown(context=ctx)


@contextmanager
def spinning(ctx, *nodes):
    ex = MultiThreadedExecutor(num_threads=2, context=ctx)
    for n in nodes:
        ex.add_node(n)
    thread = threading.Thread(target=ex.spin, daemon=True)
    thread.start()
    try:
        yield ex
    finally:
        ex.shutdown(timeout_sec=2.0)
        for n in nodes:
            n.destroy_node()


def wait_for(predicate, timeout=30.0, step=0.05):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return False
