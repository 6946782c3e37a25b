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

"""Known objects from a camera (pcrp_core/instance): each step on shapes whose answer is known."""
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import open3d as o3d
from pcrp_core.confidence import expected_calibration_error, fit_calibration, reliability
from pcrp_core.config import InstanceOptions
from pcrp_core.geometry import rotation_angle_deg, rotation_taking
from pcrp_core.instance import hypotheses, local_shape
from pcrp_core.instance.matcher import Candidate, InstanceMatcher, looks_again
from pcrp_core.instance.shape_index import ShapeIndex
from pcrp_core.instance.signatures import ray_frame, SECTORS, shift_costs, signature
from pcrp_core.instance.templates import (
    extent, object_templates, stack, Templates, TemplateSettings
)
from pcrp_core.instance.verification import (distances, Fit, judge, query_surface, Surface,
                                             visible_points)
from pcrp_core.sources.camera import look_at, Mesh, MeshCamera
from pcrp_core.sources.household import union
from pcrp_core.threads import one_open3d_thread
import pytest
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

SMALL = TemplateSettings(views=16, visibility_directions=128, surface_points=512, view_points=256)


def _mesh(shape) -> Mesh:
    return Mesh(
        np.asarray(shape.vertices, dtype=np.float64), np.asarray(shape.triangles, dtype=np.int64)
    )


def box(x, y, z) -> Mesh:
    m = o3d.geometry.TriangleMesh.create_box(x, y, z)
    return _mesh(m.translate([-x / 2, -y / 2, 0.0]))


def test_a_roll_about_the_line_of_sight_shifts_the_signature_by_as_many_sectors():
    rng = np.random.default_rng(0)
    pts = rng.normal(size=(2000, 3)) * [0.05, 0.02, 0.01] + [0.0, 0.0, 0.6]
    frame = ray_frame(pts.mean(0), np.array([1.0, 0.0, 0.0]))
    turn = Rotation.from_rotvec(frame[2] * np.radians(7 * 360 / SECTORS)).as_matrix()
    turned = (pts - pts.mean(0)) @ turn.T + pts.mean(0)
    costs = shift_costs(
        signature(turned, frame, pts.mean(0)), signature(pts, frame, pts.mean(0))[None]
    )
    assert int(np.argmin(costs[0])) == 7 and costs[0].min() < 1e-4 < costs[0, 0]


def test_shift_costs_are_the_mean_squared_differences_of_the_rolled_signatures():
    rng = np.random.default_rng(1)
    query, views = rng.random((SECTORS, 2)) * 0.1, rng.random((5, SECTORS, 2)) * 0.1
    views[2, 4:11] = 0.0   # sectors a view holds no point in
    costs = shift_costs(query, views, depth_weight=0.3)
    for v in range(len(views)):
        for s in range(SECTORS):
            diff = np.roll(views[v], s, axis=0) - query
            expected = (diff[:, 0] ** 2).mean() + 0.3 * (diff[:, 1] ** 2).mean()
            assert costs[v, s] == pytest.approx(expected, rel=1e-9, abs=1e-15)


def test_taking_and_about_are_the_rotations_they_say():
    a, b = np.array([0.0, 0.6, 0.8]), np.array([1.0, 0.0, 0.0])
    R = rotation_taking(a, b)
    np.testing.assert_allclose(R @ a, b, atol=1e-12)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    np.testing.assert_allclose(rotation_taking(a, -a) @ a, -a, atol=1e-12)
    np.testing.assert_allclose(rotation_taking(2 * a, b) @ a, b, atol=1e-12)
    Rz = hypotheses.about(np.array([0.0, 0.0, 1.0]), [np.pi / 2])[0]
    np.testing.assert_allclose(Rz @ [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], atol=1e-12)


