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

"""The category-level path's confidence: learnt at build, stored, and what it says."""

from helpers import MODELNET, modelnet, random_pose
import numpy as np
from pcrp_core import PCRP
from pcrp_core.category.evidence import FEATURES
import pytest


def test_search_leaves_out_the_objects_it_is_told_to(small_model):
    model = PCRP.load(small_model)
    vec = model.gallery.vectors[0]
    idx, _ = model.gallery.search(vec, 10)
    assert idx[0] == 0
    drop = list(idx[:5])
    again, _ = model.gallery.search(vec, 10, drop)
    assert not set(drop) & set(again.tolist()) and len(again) == 10


def test_the_build_learns_a_confidence_that_is_stored_and_answers_report(small_model, tmp_path):
    model = PCRP.load(small_model)
    cal = model.category_calibration
    # a regression each for whole clouds and one-sided views, on every piece of evidence
    assert cal is not None and cal.key == 'whole' and len(cal.parts) == 2
    assert all(p.names == FEATURES and np.isfinite(p.coef).all() for p in cal.parts)
    model.save(tmp_path / 'again')
    again = PCRP.load(tmp_path / 'again')
    for mine, stored in zip(cal.parts, again.category_calibration.parts):
        np.testing.assert_array_equal(stored.coef, mine.coef)
    points = modelnet('chair', 'test', 1)[0][0]
    R, t = random_pose(np.random.default_rng(3))
    r = model.estimate(points @ R.T + t)
    assert 0.0 <= r.confidence <= 1.0 and r.rejected == (
        r.confidence < model.options.min_confidence
    )
    # without a calibration the fit score stands in, as before
    model.category_calibration = None
    assert model.estimate(points @ R.T + t).confidence == pytest.approx(r.score)


def test_calibration_also_asks_about_solids_no_gallery_holds_and_counts_them_wrong(small_model):
    from pcrp_core.category.calibration import answer_query, solid_queries

    model = PCRP.load(small_model)
    solids = solid_queries(model, 3)
    again = solid_queries(model, 3)
    assert len(solids) == 3 and all(np.array_equal(a[1], b[1]) for a, b in zip(solids, again))
    # whole clouds, of a gallery object's size, with nothing to be right about
    assert all(index is None and vp is None and R is None for index, _, vp, R in solids)
    sizes = [np.sqrt(((p - p.mean(0)) ** 2).sum(1).mean()) for _, p, _, _ in solids]
    assert min(sizes) >= 0.5 * model.radii.min() and max(sizes) <= 2.0 * model.radii.max()
    (evidence, right), = answer_query({'model': model}, solids[0])
    assert right is False and set(FEATURES) <= set(evidence)


@pytest.mark.skipif(not MODELNET.exists(), reason='needs ../shared/data/modelnet40')
def test_objects_of_categories_outside_the_gallery_are_less_trusted_than_its_own(small_model):
    """
    The gallery holds chairs, sofas and airplanes.

    Its own objects (as a robot that knows them would see them) must come back more confident than
    lamps and bottles it never held.
    """
    model = PCRP.load(small_model)
    rng = np.random.default_rng(11)
    own, outside = [], []
    for gid in model.gallery_ids[::12]:
        R, t = random_pose(rng)
        p = model.gallery_cloud(gid).astype(np.float64)
        own.append(model.estimate((p + rng.normal(scale=0.01, size=p.shape)) @ R.T + t).confidence)
    for category in ('lamp', 'bottle'):
        for p in modelnet(category, 'test', 5)[0]:
            R, t = random_pose(rng)
            outside.append(model.estimate(p @ R.T + t).confidence)
    assert np.median(own) > 0.5 > np.median(outside)
