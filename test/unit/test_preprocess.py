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

"""Cleaning a cloud: duplicates merged by distance, first come first kept, once and for all."""
import numpy as np
from pcrp_core import InvalidCloud
from pcrp_core.preprocess import check_geometry, farthest_point_sampling, merge_duplicates, spread
from pcrp_core.visibility import sphere_directions
import pytest
from scipy.spatial.distance import cdist


def _greedy_by_hand(points, resolution=0.005):
    """Keep each point unless a kept earlier one is that close: the definition, point by point."""
    radius = np.sqrt(((points - points.mean(axis=0)) ** 2).sum(axis=1).mean())
    kept = []
    for p in points:
        if not kept or np.min(cdist([p], kept)) > resolution * radius:
            kept.append(p)
    return np.array(kept)


def test_merging_keeps_what_the_definition_keeps():
    rng = np.random.default_rng(0)
    points = np.round(rng.normal(size=(1500, 3)), 2)
    points = np.vstack([points, points[:400] + 1e-4, points[:200] - 2e-3])
    rng.shuffle(points)
    merged = merge_duplicates(points)
    assert len(merged) < len(points) - 400
    np.testing.assert_array_equal(merged, _greedy_by_hand(points))


def test_a_jittered_cluster_becomes_one_point_and_merging_again_keeps_all():
    # a grid split such clusters at its cell borders and a second pass merged more (the
    # million-point fault case: 338 points, each repeated with 0.1 mm jitter)
    rng = np.random.default_rng(1)
    surface = rng.normal(scale=0.1, size=(300, 3))
    repeated = surface[rng.integers(0, 300, 3000)] + rng.normal(scale=1e-4, size=(3000, 3))
    merged = merge_duplicates(repeated)
    assert len(merged) <= 310
    np.testing.assert_array_equal(merge_duplicates(merged), merged)


def test_a_normally_spaced_cloud_is_not_thinned():
    rng = np.random.default_rng(2)
    points = rng.normal(size=(3000, 3))
    assert len(merge_duplicates(points)) >= 2990


def test_clumps_that_outlast_merging_are_spread_over_not_filled():
    # 300 surface points each repeated with jitter wider than merging's distance: sampling
    # took a point a clump and filled the clumps with the other 724
    rng = np.random.default_rng(3)
    surface = sphere_directions(300)   # evenly spaced, as a sensor grid
    clumped = surface[rng.integers(0, 300, 3000)] + rng.normal(scale=0.005, size=(3000, 3))
    clumped = merge_duplicates(clumped)
    assert len(clumped) > 1500
    kept = spread(clumped, 1024)
    assert len(kept) < 450
    assert cdist(surface, kept).min(axis=1).max() < 0.03   # no clump left out


@pytest.mark.parametrize('cloud', ['surface', 'curve'])
def test_spread_of_an_unclumped_cloud_is_farthest_point_sampling(cloud):
    t = np.linspace(0, 6 * np.pi, 3000)
    curve = np.c_[np.cos(t), np.sin(t), 0.1 * t]
    points = sphere_directions(3000) if cloud == 'surface' else curve
    np.testing.assert_array_equal(
        spread(points, 1024), points[np.sort(farthest_point_sampling(points, 1024))]
    )


def test_negative_zero_is_the_same_point_as_zero():
    corners = np.array([[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]])
    check_geometry(corners, 4)
    with pytest.raises(InvalidCloud) as refused:
        check_geometry(np.vstack([corners[:3], [[-0.0, 0.0, -0.0]]]), 4)
    assert refused.value.reason == 'too_few_points'