@pytest.fixture(scope='module')
def brick():
    """Make a 12 x 6 x 3 cm brick, its templates, and a view of it from a known pose."""
    mesh = box(0.12, 0.06, 0.03)
    tpl = stack([object_templates(mesh, SMALL)])
    R = Rotation.from_euler('xyz', [30, -20, 50], degrees=True).as_matrix()
    t = np.array([0.02, -0.01, 0.55]) - R @ tpl.centre[0]
    seen = MeshCamera(mesh).view(R, t)
    return mesh, tpl, R, t, seen


def test_templates_survive_a_round_trip_through_arrays(brick):
    _, tpl, _, _, _ = brick
    again = Templates.from_arrays({k: np.asarray(v) for k, v in tpl.to_arrays().items()})
    np.testing.assert_array_equal(again.visible, tpl.visible)
    np.testing.assert_allclose(again.signatures, tpl.signatures, rtol=1e-6)
    assert len(again) == 1 and tpl.diameter[0] == pytest.approx(
        np.linalg.norm([0.12, 0.06, 0.03]), rel=1e-3
    )


def test_visibility_looked_up_for_a_pose_is_the_side_facing_the_camera(brick):
    mesh, tpl, R, t, _ = brick
    seen = np.zeros(len(tpl.points[0]), bool)
    seen[visible_points(tpl.visible[0], tpl.directions, tpl.centre[0], R, t)] = True
    truth = MeshCamera(mesh).sees(-R.T @ t, tpl.points[0])     # ray cast from the camera itself
    assert 0.2 < truth.mean() < 0.8
    assert (seen & truth).sum() > 0.9 * truth.sum() and (seen & ~truth).sum() < 0.1 * seen.sum()


def test_the_true_pose_costs_less_than_a_slightly_wrong_one_and_a_smaller_brick(brick):
    mesh, tpl, R, t, seen = brick
    query, noise = query_surface(seen)
    surface = Surface(
        tpl.points[0],
        tpl.normals[0],
        __import__('scipy').spatial.cKDTree(tpl.points[0]),
        float(tpl.spacing[0]),
    )
    expected = visible_points(tpl.visible[0], tpl.directions, tpl.centre[0], R, t)
    right = judge(query, surface, expected, R, t, 0.003)
    off = Rotation.from_rotvec([0.0, 0.0, np.radians(8)]).as_matrix() @ R
    wrong = judge(query, surface, expected, off, t, 0.003)
    assert (
        right.cost < 0.05
        and right.fit > 0.95
        and right.coverage > 0.9
        and wrong.cost > 3 * right.cost
    )
    assert noise < 1e-3          # a noiseless render: points lie on their planes
    small = 0.8 * tpl.points[0]  # a brick 20 % smaller, posed the same way, cannot show all of it
    surface_small = Surface(
        small, tpl.normals[0], __import__('scipy').spatial.cKDTree(small), float(tpl.spacing[0])
    )
    assert judge(query, surface_small, expected, R, t, 0.003).cost > 5 * right.cost


def test_an_occluded_view_of_a_large_object_shortlists_it_before_a_small_one():
    # per axis (log metres) the cloud is 0.3 smaller than the large object's only view and 0.2
    # larger than the small one's: compared symmetrically the small one is nearer; an occluder
    # can cut a view down, nothing makes it show more, so at half weight the large one is
    large, small = np.log([0.20, 0.10, 0.05]), np.log([0.20, 0.10, 0.05]) - 0.5
    matcher = InstanceMatcher(SimpleNamespace(shapes=np.stack([large, small])[:, None, :],
                                              directions=None))
    cloud = large - 0.3
    even, half = InstanceOptions(smaller_weight=1.0), InstanceOptions(smaller_weight=0.5)
    assert matcher.shortlist(cloud, even).tolist() == [1, 0]
    assert matcher.shortlist(cloud, half).tolist() == [0, 1]


