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

"""End to end on real ModelNet40 objects: retrieval, pose, rejection of unusable input."""
import copy
import dataclasses

from helpers import modelnet, random_pose, rotation_error_deg
import numpy as np
from pcrp_core import InvalidCloud, PCRP
import pytest


@pytest.fixture(scope='module')
def model(small_model):
    return PCRP.load(small_model)


def test_gallery_objects_in_random_poses_come_back_exactly(model):
    rng = np.random.default_rng(11)
    for gid in model.gallery_ids[::17]:
        p = model.gallery_cloud(gid).astype(np.float64)
        R, t = random_pose(rng)
        r = model.estimate((p @ R.T + t)[rng.permutation(len(p))])
        assert r.gallery_id == gid and not r.rejected
        assert rotation_error_deg(r.rotation, R) < 1.0
        np.testing.assert_allclose(r.translation, t, atol=0.01)
        np.testing.assert_allclose(r.transform[:3, :3], R, atol=0.02)
        assert r.score > 0.9 and r.scale == 1.0
        assert set(r.timings) >= {'features', 'retrieval', 'registration', 'total'}


@pytest.mark.parametrize('category', ['chair', 'sofa'])
def test_held_back_objects_get_their_category_and_pose(model, category):
    points, _ = modelnet(category, 'test', 12)
    rng = np.random.default_rng(5)
    errors, right = [], []
    for p in points:
        R, t = random_pose(rng)
        r = model.estimate(p @ R.T + t)
        errors.append(rotation_error_deg(r.rotation, R))
        right.append(r.category == category)
    # a 40-object-per-category gallery: far smaller than the real one, so bounds are looser
    # (front/back flips of box-like sofas are the known weak spot, see the README)
    assert np.mean(right) >= 0.75
    assert np.mean(np.array(errors) < 30.0) >= 0.55
    assert np.median(np.sort(errors)[: len(errors) // 2]) < 8.0


def test_same_object_under_two_rotations_gives_the_same_canonical_pose(model):
    p = modelnet('chair', 'test', 1, start=4)[0][0]
    rng = np.random.default_rng(8)
    poses = []
    for _ in range(2):
        R, t = random_pose(rng)
        r = model.estimate(p @ R.T + t)
        # undo the known motion: what remains is the estimated pose of the object itself
        poses.append(R.T @ r.rotation)
    assert rotation_error_deg(poses[0], poses[1]) < 5.0


def _mirror_snap(model, on: bool):
    """
    Return the model with the mirror-plane finish on or off.

    Shares the gallery and its cache.
    """
    m = copy.copy(model)
    m.pose_options = dataclasses.replace(model.pose_options, mirror_snap=on)
    return m


@pytest.mark.slow
def test_mirror_planes_tighten_the_poses_of_mirror_symmetric_objects(model):
    """
    Held-back airplanes and chairs, whole, in random poses.

    Laying each query's mirror plane on its gallery object's (registration/mirror.py) must bring
    the poses ICP aligns closer still.
    """
    rng = np.random.default_rng(11)
    queries = []
    for category in ('airplane', 'chair'):
        for p in modelnet(category, 'test', 10)[0]:
            R, t = random_pose(rng)
            queries.append((p @ R.T + t, R))
    errors = {snap: np.array([rotation_error_deg(_mirror_snap(model, snap).estimate(q).rotation, R)
                              for q, R in queries]) for snap in (False, True)}
    aligned = (errors[False] < 5.0) & (errors[True] < 5.0)
    assert aligned.sum() >= 10
    # a correction, not a new guess: no pose moves off by more than sampling noise...
    assert np.all(errors[True][aligned] < errors[False][aligned] + 0.3)
    # ...and together they come closer (measured: median 0.74 -> 0.50 degrees over 11 aligned)
    assert np.median(errors[True][aligned]) < 0.8 * np.median(errors[False][aligned])


def test_mirror_planes_leave_known_objects_to_their_own_fit(model):
    """
    A gallery object re-measured fits its own gallery copy more tightly than its mirror image.

    Re-measured: noise of 1 % of its size. That registration is the more precise one and must
    stand. (Snapped regardless, such poses lost about 0.1 degree on ModelNet40's known objects.)
    """
    rng = np.random.default_rng(12)
    for gid in model.gallery_ids[3::15]:
        p = model.gallery_cloud(gid).astype(np.float64)
        R, t = random_pose(rng)
        q = (
            p + rng.normal(scale=0.01 * np.linalg.norm(p - p.mean(0), axis=1).max(), size=p.shape)
        ) @ R.T + t
        poses = [_mirror_snap(model, snap).estimate(q).rotation for snap in (False, True)]
        np.testing.assert_allclose(poses[1], poses[0], atol=1e-9)


@pytest.mark.parametrize('category', ['chair', 'sofa'])
def test_objects_modelled_outside_modelnet_get_their_category_and_one_canonical_pose(
    model, category
):
    """
    The procedural generator's chairs and sofas against the ModelNet gallery.

    They are made here, not drawn from ModelNet, each under two random rotations.
    """
    from pcrp_core.sources.procedural import generate_object
    rng = np.random.default_rng(2)
    right, disagreement = [], []
    for seed in range(100, 108):
        p = generate_object(category, seed).astype(np.float64)
        p = p / np.linalg.norm(p - p.mean(0), axis=1).max()  # the gallery's units: the unit sphere
        poses = []
        for _ in range(2):
            R, t = random_pose(rng)
            r = model.estimate(p @ R.T + t)
            right.append(r.category == category)
            poses.append(R.T @ r.rotation)        # the known motion undone: the object's own pose
        disagreement.append(rotation_error_deg(poses[0], poses[1]))
    assert np.mean(right) >= 15 / 16
    assert np.median(disagreement) < 5.0 and max(disagreement) < 15.0


def test_retrieve_returns_k_sorted_pairs(model):
    gid = model.gallery_ids[50]
    hits = model.retrieve(model.gallery_cloud(gid), k=7)
    assert len(hits) == 7 and hits[0][0] == gid
    assert all(a[1] <= b[1] for a, b in zip(hits, hits[1:]))


def test_large_clouds_are_downsampled_and_answered(model):
    gid = model.gallery_ids[10]
    p = model.gallery_cloud(gid).astype(np.float64)
    rng = np.random.default_rng(2)
    dense = np.repeat(p, 20, axis=0) + rng.normal(scale=1e-3, size=(len(p) * 20, 3))
    r = model.estimate(dense)
    # each point a clump of twenty: sampling keeps about one a clump, not the clumps' insides
    assert r.gallery_id == gid and 0.9 * len(p) <= r.n_points <= model.options.max_points


def test_a_gallery_object_seen_by_a_sensor_is_not_outvoted_by_relatives_facing_otherwise():
    """
    Like ModelNet's cars, some of which face along x and others along y.

    Nine relatives turned a quarter turn about the vertical must not vote a cloud of the very
    object (here the whole of it, from a sensor at the origin, as the node takes clouds by default)
    into their frame. Checked to fail with exact_ratio_view=0: every trial then came back as a
    relative, 90 deg off.
    """
    from pcrp_core.sources import GalleryObject
    from pcrp_core.sources.procedural import generate_object
    from scipy.spatial.transform import Rotation
    quarter = Rotation.from_euler('z', 90, degrees=True).as_matrix()
    model = PCRP.build(
        [
            GalleryObject(
                f'car_{k}', 'car', generate_object('car', k) @ (quarter.T if k else np.eye(3))
            )
            for k in range(10)
        ],
        n_jobs=1,
    )
    rng = np.random.default_rng(3)
    p = generate_object('car', 0).astype(np.float64)
    for _ in range(4):
        R, _ = random_pose(rng)
        r = model.estimate(
            p @ R.T + [0.0, 0.0, 3.0] + rng.normal(scale=0.003, size=p.shape),
            viewpoint=np.zeros(3),
        )
        assert r.gallery_id == 'car_0' and rotation_error_deg(r.rotation, R) < 2.0


@pytest.mark.parametrize('cloud, reason', [
    (np.zeros((0, 3)), 'empty'),
    (np.full((100, 3), np.nan), 'no_finite_points'),
    (np.random.default_rng(0).normal(size=(10, 3)), 'too_few_points'),
    (np.ones((500, 3)), 'too_few_points'),
    (np.outer(np.linspace(0, 1, 500), [1.0, 2.0, 3.0]), 'degenerate'),
    (np.zeros((10, 2)), 'bad_shape'),
])
def test_unusable_clouds_raise_with_a_reason(model, cloud, reason):
    with pytest.raises(InvalidCloud) as err:
        model.estimate(cloud)
    assert err.value.reason == reason


def test_settings_are_validated_and_an_invalid_change_changes_nothing(model):
    before = model.get_params()
    with pytest.raises(ValueError, match='n_candidates'):
        model.set_params(n_candidates=0)
    with pytest.raises(ValueError, match='unknown setting colour'):
        model.set_params(colour='red')
    with pytest.raises(ValueError, match='min_points must not exceed'):
        model.set_params(min_points=5000)
    with pytest.raises(ValueError, match='up_tolerance_deg'):
        model.set_params(n_candidates=4, up_tolerance_deg=0.0)
    assert model.get_params() == before
    variant = model.with_options(min_confidence=0.3, refine=False)
    assert (variant.options.min_confidence, variant.pose_options.refine) == (0.3, False)
    assert model.get_params() == before and variant.gallery is model.gallery
    with pytest.warns(DeprecationWarning, match='min_confidence'):
        variant = model.with_options(min_score=0.25)
    assert variant.options.min_confidence == 0.25


def test_clouds_from_a_sensor_are_voted_on_by_their_own_number_of_candidates(model, monkeypatch):
    from pcrp_core.sources.views import partial_view
    asked = []
    search = model.gallery.search
    monkeypatch.setattr(
        model.gallery, 'search', lambda vec, k, *a: asked.append(k) or search(vec, k, *a)
    )
    variant = model.with_options(n_candidates=12, n_candidates_view=20)
    cloud = model.gallery_cloud(model.gallery_ids[0]).astype(np.float64)
    variant.estimate(cloud)
    part, camera = partial_view(cloud, np.random.default_rng(5), 0.0, with_camera=True)
    variant.estimate(part, viewpoint=camera)
    assert asked == [12, 20]


def test_clouds_from_a_sensor_keep_their_own_share_of_icp_matches(model, monkeypatch):
    from pcrp_core.category import fitting
    from pcrp_core.sources.views import partial_view
    trims = []
    icp = fitting.icp_batch
    monkeypatch.setattr(
        fitting, 'icp_batch', lambda *args, **kw: trims.append(args[6]) or icp(*args, **kw)
    )
    variant = model.with_options(icp_trim=0.7, icp_trim_view=0.9)
    cloud = model.gallery_cloud(model.gallery_ids[0]).astype(np.float64)
    variant.estimate(cloud)
    whole, trims[:] = set(trims), []
    part, camera = partial_view(cloud, np.random.default_rng(5), 0.0, with_camera=True)
    variant.estimate(part, viewpoint=camera)
    assert (whole, set(trims)) == ({0.7}, {0.9})


def test_whole_clouds_rank_hypotheses_on_fewer_points_and_fewer_candidates_features(
    model, monkeypatch
):
    from pcrp_core.category import fitting
    from pcrp_core.sources.views import partial_view
    points, featured = [], []
    icp, get = fitting.icp_batch, model.prepared.get
    monkeypatch.setattr(
        fitting, 'icp_batch', lambda *args, **kw: points.append(len(args[0])) or icp(*args, **kw)
    )
    monkeypatch.setattr(
        model.prepared, 'get', lambda i, feats, size: featured.append(feats) or get(i, feats, size)
    )
    variant = model.with_options(seed_points=40, coarse_points=200, n_matched=3, whole_matched=1)
    cloud = model.gallery_cloud(model.gallery_ids[0]).astype(np.float64)
    variant.estimate(cloud)
    whole = (set(points), sum(featured))
    points[:], featured[:] = [], []
    part, camera = partial_view(cloud, np.random.default_rng(5), 0.0, with_camera=True)
    variant.estimate(part, viewpoint=camera)
    # a whole cloud: hypotheses on 40 points, the vote on 200, the final refinement on all 256; one
    # candidate's features (retrieval finds the cloud's own object, a twin). A view: its hypotheses
    # on the vote's points, three candidates' features
    assert whole == ({40, 200, 256}, 1)
    assert (set(points), sum(featured)) == ({200, 256}, 3)


def test_the_vote_refines_in_full_only_the_survivors_of_its_first_round(model, monkeypatch):
    from pcrp_core.category import fitting
    from pcrp_core.geometry import rotation_angle_deg
    batches = []
    icp = fitting.icp_batch
    monkeypatch.setattr(
        fitting,
        'icp_batch',
        lambda *args, **kw: batches.append((len(args[0]), len(args[3]))) or icp(*args, **kw),
    )
    cloud = model.gallery_cloud(model.gallery_ids[0]).astype(np.float64)
    answers, vote_sizes = [], []
    for survivors in (0, 2):
        batches[:] = []
        variant = model.with_options(
            seed_points=40, coarse_points=200, vote_survivors=survivors, vote_first_iterations=1
        )
        answers.append(variant.estimate(cloud))
        # the vote's full rounds are its ICP runs on the coarse points (200)
        vote_sizes.append({n for points, n in batches if points == 200})
    # two by the first round's scores, and the best fit on any one candidate if not one of them
    assert max(vote_sizes[0]) > 3 and vote_sizes[1] and vote_sizes[1] <= {2, 3}
    assert answers[0].gallery_id == answers[1].gallery_id
    assert rotation_angle_deg(answers[0].rotation, answers[1].rotation) < 1.0
