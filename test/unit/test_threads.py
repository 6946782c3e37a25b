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

"""Open3D's threads: held to OMP_NUM_THREADS when a model is made, one while building."""
import open3d as o3d
from pcrp_core.threads import one_open3d_thread, threads_from_environment
import pytest


@pytest.fixture
def open3d_unbounded():
    o3d.utility.set_max_threads(0)
    yield
    o3d.utility.set_max_threads(0)


def test_omp_num_threads_bounds_open3d_too(monkeypatch, open3d_unbounded):
    # oneTBB reads no environment variable: a worker told one thread ran Open3D on every core
    monkeypatch.setenv('OMP_NUM_THREADS', '1')
    threads_from_environment()
    assert o3d.utility.get_max_threads() == 1


def test_without_the_variable_open3d_keeps_its_threads(monkeypatch, open3d_unbounded):
    monkeypatch.delenv('OMP_NUM_THREADS', raising=False)
    every = o3d.utility.get_max_threads()
    threads_from_environment()
    assert o3d.utility.get_max_threads() == every


def test_one_thread_for_a_block_then_as_it_was(open3d_unbounded):
    every = o3d.utility.get_max_threads()
    if every < 2:
        pytest.skip('one core: one thread is all Open3D has anyway')
    with one_open3d_thread():
        assert o3d.utility.get_max_threads() == 1
    assert o3d.utility.get_max_threads() == every