def test_the_shape_gap_is_how_far_a_cloud_is_from_each_objects_nearest_view():
    # the confidence weighs it: an object the gallery lacks is often answered by one of another
    # size; a cloud smaller than a view counts smaller_weight times (an occluder cuts views down)
    view = np.log([0.20, 0.10, 0.05])
    shapes = np.stack([[view, view + 1.0], [view - 0.5, view - 2.0]])
    matcher = InstanceMatcher(SimpleNamespace(shapes=shapes, directions=None))
    weight = InstanceOptions(smaller_weight=0.5).smaller_weight
    assert np.allclose(matcher.shapes.gaps(view, weight), [0.0, 0.5 * np.sqrt(3)])
    assert np.allclose(matcher.shapes.gaps(view - 0.5, weight), [0.25 * np.sqrt(3), 0.0])


@pytest.mark.parametrize('weight', [0.5, 1.0, 2.0])
def test_the_shape_search_of_a_large_gallery_finds_what_a_scan_of_every_view_finds(weight):
    # a tree of the views answers large galleries; its search must widen until no view it has
    # not returned could beat what it found, whatever the weight of being smaller
    rng = np.random.default_rng(5)
    centres = rng.normal(scale=0.6, size=(3000, 1, 3))
    shapes = centres + rng.normal(scale=0.15, size=(3000, 24, 3))
    shapes[7] = shapes[8]                       # two objects of one shape: ties go by index
    tree, scan = ShapeIndex(shapes, scan_views=0), ShapeIndex(shapes, scan_views=10**9)
    assert tree._tree is not None and scan._tree is None
    for n in range(40):
        query = shapes[rng.integers(3000), rng.integers(24)] + rng.normal(scale=0.1, size=3)
        if n == 0:
            query = shapes[7, 3]
        exclude = rng.choice(3000, 20, replace=False) if n % 2 else ()
        k = (1, 8, 50)[n % 3]
        got = tree.nearest(query, k, weight, exclude)
        want = scan.nearest(query, k, weight, exclude)
        assert got[0].tolist() == want[0].tolist()
        np.testing.assert_allclose(got[1], want[1])
        all_gaps = scan.gaps(query, weight)
        all_gaps[list(exclude)] = np.inf
        np.testing.assert_allclose(want[1], np.sort(all_gaps)[:k])
    assert tree.nearest(shapes[7, 3], 2, weight)[0].tolist() == [7, 8]
    assert len(tree.nearest(shapes[0, 0], 5, weight, range(3000))[0]) == 0


def test_distances_to_a_plane_do_not_count_the_sampling_gap():
    grid = np.stack(
        np.meshgrid(np.arange(0, 0.1, 0.01), np.arange(0, 0.1, 0.01), [0.0]), -1
    ).reshape(-1, 3)
    plane = Surface(
        grid,
        np.tile([0.0, 0.0, 1.0], (len(grid), 1)),
        __import__('scipy').spatial.cKDTree(grid),
        0.01,
    )
    # 7 mm from the nearest grid point, 2 mm off the plane
    between = np.array([[0.045, 0.055, 0.002]])
    assert distances(between, plane)[0] == pytest.approx(0.002)


def test_view_hypotheses_include_the_true_pose_of_a_brick(brick):
    _, tpl, R, t, seen = brick
    view = hypotheses.QueryView(seen)
    Rs, ts, _ = hypotheses.from_views(
        view, tpl.frames[0], tpl.signatures[0], tpl.view_centres[0], 8
    )
    # a brick has four poses that look alike (its symmetries): any of them is right
    sym = [np.diag(d) for d in ([1, 1, 1], [1, -1, -1], [-1, 1, -1], [-1, -1, 1])]
    best = min(rotation_angle_deg(Rh, R @ S) for Rh in Rs for S in sym)
    assert best < 25.0


