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

"""Cleaning a cloud: the fast duplicate tests keep exactly what numpy's row-wise unique keeps."""
import numpy as np
from pcrp_core import InvalidCloud
from pcrp_core.preprocess import _first_of_each_row, check_geometry, merge_duplicates
import pytest


def _merged_by_rows(points, resolution=0.005):
    radius = np.sqrt(((points - points.mean(axis=0)) ** 2).sum(axis=1).mean())
    keys = np.floor((points - points.min(axis=0)) / (resolution * radius)).astype(np.int64)
    return points[np.sort(np.unique(keys, axis=0, return_index=True)[1])]


def test_merging_keeps_the_rows_a_row_wise_unique_keeps():
    rng = np.random.default_rng(0)
    points = np.round(rng.normal(size=(3000, 3)), 2)
    points = np.vstack([points, points[:700] + 1e-4])
    rng.shuffle(points)
    merged = merge_duplicates(points)
    assert len(merged) < len(points) - 600
    np.testing.assert_array_equal(merged, _merged_by_rows(points))


@pytest.mark.parametrize('high', [50, 2 ** 40])
def test_first_of_each_row_is_numpys_row_wise_unique(high):
    # 2 ** 40: the rows no longer fold into one integer, and numpy's own unique answers
    rng = np.random.default_rng(high)
    rows = rng.integers(0, high, size=(2000, 3))
    rows = np.vstack([rows, rows[rng.integers(0, 2000, 900)]])
    np.testing.assert_array_equal(_first_of_each_row(rows),
                                  np.unique(rows, axis=0, return_index=True)[1])


def test_negative_zero_is_the_same_point_as_zero():
    corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    check_geometry(corners, 4)
    with pytest.raises(InvalidCloud) as refused:
        check_geometry(np.vstack([corners[:3], [[-0.0, 0.0, -0.0]]]), 4)
    assert refused.value.reason == 'too_few_points'
