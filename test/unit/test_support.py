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

"""What support() sets aside of a view of an object on a table, and what it never touches."""
import numpy as np
from pcrp_core.support import FLAT, LAYER, support

UP = np.array([0.0, -0.6, -0.8])    # the table's normal in a camera frame looking down at it


def _frame():
    """Return two unit vectors along the table, square to UP."""
    a = np.cross(UP, [1.0, 0.0, 0.0])
    a /= np.linalg.norm(a)
    return a, np.cross(UP, a)


def _box(height, n=2000, seed=0):
    """Return points on the sides and top of a 6 cm box standing on the table (height 0)."""
    rng = np.random.default_rng(seed)
    a, b = _frame()
    u, v = rng.uniform(-0.03, 0.03, (2, n))
    h = rng.uniform(0.0, height, n)
    side = rng.random(n) < 0.7
    h[~side] = height
    u[side] = 0.03
    return np.outer(u, a) + np.outer(v, b) + np.outer(h, UP)


def _ring(n=200, seed=1):
    """Return the table just around the box's foot, measured with 1.5 mm of noise."""
    rng = np.random.default_rng(seed)
    a, b = _frame()
    angle = rng.uniform(0, 2 * np.pi, n)
    r = 0.045 + rng.uniform(0, 0.005, n)
    return (np.outer(r * np.cos(angle), a) + np.outer(r * np.sin(angle), b)
            + np.outer(rng.normal(0, 0.0015, n), UP))


def test_the_table_around_the_foot_is_set_aside_with_the_strip_of_the_object_that_low():
    box, ring = _box(0.1), _ring()
    apart, top = support(np.vstack([box, ring]), UP)
    assert apart[len(box):].mean() > 0.95
    # of the object, only what lies that close to the table
    low = box @ UP < top
    assert top < 1.5 * LAYER and not apart[:len(box)][~low].any()
    assert apart[:len(box)].mean() < 0.1


def test_a_clean_view_loses_only_its_foot_strip():
    box = _box(0.1)
    apart, top = support(box, UP)
    assert apart.any() and np.all(box[apart] @ UP < top) and top < 1.5 * LAYER


def test_a_flat_object_is_left_whole():
    flat = _box(0.6 * FLAT)
    apart, top = support(np.vstack([flat, _ring()]), UP)
    assert not apart.any() and top is None


def test_a_speck_below_the_table_does_not_set_the_level():
    box, ring = _box(0.1), _ring()
    speck = -0.05 * UP + np.random.default_rng(3).normal(0, 0.005, (10, 3))
    apart, top = support(np.vstack([box, ring, speck]), UP)
    assert apart[len(box):].mean() > 0.95 and top > 0.0


def test_no_points_no_layer():
    apart, top = support(np.zeros((0, 3)), UP)
    assert apart.shape == (0,) and top is None


def _cut_face(n=3000, seed=4):
    """Return a box's face whose foot something in front hides, along a slanting edge."""
    rng = np.random.default_rng(seed)
    a, _ = _frame()
    u, h = rng.uniform(-0.03, 0.03, n), rng.uniform(0.0, 0.1, n)
    seen = h > 0.02 + 0.5 * (u + 0.03)
    return np.outer(u[seen], a) + np.outer(h[seen], UP)


def test_a_lowest_band_that_is_not_crowded_is_the_object_and_left_whole():
    # the lowest of the face is a corner of it: fewer points at the bottom than just above
    face = _cut_face()
    apart, top = support(face, UP)
    assert not apart.any() and top is None
