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

"""The segmenter's faults the segmentation report adds to a view, and the report's table."""
import numpy as np
import open3d as o3d
from pcrp_core.evaluation.scenes import sample_scene
from pcrp_core.sources.camera import Mesh
import pytest
from tools.segmentation_faults import FAULTS, SPECK_POINTS, with_fault
from tools.segmentation_report import KINDS, markdown, NOTHING_ASIDE, TABLE_ASIDE

BOX = o3d.geometry.TriangleMesh.create_box(0.12, 0.08, 0.05)
MESH = Mesh(np.asarray(BOX.vertices, dtype=np.float64), np.asarray(BOX.triangles, dtype=np.int64))


@pytest.fixture(scope='module', params=list(KINDS))
def scene(request):
    return sample_scene(MESH, 'box', 3, 0, request.param, seed=11)


def _added(scene, fault):
    points = with_fault(scene, MESH, fault)
    np.testing.assert_array_equal(points[:len(scene.points)], scene.points.astype(np.float64))
    return points[len(scene.points):]


def test_a_clean_view_gets_nothing_and_every_fault_something(scene):
    assert len(_added(scene, 'clean')) == 0
    for fault in set(FAULTS) - {'clean'}:
        assert len(_added(scene, fault)) > 0, fault
    assert len(_added(scene, 'speck_behind')) == SPECK_POINTS


def test_faults_are_the_same_every_run_and_differ_between_views(scene):
    for fault in FAULTS:
        np.testing.assert_array_equal(with_fault(scene, MESH, fault),
                                      with_fault(scene, MESH, fault))
    other = sample_scene(MESH, 'box', 3, 1, scene.kind, seed=11)
    assert not np.allclose(_added(scene, 'speck_behind').mean(0),
                           _added(other, 'speck_behind').mean(0))


def test_what_a_mask_takes_in_lies_behind_the_object_or_on_its_table(scene):
    far = scene.points[:, 2].max()
    assert (_added(scene, 'speck_behind')[:, 2] > far).mean() > 0.9
    wide = _added(scene, 'wide_mask')
    # measured with the camera's range error: a few millimetres, a centimetre at 2 m
    if scene.up is None:
        assert (wide[:, 2] > far + 0.05).all()
    else:
        table = ((MESH.vertices @ scene.R.T + scene.t) @ scene.up).min()
        on_table = np.abs(wide @ scene.up - table) < 0.015
        assert on_table.any() and (wide[~on_table, 2] > far).all()
        assert np.abs(wide[on_table] @ scene.up - table).max() > 1e-4
    # flying pixels lie between the edge next to them and the background behind it
    flying = _added(scene, 'flying_pixels')
    assert flying[:, 2].min() >= scene.points[:, 2].min() - 1e-6
    assert (flying[:, 2] <= np.maximum(wide[:, 2].max(), far) + 0.05).all()


def test_an_unknown_fault_is_refused_by_name(scene):
    with pytest.raises(ValueError, match='speckle.*expected one of'):
        with_fault(scene, MESH, 'speckle')


def test_the_report_has_a_row_per_scenario_and_fault():
    stats = {'pose_right': 0.9, 'wrong_accepted': 0.0, 'right_rejected': 0.05,
             'seconds_median': 0.08, 'added_median': 20.0, 'stray_share_median': 0.01}
    res = {'split': 'test', 'seed': 0, 'views_per_object': 1, 'objects': ['box'],
           'gallery_size': 1, 'seconds': 30.0, 'faults': FAULTS,
           'machine': {'cores': 2, 'cpu': 'cpu', 'date': '2026-12-07 00:00'},
           'model': {'recipe': 'pcrp build boxes --up-axis z', 'code': 'abc'},
           'results': {f'{k}/{f}/{s}': stats for k in KINDS for f in FAULTS
                       for s in ('defaults', NOTHING_ASIDE)}}
    res['results'].update({f'table/{f}/{TABLE_ASIDE}': stats for f in FAULTS})
    text = markdown(res)
    for kind, title in KINDS.items():
        for fault in FAULTS:
            assert f'| {title} | {fault} | 20 | 1.0 % | 90 % |' in text
    # the table setting only where up is known
    assert '| free in space | clean | 20 | 1.0 % | 90 % | 0 % | 5 % | - | - |' in text
    assert '| on a table, up known | clean | 20 | 1.0 % | 90 % | 0 % | 5 % | 90 % | 0 % |' in text