@pytest.mark.parametrize('up_object', [None, np.array([0.0, 0.0, 1.0])])
def test_a_nubbed_brick_answered_turned_half_about_its_height_is_turned_back(up_object):
    # a brick with a nub at one end looks, turned half about its height, like itself a few
    # millimetres off; so answered, the half turns find the true pose. With gravity given only
    # that turn is tried, and the up axis stays where it was
    mesh = union(box(0.12, 0.06, 0.03), box(0.02, 0.02, 0.01).moved(np.eye(3), [0.04, 0.0, 0.03]))
    tpl = stack([object_templates(mesh, SMALL)])
    R = Rotation.from_euler('xyz', [160, 10, 30], degrees=True).as_matrix()
    t = np.array([0.01, 0.02, 0.55]) - R @ tpl.centre[0]
    points = MeshCamera(mesh).view(R, t)
    query, _ = query_surface(points)
    matcher = InstanceMatcher(tpl)
    c, surface = tpl.centre[0], matcher.surface(0)[0]
    turned = R @ np.diag([-1.0, -1.0, 1.0])
    t_turned = t + (R - turned) @ c
    expected = visible_points(tpl.visible[0], tpl.directions, c, turned, t_turned)
    answer = Candidate(
        0, turned, t_turned, judge(query, surface, expected, turned, t_turned, 0.003)
    )
    source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    back = matcher.best_half_turn(answer, query, source, 0.003, InstanceOptions(), up_object)
    angle = rotation_angle_deg(back.R, R)
    assert angle < 2.0 and back.fit.cost < 0.5 * answer.fit.cost
    assert np.linalg.norm(back.t + back.R @ c - (t + R @ c)) < 0.002
    if up_object is not None:
        np.testing.assert_allclose(back.R @ up_object, R @ up_object, atol=0.02)


def test_upright_hypotheses_keep_the_up_axis_on_the_given_up():
    tpl_cameras = np.array([[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]])
    view = hypotheses.QueryView(
        np.random.default_rng(1).normal(size=(200, 3)) * 0.02 + [0, 0, 0.6]
    )
    up = np.array([0.0, -0.8, -0.6])
    R, t, v = hypotheses.upright(
        view, up, np.array([0.0, 0.0, 1.0]), tpl_cameras, np.zeros((3, 3)), 12
    )
    np.testing.assert_allclose(R @ [0.0, 0.0, 1.0], np.tile(up, (12, 1)), atol=1e-12)
    assert len(set(np.round(np.degrees(np.arctan2(R[:, 1, 0], R[:, 0, 0]))))) == 12


def test_a_calibration_is_as_right_as_it_says_on_data_drawn_from_it():
    rng = np.random.default_rng(0)
    x = rng.normal(size=4000)
    right = rng.random(4000) < 1 / (1 + np.exp(-2.0 * x))
    cal = fit_calibration([{'x': v} for v in x], right, ('x',))
    p = np.array([cal.probability({'x': v}) for v in x])
    assert expected_calibration_error(p, right) < 0.03
    assert all(abs(c - r) < 0.1 for c, r, n in reliability(p, right) if n > 100)
    with pytest.raises(ValueError, match='both right and wrong'):
        fit_calibration([{'x': 0.0}, {'x': 1.0}], [True, True], ('x',))


def test_look_at_puts_the_target_on_the_optical_axis():
    R, t = look_at(np.array([0.3, -0.4, 0.5]), np.array([0.01, 0.02, 0.03]))
    p = R @ [0.01, 0.02, 0.03] + t
    assert abs(p[0]) < 1e-12 and abs(p[1]) < 1e-12 and p[2] > 0


def lumpy(seed: int) -> Mesh:
    """Make a 16 cm egg with six bumps: curved all over, as most things a robot grasps are."""
    sphere = o3d.geometry.TriangleMesh.create_sphere(0.05, 24)
    rng = np.random.default_rng(seed)
    u = np.asarray(sphere.vertices) / 0.05
    bumps = rng.normal(size=(6, 3))
    bumps /= np.linalg.norm(bumps, axis=1, keepdims=True)
    near = np.exp(-((np.linalg.norm(u[:, None] - bumps[None], axis=2) / 0.5) ** 2))
    r = 0.05 + near @ rng.uniform(0.01, 0.025, 6)
    sphere.vertices = o3d.utility.Vector3dVector(u * r[:, None] * [1.4, 1.0, 0.8])
    return _mesh(sphere)


