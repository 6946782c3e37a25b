"""A node (or several) spinning on their own executor thread in this process, in a context of
their own: how tests, the demo and the robustness report run the node next to a client."""
from __future__ import annotations

import threading
import time
from contextlib import contextmanager

import rclpy
from rclpy.executors import MultiThreadedExecutor


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
    """Spin the nodes until the block ends, then destroy them."""
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
