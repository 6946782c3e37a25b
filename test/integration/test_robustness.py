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
Whatever a segmenter sends: the core answers or refuses with a reason, never crashes.

(The node's side of it is in test_node_robustness.py.)
"""
import time

from helpers import PROCEDURAL_MODEL, rotation_error_deg
from hypothesis import given, settings, strategies as st
import numpy as np
from pcrp_core import InvalidCloud, PCRP
from pcrp_core.sources.procedural import generate_object
import pytest


@pytest.fixture(scope='module')
def model():
    return PCRP.load(PROCEDURAL_MODEL)


def _answer_or_reason(model, cloud):
    try:
        return model.estimate(cloud)
    except InvalidCloud as e:
        assert e.reason in {
            'empty',
            'no_finite_points',
            'too_few_points',
            'degenerate',
            'bad_shape',
        }
        return e.reason


@pytest.mark.parametrize(
    'name, cloud',
    [
        (
            'plane',
            np.column_stack([np.random.default_rng(0).uniform(-1, 1, (800, 2)), np.zeros(800)]),
        ),
        (
            'sphere',
            (lambda v: v / np.linalg.norm(v, axis=1, keepdims=True))(
                np.random.default_rng(1).normal(size=(800, 3))
            ),
        ),
        (
            'cube',
            np.random.default_rng(2).uniform(-1, 1, (800, 3)).round(0) * 0.5
            + np.random.default_rng(3).uniform(-0.5, 0.5, (800, 3)) * [1, 1, 0],
        ),
        (
            'duplicated points',
            np.repeat(generate_object('chair', 1)[:100].astype(float), 10, axis=0),
        ),
        ('two points repeated', np.repeat([[0.0, 0, 0], [1, 1, 1]], 400, axis=0)),
    ],
)
def test_degenerate_geometry_is_answered_or_refused(model, name, cloud):
    out = _answer_or_reason(model, cloud)
    assert isinstance(out, str) or np.isfinite(out.transform).all()


@pytest.mark.parametrize('viewpoint, scene, said', [
    ([0.0, 0.0], None, 'viewpoint'), ([np.nan, 0.0, 0.0], None, 'viewpoint'),
    ('origin', None, 'viewpoint'), ([0.0, 0.0, 0.0], 'depth.png', 'scene'),
    ([0.0, 0.0, 0.0], np.zeros((5, 2)), 'scene'),
])
def test_a_bad_viewpoint_or_scene_is_refused_saying_what_is_expected(
        model, viewpoint, scene, said):
    """They failed deep inside as numpy's broadcasting or type errors, or scipy's."""
    cloud = model.gallery_cloud(model.gallery_ids[0]).astype(np.float64) + [0.0, 0.0, 2.0]
    with pytest.raises(ValueError, match=f'^{said}'):
        model.estimate(cloud, viewpoint=viewpoint, scene=scene)


@pytest.mark.parametrize('seed', [0, 1])
def test_screening_on_arrival_refuses_what_cleaning_does_and_keeps_the_answer(model, seed):
    # what a stream screens as clouds arrive must be what estimate() would refuse, and the
    # thinned cloud it queues must get the answer the whole cloud gets
    rng = np.random.default_rng(seed)
    big = generate_object('chair', seed).astype(float)
    big = np.repeat(big, 6, axis=0) + rng.normal(0, 0.003, (6 * len(big), 3))
    clouds = [big, big[:3], np.full((50, 3), np.nan), np.repeat(big[:2], 300, axis=0),
              np.column_stack([np.linspace(0, 1, 500)] * 3), np.zeros((0, 3))]
    for cloud in clouds:
        try:
            screened = model.screen(cloud)
        except InvalidCloud as e:
            with pytest.raises(InvalidCloud) as cleaned:
                model.prepare(cloud)
            assert cleaned.value.reason == e.reason
            continue
        assert len(screened) < len(cloud)   # the big cloud is thinned, not only checked
        np.testing.assert_array_equal(model.prepare(screened), model.prepare(cloud))
        a, b = model.estimate(screened), model.estimate(cloud)
        assert a.gallery_id == b.gallery_id
        np.testing.assert_allclose(a.transform, b.transform, atol=1e-6)


def test_a_million_points_are_downsampled_and_answered_in_bounded_time(model):
    rng = np.random.default_rng(4)
    base = generate_object('sofa', 2, n_points=4096).astype(np.float64)
    big = base[rng.integers(0, len(base), 1_000_000)] + rng.normal(
        scale=0.002, size=(1_000_000, 3)
    )
    t0 = time.perf_counter()
    r = model.estimate(big)
    assert time.perf_counter() - t0 < 20.0
    assert r.n_points == model.options.max_points and r.category == 'sofa'


def test_far_from_the_origin_the_pose_is_still_right(model):
    p = model.gallery_cloud('proc_chair_0003').astype(np.float64)
    t = np.array([1000.0, -250.0, 30.0])
    r = model.estimate(p + t)
    assert r.gallery_id == 'proc_chair_0003' and rotation_error_deg(r.rotation, np.eye(3)) < 1.0
    np.testing.assert_allclose(r.translation, t, atol=0.01)


def test_a_cloud_in_millimetres_is_answered_or_rejected_not_crashed(model):
    out = _answer_or_reason(
        model, model.gallery_cloud('proc_car_0001').astype(np.float64) * 1000.0
    )
    assert isinstance(out, str) or np.isfinite(out.transform).all()
    model.set_params(scale_mode='normalize')
    try:
        r = model.estimate(model.gallery_cloud('proc_car_0001').astype(np.float64) * 1000.0)
    finally:
        model.set_params(scale_mode='metric')
    assert r.gallery_id == 'proc_car_0001' and r.scale == pytest.approx(1000.0, rel=0.01)


@settings(max_examples=8, deadline=None)
@given(rotvec=st.tuples(*[st.floats(-3.0, 3.0)] * 3), shift=st.tuples(*[st.floats(-5.0, 5.0)] * 3))
def test_any_rotation_and_translation_of_a_gallery_object_gives_its_pose(model, rotvec, shift):
    from scipy.spatial.transform import Rotation
    R = Rotation.from_rotvec(rotvec).as_matrix()
    p = model.gallery_cloud('proc_airplane_0004').astype(np.float64)
    r = model.estimate(p @ R.T + shift)
    assert r.gallery_id == 'proc_airplane_0004'
    assert rotation_error_deg(r.rotation, R) < 1.0
    np.testing.assert_allclose(r.translation, shift, atol=0.01)
