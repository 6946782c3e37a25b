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
The executor pcrp nodes spin on, and spinning them on a thread of this process.

`pcrp_node` spins on node_executor() until interrupted (spin_until_interrupted); tests, the demo
and the robustness report spin the node next to a client with spinning(), in a context of their
own.
"""
from __future__ import annotations

from contextlib import contextmanager
import signal
import threading
import time

import rclpy
from rclpy.executors import MultiThreadedExecutor
from rclpy.signals import SignalHandlerOptions


# Threads for the callbacks of the nodes an executor spins. Jazzy's rclpy (7.1) hands a callback
# to its thread pool and, until a pool thread starts it, yields it again on every pass of a loop
# that holds the GIL (ros2/rclpy#1452, fixed in rclpy 10). With two threads and four topics, a
# burst of four clouds left two callbacks waiting while the loop spun ~700 times a second, and the
# screening of the other two took 40-50 ms instead of 5. A thread for every callback that can run
# at once (one group per input topic, the reload service, the diagnostics timer, the lifecycle
# services) leaves none waiting. Python starts pool threads only when they are needed, so the cap
# costs nothing until used; it is set well above any number of input topics a node is given (a
# cap of 16 left callbacks waiting from about 14 topics on).
CALLBACK_THREADS = 64


def node_executor(context=None) -> MultiThreadedExecutor:
    """Return the executor to spin pcrp nodes on (see CALLBACK_THREADS)."""
    return MultiThreadedExecutor(num_threads=CALLBACK_THREADS, context=context)


def spin_until_interrupted(executor, step: float = 0.2) -> None:
    """
    Spin the executor on a thread until Ctrl-C or SIGTERM, then stop it; re-raise what it raised.

    The main thread waits, so a signal reaches it at once as KeyboardInterrupt (see
    init_stopping_on_signals) and never inside the executor's own code. The executor looks for
    the stop every step seconds: a wake alone does not end its wait, and rclpy's
    spin_until_future_complete adds a callback to the future at every turn, which a node
    spinning for days would pile up.
    """
    spinner = _Spinner(executor, step)
    # Started inside the try: a Ctrl-C can land while start() waits for the thread, and a thread
    # still in rcl's wait when the interpreter exits aborts it (std::terminate at pthread_exit).
    try:
        spinner.start()
        while not spinner.done.wait(0.5):
            pass
    finally:
        spinner.halt()
    spinner.raise_failure()


class _Spinner(threading.Thread):
    """
    A thread that spins an executor until halted or its context is shut down.

    done is set once it has left the executor: only then may the nodes be destroyed and the
    executor shut down, which destroys what the wait it was in used.
    """

    def __init__(self, executor, step: float):
        super().__init__(name='executor', daemon=True)
        self.executor, self.step = executor, step
        self.done, self._halt = threading.Event(), threading.Event()
        self.failure = None   # what the executor raised, for whoever waits on done to decide

    def run(self):
        try:
            while not self._halt.is_set() and self.executor.context.ok():
                self.executor.spin_once(timeout_sec=self.step)
        except BaseException as e:
            self.failure = e
        finally:
            _wait_for_callbacks(self.executor)
            self.done.set()

    def halt(self) -> None:
        """Tell the thread to stop and wait (5 s at most) until it has left the executor."""
        self._halt.set()
        self.done.wait(5.0)

    def raise_failure(self) -> None:
        if self.failure is not None:
            raise self.failure


def _wait_for_callbacks(executor, timeout: float = 2.0) -> None:
    """
    Wait until the callbacks a multi-threaded executor handed to its threads have returned.

    Executor.shutdown() is meant to, but rclpy 7.1's never waits (it tests its shutdown flag just
    after setting it): a callback taken just before the stop then ran against destroyed nodes
    ('cannot use Destroyable because destruction was requested', a cloud received and never
    counted). The executor keeps them in _futures; nothing public lists them.
    """
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if all(task.done() for task in list(getattr(executor, '_futures', ()))):
            return
        time.sleep(0.01)


def init_stopping_on_signals(args=None) -> None:
    """
    Initialise rclpy for a program whose Ctrl-C and SIGTERM raise KeyboardInterrupt.

    Not rclpy's signal handlers: they shut the context down at Ctrl-C, with the program's
    publishers and subscriptions still in it, and Fast DDS then deletes them against a context
    that is gone. On a loaded machine that crashed the node now and then (SIGSEGV in a DDS thread
    while it destroyed a publisher). Here a signal reaches the main thread only, which stops its
    work, destroys its nodes and shuts the context down last, as ROS 2 expects.
    """
    def interrupt(signum, frame):
        raise KeyboardInterrupt(signal.Signals(signum).name)

    rclpy.init(args=args, signal_handler_options=SignalHandlerOptions.NO)
    signal.signal(signal.SIGTERM, interrupt)
    signal.signal(signal.SIGINT, interrupt)


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
    """
    Spin the nodes until the block ends, then destroy them.

    What a callback raised in the executor's own thread is raised here when the block ends.
    """
    ex = node_executor(ctx)
    for n in nodes:
        ex.add_node(n)
    spinner = _Spinner(ex, 0.1)
    spinner.start()
    try:
        yield ex
    finally:
        spinner.halt()
        ex.shutdown(timeout_sec=2.0)
        for n in nodes:
            n.destroy_node()
    spinner.raise_failure()


def wait_for(predicate, timeout=30.0, step=0.05):
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(step)
    return False
