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
What a confidence is learnt from and how it is stored.

The evidence both ways of a posed answer; the split calibration, a regression for each kind of
answer, stored as plain arrays.
"""

import numpy as np
from pcrp_core.category.evidence import both_ways
from pcrp_core.category.fitting import Fitter
from pcrp_core.category.hypothesis import Hypothesis
from pcrp_core.category.prepared import prepare
from pcrp_core.confidence import (
    BoostedCalibration,
    Calibration,
    calibration_from_arrays,
    fit_boosted_calibration,
    fit_calibration,
    fit_split_calibration,
    SplitCalibration,
)
from pcrp_core.config import PoseOptions
from pcrp_core.instance.calibration import FEATURES, fit_view_calibration, LEAST_FOR_TREES
import pytest


def opposite_kinds(n: int = 2000):
    """Make evidence x meaning right for kind 0, wrong for kind 1: one regression reads neither."""
    rng = np.random.default_rng(5)
    x, kind = rng.normal(size=n), rng.random(n) < 0.5
    right = rng.random(n) < 1 / (1 + np.exp(-3.0 * np.where(kind, -x, x)))
    return [{'x': a, 'kind': float(k)} for a, k in zip(x, kind)], right


def test_each_kind_of_answer_is_read_by_its_own_regression():
    samples, right = opposite_kinds()
    split = fit_split_calibration(samples, right, ('x',), 'kind')
    assert split.probability({'x': 2.0, 'kind': 0.0}) > 0.9
    assert split.probability({'x': 2.0, 'kind': 1.0}) < 0.1
    pooled = fit_calibration(samples, right, ('x',))
    assert 0.3 < pooled.probability({'x': 2.0, 'kind': 0.0}) < 0.7


def test_a_kind_with_answers_all_right_falls_back_to_the_pooled_regression():
    samples, right = opposite_kinds()
    right = np.where([s['kind'] > 0.5 for s in samples], True, right)
    split = fit_split_calibration(samples, right, ('x',), 'kind')
    pooled = fit_calibration(samples, right, ('x',))
    np.testing.assert_array_equal(split.parts[1].coef, pooled.coef)
    assert not np.array_equal(split.parts[0].coef, pooled.coef)
    # both kinds all one way or the other: one pooled regression reads both
    one_each = np.array([s['kind'] > 0.5 for s in samples])
    both = fit_split_calibration(samples, one_each, ('x',), 'kind')
    assert both.parts[0] is both.parts[1]


def test_calibrations_come_back_from_their_arrays_as_they_were_stored():
    samples, right = opposite_kinds()
    split = fit_split_calibration(samples, right, ('x',), 'kind')
    again = calibration_from_arrays(split.to_arrays('c_'), 'c_')
    assert isinstance(again, SplitCalibration) and again.names == ('x',)
    for s in samples[:20]:
        assert again.probability(s) == split.probability(s)
    # a model stored before calibrations were split keeps its one regression
    one = fit_calibration(samples, right, ('x',))
    assert isinstance(calibration_from_arrays(one.to_arrays('c_'), 'c_'), Calibration)
    assert calibration_from_arrays({}, 'c_') is None


def a_band(n: int = 1500, seed: int = 6):
    """Make evidence x meaning right inside a band (|x| < 1), wrong on either side of it."""
    rng = np.random.default_rng(seed)
    x = rng.normal(scale=1.5, size=n)
    right = rng.random(n) < np.where(np.abs(x) < 1.0, 0.95, 0.05)
    return [{'x': a} for a in x], right


def test_boosted_trees_read_a_band_of_evidence_that_one_weight_cannot():
    samples, right = a_band()
    trees, one = fit_boosted_calibration(samples, right, ('x',)), fit_calibration(
        samples, right, ('x',))
    assert trees.probability({'x': 0.0}) > 0.85
    assert trees.probability({'x': -2.5}) < 0.15 and trees.probability({'x': 2.5}) < 0.15
    # a regression leans one way: it cannot call both sides of the band wrong
    assert max(one.probability({'x': -2.5}), one.probability({'x': 2.5})) > 0.3


def test_boosted_trees_from_plain_arrays_give_scikit_learns_probabilities():
    from sklearn.ensemble import GradientBoostingClassifier

    samples, right = a_band(400, seed=7)
    samples = [{'x': s['x'], 'y': float(k)} for k, s in enumerate(samples)]
    trees = fit_boosted_calibration(samples, right, ('x', 'y'))
    X = np.array([[s['x'], s['y']] for s in samples])
    reference = GradientBoostingClassifier(
        n_estimators=200, max_depth=3, learning_rate=0.05, min_samples_leaf=10, subsample=0.8,
        random_state=0).fit(X, right.astype(int))
    again = calibration_from_arrays(trees.to_arrays('c_'), 'c_')
    assert isinstance(again, BoostedCalibration)
    ours = [again.probability(s) for s in samples]
    np.testing.assert_allclose(ours, reference.predict_proba(X)[:, 1], atol=1e-12)


@pytest.mark.parametrize('key, value, words', [
    ('left', 10 ** 6, 'outside'),       # past the table
    ('left', 0, 'before'),              # back to the root: a walk that never ends
    ('feature', 7, 'evidence'),         # evidence the calibration does not name
])
def test_stored_trees_that_cannot_be_walked_are_refused(key, value, words):
    samples, right = a_band(300)
    arrays = fit_boosted_calibration(samples, right, ('x',)).to_arrays('c_')
    arrays[f'c_trees_{key}'] = arrays[f'c_trees_{key}'].copy()
    arrays[f'c_trees_{key}'][0] = value
    with pytest.raises(ValueError, match=words):
        calibration_from_arrays(arrays, 'c_')


def test_view_calibration_is_trees_given_answers_enough_of_each_kind_else_a_regression():
    rng = np.random.default_rng(3)

    def answers(n_right, n_wrong):
        right = np.r_[np.ones(n_right, bool), np.zeros(n_wrong, bool)]
        X = [{n: float(rng.normal() + 2.0 * r * (n == 'cost')) for n in FEATURES} for r in right]
        return X, list(right)

    assert isinstance(fit_view_calibration(*answers(400, 400)), BoostedCalibration)
    assert isinstance(fit_view_calibration(*answers(400, LEAST_FOR_TREES - 1)), Calibration)
    assert fit_view_calibration(*answers(40, 0)) is None


def egg(n: int = 2048) -> np.ndarray:
    """Make points on an egg 2 x 1.2 x 0.8 across: long enough that a quarter turn fits badly."""
    rng = np.random.default_rng(8)
    u = rng.normal(size=(n, 3))
    return u / np.linalg.norm(u, axis=1, keepdims=True) * [1.0, 0.6, 0.4]


def evidence_of(query: np.ndarray, gallery: np.ndarray, R=np.eye(3)) -> dict:
    fitter = Fitter(prepare(query), PoseOptions(), np.random.default_rng(0))
    pose = Hypothesis(R, np.zeros(3), 1.0, 0.0, 0.0, 'test')
    return both_ways(fitter, pose, prepare(gallery), PoseOptions().inlier_distance)


def test_evidence_both_ways_tells_a_whole_object_from_half_of_it_and_from_a_wrong_turn():
    gallery = egg()
    whole, half = evidence_of(gallery, gallery), evidence_of(gallery[gallery[:, 2] > 0], gallery)
    # every point of either lies on the object...
    assert whole['fit_tight'] == half['fit_tight'] == 1.0
    # ...but half of the object is missing from the half
    # (a few hundred points leave gaps in a whole one too: only more is missing, not none)
    assert half['missing_far'] > whole['missing_far'] + 0.2
    assert half['missing'] > 2 * whole['missing']
    assert half['missing_q90'] > 2 * whole['missing_q90']
    assert half['fit_q90'] == pytest.approx(whole['fit_q90'], abs=0.5)
    quarter = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    turned = evidence_of(gallery, gallery, quarter)
    assert turned['fit_tight'] < 0.5 and turned['missing_far'] > whole['missing_far'] + 0.2
    assert turned['fit_q90'] > 2 * whole['fit_q90']
