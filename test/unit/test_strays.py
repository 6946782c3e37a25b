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

"""What strays() sets aside of a camera's view, and what it never touches."""
import numpy as np
from pcrp_core.strays import FAR_SHARE, SMALL_SHARE, SPECK, strays

REACH = 0.3     # the largest gallery object's diameter, metres


def _patch(n_side=40, size=0.1, z=0.6, x0=0.0):
    """Return a 10 cm square seen face on at 0.6 m, jittered as a depth camera measures it."""
    u = np.linspace(0.0, size, n_side)
    g = np.stack(np.meshgrid(u, u), -1).reshape(-1, 2)
    rng = np.random.default_rng(0)
    return np.column_stack([g[:, 0] + x0, g[:, 1], np.full(len(g), z)]) + rng.normal(
        0, 0.0005, (len(g), 3))


def _blob(centre, k, seed=1):
    return np.asarray(centre) + np.random.default_rng(seed).normal(0, 0.005, (k, 3))


def test_a_clean_view_loses_nothing():
    assert not strays(_patch(), REACH).any()


def test_a_blob_behind_the_object_is_set_aside_and_nothing_else():
    view = np.vstack([_patch(), _blob([0.05, 0.05, 1.4], 20)])
    apart = strays(view, REACH)
    assert apart[-20:].all() and not apart[:-20].any()


def test_lone_points_between_the_edge_and_the_background_are_specks():
    # flying pixels: alone, a few centimetres off the object's edge
    rng = np.random.default_rng(2)
    flying = np.column_stack([np.full(6, 0.1), rng.uniform(0, 0.1, 6), rng.uniform(0.65, 1.2, 6)])
    view = np.vstack([_patch(), flying[np.argsort(flying[:, 1])][::1]])
    assert strays(view, REACH)[-6:].all()
    # a speck is at most SPECK points; a larger group near the object is kept
    near = _blob([0.12, 0.05, 0.6], 3 * SPECK)
    assert not strays(np.vstack([_patch(), near]), REACH).any()


def test_a_part_cut_off_by_an_occluder_is_kept():
    # two halves of a view with an occluder's 5 cm shadow between them: both large
    view = np.vstack([_patch(x0=0.0), _patch(x0=0.15)])
    assert not strays(view, REACH).any()


def test_a_small_group_is_set_aside_only_when_far_for_the_object_size():
    body = _patch()
    n_small = int(0.6 * SMALL_SHARE * len(body))
    size = np.linalg.norm(np.ptp(body, axis=0))
    near = _blob([0.05 + 0.05 + 0.5 * FAR_SHARE * size, 0.05, 0.6], n_small)
    far = _blob([0.05 + 0.05 + 2.0 * FAR_SHARE * size, 0.05, 0.6], n_small)
    assert not strays(np.vstack([body, near]), REACH).any()
    assert strays(np.vstack([body, far]), REACH)[-n_small:].all()


def test_beyond_reach_even_a_large_group_is_set_aside():
    body = _patch()
    big = _patch(n_side=20, size=0.05, x0=0.1 + REACH + 0.05)
    apart = strays(np.vstack([body, big]), REACH)
    assert apart[len(body):].all() and not apart[:len(body)].any()
    # within reach the same group is another part of the object
    near = _patch(n_side=20, size=0.05, x0=0.14)
    assert not strays(np.vstack([body, near]), REACH).any()


def test_a_handful_of_points_is_left_alone():
    assert not strays(_patch(n_side=2), REACH).any()
