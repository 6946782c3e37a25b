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
How many threads Open3D may use.

Open3D runs its parallel loops on oneTBB, which ignores OMP_NUM_THREADS: a process told to use
one thread (a node's worker, a benchmark timing one core) still ran Open3D's ICP and ray
casting on every core. And a parallel ICP sums its residuals in whatever order its threads
finish, so the same cloud could come out differently by 1e-17, which a few hypotheses later is
another pose or, at build, another learnt confidence. One Open3D thread is repeatable.
"""
from __future__ import annotations

from contextlib import contextmanager
import os


def _limit(n: int) -> None:
    import open3d as o3d

    # an Open3D without the setting (0.20 has it) is left as it is
    setter = getattr(o3d.utility, 'set_max_threads', None)
    if setter is not None:
        setter(n)


def threads_from_environment() -> None:
    """Hold Open3D to OMP_NUM_THREADS when it is set: the one variable that bounds the rest."""
    value = os.environ.get('OMP_NUM_THREADS', '').strip()
    if value.isdigit() and int(value) >= 1:
        _limit(int(value))


@contextmanager
def one_open3d_thread():
    """Run the block with Open3D on one thread (repeatable results), then as it was."""
    import open3d as o3d

    getter = getattr(o3d.utility, 'get_max_threads', None)
    before = getter() if getter is not None else 0
    _limit(1)
    try:
        yield
    finally:
        _limit(before)
