# Copyright 2026 The pcrp authors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""
Spin a node (or several) on an executor thread of this process, in a context of their own.

This is how tests, the demo and the robustness report run the node next to a client.
"""
from __future__ import annotations

from contextlib import contextmanager
import threading
import time

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
