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
Where a cloud's pose is estimated: in the node's own process, or in a worker process.

A worker process is started with multiprocessing's spawn method (a fresh interpreter: forking
a process that runs DDS threads and Open3D's OpenMP pool can hang the child), loads its own
copy of the model from the model path and answers one cloud at a time over a pipe. Settings
travel with each cloud, so a parameter changed on the node reaches every worker with the next
cloud. Nothing here imports ROS.
"""

from __future__ import annotations

import multiprocessing
import os
import signal
import threading
import time

from pcrp_core import InvalidCloud


# One thread per worker: workers are meant one per core, and the core is as fast single-threaded
# (docs/results/BENCHMARKS.md). Thread pools are sized when numpy and Open3D load, so this is set
# in the environment a worker starts with; a value the user exported is kept.
THREAD_VARIABLES = ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS')
_ENVIRONMENT = threading.Lock()


class WorkerDied(RuntimeError):
    """A worker process ended while it held a cloud (killed, out of memory, a crash)."""


class WorkerStartError(RuntimeError):
    """A worker process could not load its model."""


class LocalEstimator:
    """Estimates in the calling thread with the node's own model (the `workers: 1` case)."""

    pid = None

    def __init__(self, model):
        self.model = model

    def estimate(self, points, viewpoint, up, params, scene=None):
        # the node sets its model's parameters itself when they change; params is for workers
        return self.model.estimate(points, viewpoint=viewpoint, up=up, scene=scene)

    def close(self):
        pass


def _worker_main(conn, model_path, params):
    """Body of a worker process: load, say ready, then answer clouds until the pipe closes."""
    # Ctrl-C in a terminal reaches the whole process group; the node stops its workers itself
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    try:
        from pcrp_core import PCRP

        model = PCRP.load(model_path or None)
        model.set_params(**params).warm()
    except Exception as e:  # reported to the node, which decides
        conn.send(('error', f'{type(e).__name__}: {e}'))
        return
    current = dict(params)
    conn.send(('ready', os.getpid()))
    while True:
        try:
            task = conn.recv()
        except (EOFError, OSError):
            return
        if task is None:
            return
        points, viewpoint, up, params, scene = task
        try:
            if params != current:
                model.set_params(**params)
                current = dict(params)
            conn.send(('ok', model.estimate(points, viewpoint=viewpoint, up=up, scene=scene)))
        except InvalidCloud as e:
            conn.send(('invalid', e.reason, str(e)))
        except Exception as e:  # one cloud must not end the worker
            conn.send(('error', f'{type(e).__name__}: {e}'))


class ProcessEstimator:
    """One worker process holding its own copy of the model."""

    def __init__(self, model_path: str, params: dict, wait: bool = True):
        """Start the worker; with wait, also wait until it has loaded its model."""
        ctx = multiprocessing.get_context('spawn')
        self._conn, child = ctx.Pipe()
        self._proc = ctx.Process(target=_worker_main, args=(child, model_path, params),
                                 name='pcrp_worker', daemon=True)
        with _ENVIRONMENT:   # spawn hands the child the environment as it is at start()
            added = [v for v in THREAD_VARIABLES if v not in os.environ]
            os.environ.update({v: '1' for v in added})
            try:
                self._proc.start()
            finally:
                for v in added:
                    os.environ.pop(v, None)
        child.close()
        self.pid = None
        if wait:
            self.wait_ready()

    def wait_ready(self, timeout: float = 300.0) -> None:
        """Wait until the worker has loaded its model; WorkerStartError if it could not."""
        try:
            reply = self._receive(timeout)
        except WorkerDied as e:
            self.close()
            raise WorkerStartError(f'worker process did not start: {e}') from None
        if reply[0] != 'ready':
            self.close()
            raise WorkerStartError(f'worker process could not load the model: {reply[1]}')
        self.pid = reply[1]

    def _receive(self, timeout: float | None = None):
        end = None if timeout is None else time.monotonic() + timeout
        while not self._conn.poll(0.2):
            if not self._proc.is_alive():
                # a reply sent just before the end is still in the pipe
                if self._conn.poll(0):
                    break
                raise WorkerDied(f'worker process {self._proc.pid} ended '
                                 f'(exit code {self._proc.exitcode})')
            if end is not None and time.monotonic() > end:
                raise WorkerDied(f'worker process {self._proc.pid} gave no answer '
                                 f'within {timeout:g} s')
        try:
            return self._conn.recv()
        except (EOFError, OSError):
            raise WorkerDied(f'worker process {self._proc.pid} ended '
                             f'(exit code {self._proc.exitcode})') from None

    def estimate(self, points, viewpoint, up, params, scene=None):
        """
        Return the worker's PoseResult; raise InvalidCloud as the model did, or WorkerDied.

        scene: what of the depth cloud the estimate can use (PCRP.scene_in_reach), not all of it.
        """
        try:
            self._conn.send((points, viewpoint, up, params, scene))
        except (BrokenPipeError, OSError):
            raise WorkerDied(f'worker process {self._proc.pid} ended '
                             f'(exit code {self._proc.exitcode})') from None
        reply = self._receive()
        if reply[0] == 'ok':
            return reply[1]
        if reply[0] == 'invalid':
            raise InvalidCloud(reply[1], reply[2])
        raise RuntimeError(reply[1])

    def alive(self) -> bool:
        return self._proc.is_alive()

    def close(self, timeout: float = 5.0):
        """Ask the worker to finish, then make sure it has."""
        try:
            self._conn.send(None)
        except (BrokenPipeError, OSError):
            pass
        self._proc.join(timeout)
        if self._proc.is_alive():
            self._proc.terminate()
            self._proc.join(2.0)
        if self._proc.is_alive():
            self._proc.kill()
            self._proc.join(2.0)
        self._conn.close()
