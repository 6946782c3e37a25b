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


"""Surface something in front of an object hid is not counted missing (instance/occlusion.py)."""
import numpy as np
from pcrp_core.instance.occlusion import hidden, occluders
from pcrp_core.instance.templates import object_templates, stack, TemplateSettings
from pcrp_core.instance.verification import judge, query_surface, Surface, visible_points
from pcrp_core.sources.camera import Mesh, MeshCamera
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

SMALL = TemplateSettings(views=16, visibility_directions=128, surface_points=512, view_points=256)


def _wall(x_max: float, z: float, step: float = 0.001) -> np.ndarray:
    """Make a wall of points at depth z covering every ray with x / z < x_max (and |y / z| < 1)."""
    x, y = np.meshgrid(np.arange(-1.0, x_max, step / z), np.arange(-1.0, 1.0, step / z))
    return np.column_stack([x.ravel() * z, y.ravel() * z, np.full(x.size, z)])


def test_points_behind_a_wall_are_hidden_and_those_beside_or_in_front_are_not():
    cloud = np.array([[0.0, 0.0, 0.5], [0.01, 0.0, 0.5]])
    occ = occluders(_wall(0.0, 0.3), cloud, spacing=0.003, reach=0.2)
    points = np.array([
        [-0.05, 0.0, 0.5],    # behind the wall
        [0.05, 0.0, 0.5],     # beside it (its ray passes no wall point)
        [-0.05, 0.0, 0.29],   # in front of it
        [-0.05, 0.0, 0.302],  # behind it by less than tau
        [-0.05, 0.0, 0.0],    # at the camera (a hypothesis far off): on no ray
        [-0.05, 0.0, -0.5],   # behind the camera
    ])
    assert hidden(points, occ, tau=0.003).tolist() == [True, False, False, False, False, False]


def test_the_objects_own_points_and_what_lies_out_of_reach_hide_nothing():
    cloud = np.column_stack([np.linspace(-0.02, 0.02, 41), np.zeros(41), np.full(41, 0.5)])
    far_wall = _wall(1.0, 2.0)          # behind everything
    beside = _wall(-0.8, 0.3)           # in front, but on rays far from the cloud's
    assert occluders(np.vstack([cloud, far_wall, beside]), cloud, 0.001, 0.2) is None


@pytest.fixture(scope='module')
def hidden_brick():
    """Make a brick, its templates, a view of it and a wall in front hiding a third of it."""
    import open3d as o3d

    shape = o3d.geometry.TriangleMesh.create_box(0.12, 0.06, 0.03).translate([-0.06, -0.03, 0.0])
    mesh = Mesh(np.asarray(shape.vertices), np.asarray(shape.triangles, dtype=np.int64))
    tpl = stack([object_templates(mesh, SMALL)])
    R = Rotation.from_euler('xyz', [30, -20, 50], degrees=True).as_matrix()
    t = np.array([0.02, -0.01, 0.55]) - R @ tpl.centre[0]
    seen = MeshCamera(mesh).view(R, t)
    cut = np.quantile(seen[:, 0] / seen[:, 2], 0.33)
    wall = _wall(cut, 0.35)
    return tpl, R, t, seen[seen[:, 0] / seen[:, 2] >= cut], wall


def _judge(tpl, R, t, cloud, scene, scale=1.0):
    query, _ = query_surface(cloud)
    if scene is not None:
        query.occluders = occluders(scene, cloud, query.spacing, 0.2)
    points = scale * tpl.points[0]
    surface = Surface(points, tpl.normals[0], cKDTree(points), float(tpl.spacing[0]))
    expected = visible_points(tpl.visible[0], tpl.directions, tpl.centre[0], R, t)
    return judge(query, surface, expected, R, t, 0.003)


def test_a_hidden_third_costs_the_right_pose_nothing_once_its_occluder_is_seen(hidden_brick):
    tpl, R, t, cloud, wall = hidden_brick
    blind = _judge(tpl, R, t, cloud, None)
    seeing = _judge(tpl, R, t, cloud, np.vstack([wall, cloud]))   # the object's own points too
    assert blind.coverage < 0.8 and blind.unshown > 0.2
    assert seeing.coverage > 0.95 and seeing.unshown < 0.05
    assert seeing.n_expected < 0.8 * blind.n_expected


def test_an_occluder_does_not_excuse_a_smaller_object(hidden_brick):
    tpl, R, t, cloud, wall = hidden_brick
    right = _judge(tpl, R, t, cloud, wall)
    smaller = _judge(tpl, R, t, cloud, wall, scale=0.8)
    assert smaller.cost > 3 * right.cost


def test_the_fit_counts_the_surface_its_occluder_hid(hidden_brick):
    tpl, R, t, cloud, wall = hidden_brick
    blind = _judge(tpl, R, t, cloud, None)
    seeing = _judge(tpl, R, t, cloud, np.vstack([wall, cloud]))
    assert blind.n_hidden == 0 and blind.hidden_share == 0.0
    assert seeing.n_expected + seeing.n_hidden == blind.n_expected
    assert 0.2 < seeing.hidden_share < 0.5     # a third of the brick's view lies behind the wall