@pytest.fixture(scope='module')
def hidden_egg():
    """Make a lumpy egg, its templates, and a view of it with a third hidden by something."""
    mesh = lumpy(0)
    tpl = stack([object_templates(mesh, SMALL)])
    R = Rotation.random(random_state=0).as_matrix()
    t = np.array([0.01, 0.02, 0.5]) - R @ tpl.centre[0]
    seen = MeshCamera(mesh).view(R, t)
    return tpl, R, t, seen[seen[:, 0] < np.quantile(seen[:, 0], 0.67)]


def test_local_shape_places_a_partly_hidden_object_that_was_answered_wrongly(hidden_egg):
    # the answer it is given is the object turned a quarter: matched local shape finds the true
    # pose although the visible part's centroid is not the object's
    tpl, R, t, points = hidden_egg
    matcher = InstanceMatcher(tpl)
    query, _ = query_surface(points)
    source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    opts = InstanceOptions()
    wrong = R @ Rotation.from_euler('x', 90, degrees=True).as_matrix()
    answer = matcher.verify(0, wrong, t, query, 0.003, opts)
    with one_open3d_thread():
        order = matcher.from_local_shape([answer], [0], points, query, source, 0.003, opts)
    best = order[0]
    assert len(order) == 1 and best.fit.cost < 0.5 * answer.fit.cost
    assert rotation_angle_deg(best.R, R) < 3.0
    c = tpl.centre[0]
    assert np.linalg.norm(best.t + best.R @ c - (t + R @ c)) < 0.003


def _described(features: np.ndarray) -> local_shape.LocalShape:
    return local_shape.LocalShape(o3d.geometry.PointCloud(), features, (features ** 2).sum(1))


def test_local_shape_matches_are_the_features_mutual_nearest_both_ways():
    rng = np.random.default_rng(3)
    cloud, obj = rng.uniform(0, 100, (60, 33)), rng.uniform(0, 100, (400, 33))
    obj[::7][:40] = cloud[:40] + rng.normal(scale=1.0, size=(40, 33))    # 40 surely mutual
    pairs = local_shape.matches(_described(cloud), _described(obj))
    nearest = cKDTree(obj).query(cloud)[1]
    back = cKDTree(cloud).query(obj)[1]
    mutual = [(i, j) for i, j in enumerate(nearest) if back[j] == i]
    assert len(mutual) >= 40 and pairs.tolist() == [list(m) for m in mutual]


def test_local_shape_keeps_every_nearest_match_when_too_few_are_mutual():
    # every cloud point is nearest one object point, which is nearest only one of them: RANSAC
    # would have one match to draw from, so it gets all of them, as Open3D's matcher gives
    rng = np.random.default_rng(4)
    obj = np.vstack([np.full((1, 33), 50.0), rng.uniform(200, 300, (100, 33))])
    cloud = 50.0 + rng.normal(scale=1.0, size=(30, 33))
    pairs = local_shape.matches(_described(cloud), _described(obj))
    assert pairs.tolist() == [[i, 0] for i in range(30)]


def test_local_shape_of_nothing_matches_nothing_and_poses_nothing():
    empty, some = _described(np.zeros((0, 33))), _described(np.ones((5, 33)))
    assert local_shape.matches(empty, some).shape == (0, 2)
    R, t = local_shape.pose(empty, some, 0.0075, 100, seed=0)
    assert np.array_equal(R, np.eye(3)) and np.array_equal(t, np.zeros(3))


def test_local_shape_is_looked_for_only_when_the_answer_fits_worse_than_its_cost(hidden_egg):
    tpl, _, _, points = hidden_egg
    matcher = InstanceMatcher(tpl)
    ran = {}
    for cost in (0.0, float('inf')):
        timings = {}
        matcher.match(points, InstanceOptions(local_shape_cost=cost), timings=timings)
        ran[cost] = 'local_shape' in timings
    assert ran == {0.0: True, float('inf'): False}


