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

"""VLAD and max pooling: shapes, normalisation, order invariance."""
import numpy as np
from pcrp_core.gallery import Gallery
from pcrp_core.vlad import VLAD
import pytest


@pytest.fixture(scope='module')
def data():
    rng = np.random.default_rng(0)
    centres = rng.normal(scale=5, size=(4, 6))
    feats = np.concatenate([c + rng.normal(size=(200, 6)) for c in centres]).astype(np.float32)
    return feats, rng


def test_vlad_vector_is_unit_length_and_sized_k_times_d(data):
    feats, rng = data
    vlad = VLAD(n_clusters=4).fit(feats)
    v = vlad.transform(feats[rng.permutation(len(feats))[:300]])
    assert v.shape == (24,)
    assert np.linalg.norm(v) == pytest.approx(1.0, abs=1e-5)


def test_vlad_ignores_point_order_and_tells_different_sets_apart(data):
    feats, rng = data
    vlad = VLAD(n_clusters=4).fit(feats)
    a = feats[:400]
    np.testing.assert_allclose(
        vlad.transform(a), vlad.transform(a[rng.permutation(400)]), atol=1e-6
    )
    b = feats[400:]
    assert np.linalg.norm(vlad.transform(a) - vlad.transform(b)) > 0.3


def test_max_pooling_is_the_normalised_channel_maximum(data):
    feats, _ = data
    v = VLAD(aggregation='max').transform(feats)
    np.testing.assert_allclose(v, feats.max(0) / np.linalg.norm(feats.max(0)), rtol=1e-5)


def test_gallery_search_returns_nearest_first_with_distances():
    rng = np.random.default_rng(1)
    vecs = rng.normal(size=(50, 8)).astype(np.float32)
    g = Gallery([f'o{i}' for i in range(50)], ['c'] * 50, [np.zeros((3, 3))] * 50, vecs)
    idx, dist = g.search(vecs[17] + 1e-3, 5)
    assert idx[0] == 17
    assert np.all(np.diff(dist) >= 0)
    brute = np.sort(np.linalg.norm(vecs - (vecs[17] + 1e-3), axis=1))[:5]
    np.testing.assert_allclose(dist, brute, rtol=1e-4, atol=1e-5)
