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
One loaded model and what answers with it: the model itself in the node, or worker processes.

The node (answering.py) keeps one Engine and swaps it for a new one when the model is reloaded,
so clouds go on being answered by the old model until the new one has loaded.
"""

from __future__ import annotations

import threading

from pcrp_core import ModelError, PCRP
from pcrp_ros.workers import LocalEstimator, ProcessEstimator, WorkerStartError

# what a failed model load raises: the model's own checks, settings it cannot take, workers
LOAD_ERRORS = (ModelError, ValueError, WorkerStartError, OSError)


class Engine:
    """One loaded model and what answers with it: the model itself, or worker processes."""

    def __init__(self, model, path: str, estimators: list):
        self.model = model
        self.path = path
        self.estimators = estimators
        self.restarts = 0
        self.down = {}            # worker index -> why it is down
        self.retry_at = {}        # worker index -> when to try starting it again
        self._closed = set()
        self._lock = threading.Lock()

    def describe(self) -> str:
        where = self.path or 'the shipped default model'
        return (f'{where} ({len(self.model.gallery_ids)} gallery objects: '
                f"{', '.join(self.model.categories)})")

    def release(self, k: int) -> None:
        """Stop worker k (idempotent); the other workers are left alone."""
        with self._lock:
            if k in self._closed:
                return
            self._closed.add(k)
            estimator = self.estimators[k]
        if estimator is not None:
            estimator.close()

    def close(self) -> None:
        for k in range(len(self.estimators)):
            self.release(k)

    def pids(self) -> list:
        return [getattr(e, 'pid', None) for e in self.estimators]


def load_engine(path: str, params: dict, up, workers: int, model=None) -> Engine:
    """
    Load and check the model at path (or take the given one) and start the workers.

    The settings are applied; LOAD_ERRORS say why not, with nothing left running.
    """
    model = model if model is not None else PCRP.load(path or None)
    model.set_params(**params)
    if up is not None:
        model.check_up(up)
    if workers == 1:
        return Engine(model.warm(), path, [LocalEstimator(model)])
    started = []
    try:
        # started together, so they load side by side
        for _ in range(workers):
            started.append(ProcessEstimator(path, params, wait=False))
        for estimator in started:
            estimator.wait_ready()
    except BaseException:
        for estimator in started:
            estimator.close()
        raise
    return Engine(model, path, started)


class ReloadRequest:
    """A request to switch models; done is set once it succeeded or failed (ok, message)."""

    def __init__(self, path: str, from_parameter: bool):
        self.path = path
        self.from_parameter = from_parameter
        self.done = threading.Event()
        self.ok = False
        self.message = ''

    def finish(self, ok: bool, message: str) -> None:
        self.ok, self.message = ok, message
        self.done.set()