def test_a_partly_hidden_answer_is_looked_for_again_at_the_lower_cost():
    opts = InstanceOptions(local_shape_cost=0.5, local_shape_cost_hidden=0.25)
    fit = Fit(0.3, 0.1, 0.2, 0.9, 0.8, 0.001, n_expected=80)
    assert not looks_again(fit, opts)                                  # seen whole, fits well
    assert looks_again(replace(fit, n_hidden=20), opts)                # a fifth hidden
    assert not looks_again(replace(fit, n_hidden=5), opts)             # barely hidden
    assert not looks_again(replace(fit, cost=0.2, n_hidden=20), opts)  # hidden, fits well
    assert looks_again(replace(fit, cost=0.6), opts)                   # fits poorly either way


def test_a_scene_hiding_part_of_the_answer_has_it_looked_for_again(hidden_egg):
    tpl, _, _, points = hidden_egg
    # a wall in front of the egg's cut-off side: the rays beyond the kept points' edge
    edge = float((points[:, 0] / points[:, 2]).max())
    x, y = np.meshgrid(np.arange(edge + 0.002, edge + 0.3, 0.002), np.arange(-0.3, 0.3, 0.002))
    wall = 0.3 * np.column_stack([x.ravel(), y.ravel(), np.ones(x.size)])
    opts = InstanceOptions(local_shape_cost=float('inf'), local_shape_cost_hidden=0.0)
    ran = {}
    for name, scene in (('blind', None), ('seeing', np.vstack([wall, points]))):
        timings = {}
        with one_open3d_thread():
            InstanceMatcher(tpl).match(points, opts, timings=timings, scene=scene)
        ran[name] = 'local_shape' in timings
    assert ran == {'blind': False, 'seeing': True}


def test_a_views_extent_bounds_its_objects_diameter_from_below_whatever_strays_in():
    mesh = lumpy(1)
    camera = MeshCamera(mesh)
    for seed in range(5):
        R = Rotation.random(random_state=seed).as_matrix()
        seen = camera.view(R, np.array([0.0, 0.0, 0.5]))
        assert 0.5 * mesh.diameter < extent(seen) <= mesh.diameter
        # a few points off the segment's edge (a flying pixel, a bit of the table) do not count
        strays = seen[:3] + [0.0, 0.0, 2 * mesh.diameter]
        assert extent(np.vstack([seen, strays])) <= mesh.diameter


def test_local_shape_leaves_out_objects_smaller_than_the_view(hidden_egg, monkeypatch):
    _, _, _, points = hidden_egg
    egg = lumpy(0)
    small = Mesh(0.5 * egg.vertices, egg.triangles)
    matcher = InstanceMatcher(stack([object_templates(m, SMALL) for m in (egg, small)]))
    tried = []
    pose = local_shape.pose
    monkeypatch.setattr(local_shape, 'pose', lambda c, o, *a, **k: tried.append(o) or pose(
        c, o, *a, **k))
    for share, expected in ((0.9, [0]), (0.0, [0, 1])):
        opts = InstanceOptions(local_shape_cost=0.0, local_shape_min_diameter=share)
        tried.clear()
        with one_open3d_thread():
            matcher.match(points, opts)
        shapes = [matcher.local_shape(i, opts.local_shape_voxel, opts.local_shape_radius)
                  for i in expected]
        assert sorted(map(id, tried)) == sorted(map(id, shapes))


def test_a_warm_matcher_makes_no_object_features_for_a_poor_fit(hidden_egg, monkeypatch):
    tpl, _, _, points = hidden_egg
    made = []
    of_object = local_shape.of_object
    monkeypatch.setattr(local_shape, 'of_object', lambda *a: made.append(1) or of_object(*a))
    opts = InstanceOptions(local_shape_cost=0.0)
    for warm, expected in ((False, 1), (True, 0)):
        matcher = InstanceMatcher(tpl)
        if warm:
            matcher.warm(opts)
        made.clear()
        with one_open3d_thread():
            matcher.match(points, opts)
        assert len(made) == expected
