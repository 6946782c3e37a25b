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

"""Which way is up: a caller that knows gravity passes it, and answers keep the object upright."""
import copy
import json

from helpers import PROCEDURAL_MODEL
import numpy as np
from pcrp_core import ModelError, PCRP
from pcrp_core.build import common_up
from pcrp_core.sources import GalleryObject
from pcrp_core.sources.procedural import generate_object
import pytest
from scipy.spatial.transform import Rotation


@pytest.fixture(scope='module')
def model():
    return PCRP.load(PROCEDURAL_MODEL)


def _tilt(result, model, up):
    """Degrees between where the answer puts the gallery's up axis and the given up direction."""
    a = result.rotation @ model.up_axis
    return np.degrees(np.arccos(np.clip(a @ up / np.linalg.norm(up), -1.0, 1.0)))


def test_the_shipped_model_and_modelnet_and_generated_sources_say_z_is_up(model):
    np.testing.assert_allclose(model.up_axis, [0.0, 0.0, 1.0])
    from pcrp_core.sources import load_source
    assert {o.up for o in load_source('procedural:1')} == {'z'}


@pytest.mark.parametrize('seed', [0, 1, 2])
def test_answers_keep_the_given_up_even_when_it_is_wrong(model, seed):
    """
    The prior is obeyed: told the truth the answer is right and upright.

    Told the object is upside down, the answer is upside down too, which it could not be if up were
    ignored.
    """
    rng = np.random.default_rng(seed)
    R = Rotation.random(random_state=seed).as_matrix()
    cloud = generate_object(['chair', 'sofa', 'car'][seed], 100_000 + seed).astype(
        np.float64
    ) @ R.T + rng.normal(size=3)
    true_up = R @ model.up_axis
    right = model.estimate(cloud, up=true_up)
    assert _tilt(right, model, true_up) < model.pose_options.up_tolerance_deg
    assert np.degrees(Rotation.from_matrix(right.rotation @ R.T).magnitude()) < 15.0
    wrong = model.estimate(cloud, up=-true_up)
    # final ICP may tip it a little
    assert _tilt(wrong, model, -true_up) < model.pose_options.up_tolerance_deg + 15.0
    assert _tilt(wrong, model, true_up) > 90.0


def test_an_unusable_up_or_a_model_without_an_up_axis_is_refused(model):
    cloud = generate_object('chair', 7).astype(np.float64)
    for bad in ([0.0, 0.0, 0.0], [1.0, 2.0], [np.nan, 0.0, 1.0]):
        with pytest.raises(ValueError, match='up must be'):
            model.estimate(cloud, up=bad)
    silent = copy.copy(model)
    silent.meta = {**model.meta, 'up_axis': None}
    with pytest.raises(ValueError, match='up-axis'):
        silent.estimate(cloud, up=[0.0, 0.0, 1.0])
    assert silent.estimate(cloud).gallery_id == model.estimate(cloud).gallery_id
    with pytest.raises(ValueError):
        model.set_params(up_tolerance_deg=0.0)


def test_a_build_records_the_up_axis_its_sources_agree_on_or_the_one_given(tmp_path):
    def objects(ups):
        return [
            GalleryObject(f'o{k}', 'chair', generate_object('chair', k), up=u)
            for k, u in enumerate(ups)
        ]
    # what the sources say, asked directly (no model needs building to check it)
    assert common_up(objects(['z', 'z', 'z'])).tolist() == [0.0, 0.0, 1.0]
    assert common_up(objects(['z', 'y', 'z'])) is None       # disagree: none
    assert common_up(objects([None, None, None])) is None     # folders say nothing
    given = PCRP.build(objects([None, None, None]), n_jobs=1, up_axis='-y')
    given.save(tmp_path / 'm')
    assert PCRP.load(tmp_path / 'm').up_axis.tolist() == [0.0, -1.0, 0.0]
    meta = json.loads((tmp_path / 'm' / 'model.json').read_text())
    meta['up_axis'] = 'sideways'
    (tmp_path / 'm' / 'model.json').write_text(json.dumps(meta))
    with pytest.raises(ModelError, match='up axis'):
        PCRP.load(tmp_path / 'm')
