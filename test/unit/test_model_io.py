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
Model files: a round trip keeps every array and answer.

(Every way a file can be broken is in pcrp_ros/faults.py, tried on the core, the node and the CLI
by test_node_robustness.py.)
"""
import numpy as np
from pcrp_core import PCRP


def test_round_trip_keeps_every_array_and_answer(small_model, tmp_path):
    model = PCRP.load(small_model)
    model.save(tmp_path / 'again')
    again = PCRP.load(tmp_path / 'again')
    assert again.gallery_ids == model.gallery_ids
    np.testing.assert_array_equal(again.gallery.vectors, model.gallery.vectors)
    q = model.gallery_cloud(model.gallery_ids[3])
    a, b = model.estimate(q), again.estimate(q)
    assert a.gallery_id == b.gallery_id
    np.testing.assert_allclose(a.transform, b.transform)


def test_stored_mirror_planes_are_the_ones_a_query_would_find_and_old_models_still_answer(
    small_model, tmp_path
):
    from pcrp_core.registration.mirror import gallery_mirror

    model = PCRP.load(small_model)
    stored = model.gallery.mirrors
    assert stored is not None and stored.shape == (len(model.gallery_ids), 4)
    assert (
        np.isfinite(stored).all(axis=1).sum() > len(stored) // 2
    )  # most objects are mirror-symmetric
    for i in range(6):
        prep = model.prepared.get(i, False, 8)
        plane = gallery_mirror(prep.points, prep.tree, model.pose_options.mirror_tolerance,
                               model.pose_options.mirror_max_deg)
        if plane is None:
            assert not np.isfinite(stored[i]).any()
        else:
            np.testing.assert_allclose(stored[i], [*plane.normal, plane.offset], atol=1e-12)
    # a model saved before planes were stored works them out as its queries need them, alike
    model.gallery.mirrors = None
    model.save(tmp_path / 'old')
    old, q = PCRP.load(tmp_path / 'old'), model.gallery_cloud(model.gallery_ids[5])
    assert old.gallery.mirrors is None
    np.testing.assert_allclose(
        old.estimate(q).transform, PCRP.load(small_model).estimate(q).transform, atol=1e-9
    )


def test_a_version_1_model_is_read_and_saved_again_as_version_2(tmp_path):
    import json

    from helpers import PROCEDURAL_MODEL

    assert json.loads((PROCEDURAL_MODEL / 'model.json').read_text())['format_version'] == 1
    model = PCRP.load(PROCEDURAL_MODEL)
    model.save(tmp_path / 'again')
    assert json.loads((tmp_path / 'again' / 'model.json').read_text())['format_version'] == 2
    again = PCRP.load(tmp_path / 'again')
    q = model.gallery_cloud(model.gallery_ids[0])
    assert again.estimate(q).confidence == model.estimate(q).confidence
