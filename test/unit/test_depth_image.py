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

"""A camera's organized depth cloud read as the image it is (instance/depth_image.py)."""
import numpy as np
from pcrp_core.instance.depth_image import DepthImage
from pcrp_core.instance.occlusion import hidden, occluders, seen_from
import pytest

FOCAL, CENTRE, SHAPE = np.array([580.0, 585.0]), np.array([322.3, 237.9]), (480, 640)


def _organized(z: np.ndarray, focal=FOCAL, centre=CENTRE) -> np.ndarray:
    """Make the organized cloud (rows, columns, 3) a pinhole camera measures of depths z."""
    rows, cols = np.indices(z.shape)
    return np.stack([(cols - centre[0]) / focal[0] * z, (rows - centre[1]) / focal[1] * z, z],
                    axis=-1).astype(np.float32)


def _scene() -> np.ndarray:
    """Make depths: a wall at 1 m, a box at 0.6 m in front of it, holes."""
    z = np.full(SHAPE, 1.0)
    z[200:300, 250:400] = 0.6
    z[::9, ::4] = np.nan
    return z


def test_an_organized_pinhole_cloud_is_read_with_its_intrinsics_and_nothing_lost():
    points = _organized(_scene())
    image = DepthImage.from_organized(points)
    assert image is not None
    np.testing.assert_allclose(image.focal, FOCAL, rtol=1e-5)
    np.testing.assert_allclose(image.centre, CENTRE, atol=1e-2)
    measured = points.reshape(-1, 3)
    measured = measured[np.isfinite(measured).all(axis=1)]
    np.testing.assert_allclose(image.points(), measured, atol=1e-5)
    again = DepthImage.from_points(image.points(), image.focal, image.centre, SHAPE)
    np.testing.assert_array_equal(again.z, image.z)


def test_clouds_that_are_no_pinhole_image_stay_lists_of_points():
    points = _organized(_scene())
    shuffled = points.reshape(-1, 3)[np.random.default_rng(0).permutation(points[..., 0].size)]
    assert DepthImage.from_organized(shuffled.reshape(points.shape)) is None
    assert DepthImage.from_organized(np.full((48, 64, 3), np.nan, np.float32)) is None
    assert DepthImage.from_organized(points[:, 300:301]) is None     # one column: no fit


def test_a_window_off_the_image_keeps_nothing_and_hides_nothing():
    image = DepthImage.from_organized(_organized(_scene()))
    off = image.crop(np.array([2.0, 2.0]), np.array([3.0, 3.0]), far=5.0)
    assert off.z.size == 0
    cloud = np.array([[2.5, 2.5, 1.0], [2.51, 2.5, 1.0]])     # on rays the camera does not have
    assert occluders(image, cloud, 0.003, 0.2) is None


def test_the_image_hides_what_its_points_hide():
    z = _scene()
    image = DepthImage.from_organized(_organized(z))
    # an object behind the box, seen beside it: its cloud is the wall's pixels right of the box
    cloud = _organized(np.full(SHAPE, 0.9))[190:310, 400:460].reshape(-1, 3).astype(np.float64)
    by_points = occluders(image.points(), cloud, 0.004, 0.3)
    by_image = occluders(image, cloud, 0.004, 0.3)
    rng = np.random.default_rng(1)
    rays = rng.uniform([-0.3, -0.3], [0.5, 0.3], (20000, 2))
    depth = rng.uniform(0.4, 1.2, 20000)
    probes = np.column_stack([rays * depth[:, None], depth])
    a, b = hidden(probes, by_points, 0.003), hidden(probes, by_image, 0.003)
    assert 0.05 < a.mean() < 0.5
    assert np.mean(a == b) > 0.98


def test_an_image_seen_from_elsewhere_than_its_camera_becomes_points():
    image = DepthImage.from_organized(_organized(_scene()))
    assert seen_from(image, np.zeros(3)) is image
    moved = seen_from(image, np.array([0.1, 0.0, 0.0]))
    np.testing.assert_allclose(moved, image.points() - [0.1, 0.0, 0.0])


def test_zero_and_nan_depths_are_nothing_measured_and_hide_nothing():
    z = np.full((48, 64), 0.5, dtype=np.float32)
    z[:, :32] = 0.0
    z[:10] = np.nan
    image = DepthImage(z, [60.0, 60.0], [31.5, 23.5])
    assert np.isinf(image.z[:, :32]).all() and np.isinf(image.z[:10]).all()
    assert len(image.points()) == 38 * 32
    cloud = np.array([[0.05, 0.05, 0.8], [0.06, 0.05, 0.8]])           # right half, behind 0.5
    behind_zeros = np.array([[-0.2, 0.1, 0.9]])
    occ = occluders(image, cloud, 0.01, 0.3)
    assert not hidden(behind_zeros, occ, 0.003).any()


@pytest.mark.parametrize('z, focal, said', [
    (np.full((4, 4), 700, np.uint16), [60.0, 60.0], 'millimetres'),   # a raw 16UC1 image
    (np.ones(16), [60.0, 60.0], 'rows, columns'),
    (np.ones((4, 4)), [0.0, 60.0], 'focal lengths'),
    (np.ones((4, 4)), [np.nan, 60.0], 'focal lengths'),
])
def test_an_image_that_cannot_be_metres_from_a_pinhole_is_refused_saying_why(z, focal, said):
    with pytest.raises(ValueError, match=said):
        DepthImage(z, focal, [2.0, 2.0])
