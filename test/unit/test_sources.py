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

"""Where objects come from: the generator, ModelNet archives, the user's folders, sensor views."""
from helpers import MODELNET
import numpy as np
import open3d as o3d
from pcrp_core.sources import load_source, load_sources
from pcrp_core.sources.primitives import random_solid
from pcrp_core.sources.procedural import CATEGORIES, generate_object
from pcrp_core.sources.views import crop_half_plane, partial_view, random_rotation, sensor_view
from pcrp_core.visibility import visible_from
import pytest
from scipy.spatial import cKDTree


@pytest.mark.parametrize('category', CATEGORIES)
def test_generated_objects_are_deterministic_varied_normalised_and_have_a_front(category):
    a, b, other = (
        generate_object(category, 3),
        generate_object(category, 3),
        generate_object(category, 4),
    )
    np.testing.assert_array_equal(a, b)
    assert cKDTree(other).query(a)[0].mean() > 0.02
    np.testing.assert_allclose(a.mean(0), 0, atol=1e-5)
    assert np.linalg.norm(a, axis=1).max() == pytest.approx(1.0, abs=1e-5)
    turned = a * [-1, -1, 1]   # half turn about z: a pose must be told from this
    assert cKDTree(a).query(turned)[0].mean() > 0.03


def test_random_solids_are_seeded_centred_and_of_varied_shape():
    first = [random_solid(np.random.default_rng(s), 500) for s in range(12)]
    again = random_solid(np.random.default_rng(0), 500)
    np.testing.assert_array_equal(first[0], again)
    assert all(p.shape == (500, 3) and np.abs(p.mean(0)).max() < 1e-9 for p in first)
    # proportions: from rods and plates to near-balls, not one shape twelve times
    spread = [np.sqrt(np.linalg.eigvalsh(np.cov(p.T))) for p in first]
    flatness = [s[0] / s[2] for s in spread]
    assert min(flatness) < 0.3 and max(flatness) > 0.5


def test_procedural_train_and_test_splits_differ_and_ids_are_unique():
    train, test = load_source('procedural:3'), load_source('procedural:3', split='test')
    assert len(train) == 12 and {o.category for o in train} == set(CATEGORIES)
    assert not {o.gallery_id for o in train} & {o.gallery_id for o in test}
    with pytest.raises(ValueError, match='twice'):
        load_sources(['procedural:2', 'procedural:2'])


@pytest.mark.skipif(not MODELNET.exists(), reason='needs ../shared/data/modelnet40')
def test_modelnet_archives_give_official_names_and_the_category():
    objs = load_source(str(MODELNET / 'sofa.npz'), split='test', limit_per_category=3)
    assert [o.gallery_id for o in objs][0].startswith('sofa_') and {o.category for o in objs} == {
        'sofa'
    }
    assert objs[0].points.shape == (1024, 3) and objs[0].points.dtype == np.float32


def test_folders_of_meshes_and_clouds_load_and_broken_files_are_skipped(tmp_path, caplog):
    (tmp_path / 'box').mkdir()
    (tmp_path / 'ball').mkdir()
    mesh = o3d.geometry.TriangleMesh.create_box(2.0, 1.0, 0.5)
    o3d.io.write_triangle_mesh(str(tmp_path / 'box' / 'crate.obj'), mesh)
    np.save(tmp_path / 'ball' / 'b1.npy', np.random.default_rng(0).normal(size=(500, 3)))
    (tmp_path / 'ball' / 'broken.ply').write_text('not a ply')
    objs = load_source(str(tmp_path), n_points=300)
    ids = sorted(o.gallery_id for o in objs)
    assert ids == ['ball/b1', 'box/crate']
    crate = next(o for o in objs if o.gallery_id == 'box/crate')
    # a mesh is sampled densely (the build thins it evenly) and kept, to render views from
    assert crate.points.shape == (1200, 3) and crate.points[:, 0].max() == pytest.approx(
        2.0, abs=1e-3
    )
    assert crate.mesh is not None and len(crate.mesh.triangles) == 12
    assert next(o for o in objs if o.gallery_id == 'ball/b1').mesh is None
    assert 'broken.ply' in caplog.text
    with pytest.raises(ValueError, match='not a ModelNet40 archive'):
        load_source(str(tmp_path / 'nothing_here'))


def test_a_flat_folder_of_meshes_is_one_object_per_file(tmp_path):
    # as ../shared/data/ycb is laid out: <id>_<name>.ply side by side, no category folders
    o3d.io.write_triangle_mesh(
        str(tmp_path / '002_can.ply'), o3d.geometry.TriangleMesh.create_cylinder(0.05, 0.12)
    )
    o3d.io.write_triangle_mesh(
        str(tmp_path / '003_box.ply'), o3d.geometry.TriangleMesh.create_box(0.07, 0.16, 0.21)
    )
    (tmp_path / 'README.md').write_text('not an object')
    objs = load_source(str(tmp_path), n_points=256)
    assert [(o.gallery_id, o.category) for o in objs] == [
        ('002_can', '002_can'),
        ('003_box', '003_box'),
    ]
    assert all(o.mesh is not None for o in objs)
    assert objs[1].points.max(axis=0) == pytest.approx([0.07, 0.16, 0.21], abs=2e-3)


@pytest.mark.parametrize('distance', [1.5, 20.0, 1000.0])
def test_a_camera_at_any_distance_sees_the_side_facing_it(distance):
    # hidden point removal breaks once the camera is further than its flipping sphere's radius:
    # from 1000 diameters it used to report the far side
    rng = np.random.default_rng(0)
    p = rng.normal(size=(2000, 3))
    p /= np.linalg.norm(p, axis=1, keepdims=True)
    seen = p[visible_from(p, np.array([0.0, 0.0, 2.0 * distance]))]
    assert 0.3 * len(p) < len(seen) < 0.6 * len(p)
    assert np.mean(seen[:, 2] > 0) > 0.9


def test_a_sensor_sees_one_side_with_noise_along_its_rays():
    rng = np.random.default_rng(1)
    p = generate_object('car', 0).astype(np.float64) + [0, 0, 3.0]
    seen = sensor_view(p, np.zeros(3), rng, noise_sigma=0.0)
    assert 0.15 * len(p) < len(seen) < 0.8 * len(p)
    assert seen[:, 2].mean() < p[:, 2].mean()         # the near side
    noisy = partial_view(p, np.random.default_rng(2), noise_sigma=0.01)
    again = partial_view(p, np.random.default_rng(2), noise_sigma=0.01)
    np.testing.assert_array_equal(noisy, again)
    assert len(crop_half_plane(p, rng, keep=0.7)) == pytest.approx(0.7 * len(p), abs=2)
    R = random_rotation(rng)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)
