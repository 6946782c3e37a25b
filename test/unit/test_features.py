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

"""The feature stages on their own: invariance, reconstruction, determinism."""
from helpers import MODELNET, modelnet, random_pose
import numpy as np
from pcrp_core.features import PointHop
from pcrp_core.features.lrf import local_frames
from pcrp_core.features.neighbours import knn
from pcrp_core.features.saab import ChannelwiseSaab, Saab
from pcrp_core.preprocess import farthest_point_sampling
import pytest

pytestmark = pytest.mark.skipif(not MODELNET.exists(), reason='needs ../shared/data/modelnet40')


@pytest.fixture(scope='module')
def clouds():
    return list(modelnet('chair', count=12)[0]) + list(modelnet('airplane', count=12)[0])


def test_saab_keeping_every_kernel_reconstructs_exactly():
    rng = np.random.default_rng(0)
    X = rng.normal(size=(400, 9)) @ rng.normal(size=(9, 9)) + 2.0
    saab = Saab(energy_threshold=0.0).fit(X)
    assert saab.n_components_ == 9
    np.testing.assert_allclose(saab.kernels_ @ saab.kernels_.T, np.eye(9), atol=1e-10)
    np.testing.assert_allclose(saab.inverse_transform(saab.transform(X)), X, atol=1e-9)
    # the first kernel is the constant (DC) direction
    np.testing.assert_allclose(np.abs(saab.kernels_[0]), 1 / 3.0)


def test_saab_threshold_drops_low_energy_kernels_and_energies_sum_to_one():
    rng = np.random.default_rng(1)
    X = np.column_stack([rng.normal(scale=s, size=500) for s in (5, 3, 1, 0.01, 0.001)])
    saab = Saab(energy_threshold=1e-3).fit(X)
    assert saab.energy_ratio_.sum() == pytest.approx(1.0)
    assert 2 <= saab.n_components_ < 5
    partial = saab.inverse_transform(saab.transform(X))
    assert np.mean((partial - X) ** 2) < 1e-2 * np.mean((X - X.mean(0)) ** 2)


def test_channelwise_saab_keeps_more_of_energetic_channels():
    rng = np.random.default_rng(2)
    X = rng.normal(size=(300, 8, 2)) * np.array([10.0, 0.1])
    cw = ChannelwiseSaab(energy_threshold=1e-3).fit(X, parent_energy=np.array([0.99, 0.01]))
    assert cw.saabs_[0].n_components_ > cw.saabs_[1].n_components_
    assert cw.transform(X).shape == (300, cw.n_components_)


def test_farthest_point_sampling_does_not_depend_on_pose_or_order(clouds):
    p = clouds[0]
    rng = np.random.default_rng(3)
    R, t = random_pose(rng)
    perm = rng.permutation(len(p))
    a = farthest_point_sampling(p, 256)
    b = farthest_point_sampling((p @ R.T + t)[perm], 256)
    assert len(set(a.tolist())) == 256
    assert set(a.tolist()) == set(perm[b].tolist())


def test_local_frames_are_proper_rotations_that_rotate_with_the_cloud(clouds):
    p = clouds[1]
    R, _ = random_pose(np.random.default_rng(4))
    nb = knn(p, p, 32)
    F = local_frames(p, p, nb, p.mean(0))
    F2 = local_frames(p @ R.T, p @ R.T, nb, (p @ R.T).mean(0))
    np.testing.assert_allclose(np.linalg.det(F), 1.0, atol=1e-9)
    # a frame rotates with the cloud: F2 = F @ R^T, for all but sign-ambiguous points
    agree = np.all(np.abs(F2 - F @ R.T) < 1e-6, axis=(1, 2))
    assert agree.mean() > 0.97


@pytest.mark.parametrize('hop1', ['fpfh', 'octant'])
def test_point_features_are_rotation_invariant(clouds, hop1):
    ph = PointHop(hop1=hop1).fit(clouds[2:])
    assert 100 <= ph.n_features_ <= 300
    p = clouds[0]
    rng = np.random.default_rng(5)
    R, t = random_pose(rng)
    perm = rng.permutation(len(p))
    s1, f1 = ph.transform(p)
    s2, f2 = ph.transform((p @ R.T + t)[perm])
    assert f1.shape == (512, ph.n_features_)
    by_index = dict(zip(perm[s2].tolist(), f2))
    f2_aligned = np.stack([by_index[i] for i in s1.tolist()])
    rel = np.linalg.norm(f1 - f2_aligned, axis=1) / np.linalg.norm(f1, axis=1)
    assert np.median(rel) < 0.01
    # and they are informative: features of different points differ far more
    spread = (
        np.linalg.norm(f1[:, None] - f1[None, :50], axis=2).mean()
        / np.linalg.norm(f1, axis=1).mean()
    )
    assert spread > 0.2
