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
Describing many gallery objects on every core.

Building a model is dominated by per-object features (FPFH and two hops), computed one object at a
time and single-threaded inside Open3D and numpy for clouds this small, so objects are spread over
worker processes. joblib's loky workers (joblib comes with scikit-learn) start as fresh
interpreters: a plain fork after Open3D has run its OpenMP pool can hang the child, and
multiprocessing's spawn re-runs the caller's script unless it has a __main__ guard. Objects go in
chunks, so the fitted estimators are shipped once per chunk, not once per object. The functions
run in the workers live beside their callers (build.py, instance/calibration.py, ...), at module
level so that they pickle by name.
"""
from __future__ import annotations

import os

from pcrp_core.threads import one_open3d_thread


def default_jobs() -> int:
    return (
        len(os.sched_getaffinity(0)) if hasattr(os, 'sched_getaffinity') else (os.cpu_count() or 1)
    )


def _chunk(fn, state, items):
    # Open3D on one thread: a model's parts come out the same whatever the cores (threads.py)
    with one_open3d_thread():
        return [fn(state, x) for x in items]


def parallel_map(
    fn,
    items,
    state: dict,
    n_jobs: int | None = None,
    progress=None,
    desc: str = '',
    chunksize: int = 16,
):
    """
    [fn(state, item) for item in items], in order, over n_jobs processes (default: every core).

    With one job, or few items, it runs here without processes.
    """
    items = list(items)
    wrap = progress or (lambda it, **_: it)
    n_jobs = default_jobs() if n_jobs is None else max(1, n_jobs)
    if n_jobs == 1 or len(items) < 2 * chunksize:
        return _chunk(fn, state, wrap(items, desc=desc, unit='obj'))
    from joblib import delayed, Parallel
    chunks = [items[i:i + chunksize] for i in range(0, len(items), chunksize)]
    results = Parallel(n_jobs=n_jobs, backend='loky', return_as='generator')(
        delayed(_chunk)(fn, state, c) for c in chunks)
    return [
        r
        for part in wrap(results, desc=desc, unit=f'x{chunksize} obj', total=len(chunks))
        for r in part
    ]
