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

"""Which axis map lays one gallery object on another (pcrp_core/category/frames.py)."""

import numpy as np
from pcrp_core.category import frames
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation


def _box(n: int = frames.POINTS) -> np.ndarray:
    # three distinct extents and a knob on one corner: every axis map but the identity moves it
    rng = np.random.default_rng(0)
    box = rng.uniform(-1, 1, (n, 3)) * [1.0, 0.4, 0.2]
    box[: n // 4] = [0.9, 0.35, 0.15] + rng.normal(scale=0.05, size=(n // 4, 3))
    return box


def _index(M: np.ndarray) -> int:
    return [np.allclose(A, M, atol=1e-9) for A in frames.AXIS_ROTATIONS].index(True)


def test_the_chamfers_find_the_axis_turn_between_two_copies_of_an_object():
    box = _box()
    quarter = _index(Rotation.from_euler('z', 90, degrees=True).as_matrix())
    gallery = np.stack([box, box @ frames.AXIS_ROTATIONS[quarter].T])
    cost = frames.chamfer_by_rotation(box, gallery, [cKDTree(c) for c in gallery])
    assert cost.argmin(1).tolist() == [frames.IDENTITY, quarter]


def test_axis_turn_lays_a_cloud_on_a_turned_and_moved_copy_of_itself():
    box = _box(1024)
    half = Rotation.from_euler('x', 180, degrees=True).as_matrix()
    moved = box @ half.T + [5.0, -2.0, 1.0]
    np.testing.assert_allclose(frames.axis_turn(box, moved), half, atol=1e-9)
    np.testing.assert_allclose(frames.axis_turn(box, box + 3.0), np.eye(3), atol=1e-9)
    # a small object (fewer points than the chamfers use) is measured too
    np.testing.assert_allclose(frames.axis_turn(box[:40], moved[:40]), half, atol=1e-9)
