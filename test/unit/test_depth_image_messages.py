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

"""Depth images and their CameraInfo read as DepthImages (pcrp_ros/depth_images.py)."""
import numpy as np
from pcrp_ros.conversions import CloudFormatError
from pcrp_ros.depth_images import camera_info_topic, depth_image, depth_metres
import pytest
from sensor_msgs.msg import CameraInfo, Image, RegionOfInterest
from std_msgs.msg import Header

DEPTH_MM = np.array([[0, 500, 1000], [1500, 65535, 250]], dtype=np.uint16)


def _image(values: np.ndarray, encoding: str, big_endian=False, pad: int = 0, frame='cam'):
    raw = values.astype(values.dtype.newbyteorder('>' if big_endian else '<'))
    rows = [r.tobytes() + bytes(pad) for r in raw]
    return Image(header=Header(frame_id=frame), height=raw.shape[0], width=raw.shape[1],
                 encoding=encoding, is_bigendian=int(big_endian),
                 step=raw.shape[1] * raw.itemsize + pad, data=b''.join(rows))


def _info(frame='cam', size=(3, 2), k=(600.0, 0.0, 1.0, 0.0, 610.0, 0.5, 0.0, 0.0, 1.0), **more):
    return CameraInfo(header=Header(frame_id=frame), width=size[0], height=size[1], k=list(k),
                      **more)


@pytest.mark.parametrize('big_endian', [False, True])
@pytest.mark.parametrize('pad', [0, 6])
def test_millimetres_and_metres_read_as_metres_with_no_depth_as_inf(big_endian, pad):
    expected = np.where(DEPTH_MM > 0, DEPTH_MM / 1000.0, np.inf)
    metres = DEPTH_MM / 1000.0
    metres[0, 0] = np.nan
    for msg in (_image(DEPTH_MM, '16UC1', big_endian, pad),
                _image(metres.astype(np.float32), '32FC1', big_endian, pad)):
        np.testing.assert_allclose(depth_metres(msg)[1], expected[1], rtol=1e-6)
        np.testing.assert_allclose(depth_image(msg, _info()).z, expected, rtol=1e-6)


@pytest.mark.parametrize('msg, reason', [
    (_image(DEPTH_MM.astype(np.uint8), 'rgb8'), 'bad_encoding'),
    (Image(height=2, width=3, encoding='16UC1', step=4, data=bytes(8)), 'bad_layout'),
    (Image(height=2, width=3, encoding='16UC1', step=6, data=bytes(10)), 'truncated_data'),
])
def test_unreadable_depth_images_say_why(msg, reason):
    with pytest.raises(CloudFormatError) as e:
        depth_metres(msg)
    assert e.value.reason == reason


def test_the_camera_info_gives_the_intrinsics_and_must_fit_the_image():
    image = depth_image(_image(DEPTH_MM, '16UC1'), _info())
    np.testing.assert_allclose(image.focal, [600.0, 610.0])
    np.testing.assert_allclose(image.centre, [1.0, 0.5])
    for info, reason in [(None, 'no_camera_info'), (_info(frame='other'), 'camera_info_mismatch'),
                         (_info(size=(6, 4)), 'camera_info_mismatch'),
                         (_info(k=[0.0] * 9), 'camera_info_mismatch')]:
        with pytest.raises(CloudFormatError) as e:
            depth_image(_image(DEPTH_MM, '16UC1'), info)
        assert e.value.reason == reason


def test_a_rectified_image_takes_p_as_image_geometry_does_with_binning_and_roi():
    # K is the raw (distorted) image's; a rectified image's own intrinsics are P's
    p = [580.0, 0.0, 1.5, 0.0, 0.0, 590.0, 0.25, 0.0, 0.0, 0.0, 1.0, 0.0]
    image = depth_image(_image(DEPTH_MM, '16UC1'), _info(p=p, d=[0.1, -0.2, 0.0, 0.0, 0.05]))
    np.testing.assert_allclose(image.focal, [580.0, 590.0])
    np.testing.assert_allclose(image.centre, [1.5, 0.25])
    # the full sensor 12 x 8, a 6 x 4 window at (2, 4) read out binned by two: 3 x 2 pixels
    windowed = _info(size=(12, 8), p=[580.0, 0.0, 5.0, 0.0, 0.0, 590.0, 7.0, 0.0, 0.0, 0.0, 1.0,
                                      0.0], binning_x=2, binning_y=2,
                     roi=RegionOfInterest(x_offset=2, y_offset=4, width=6, height=4))
    image = depth_image(_image(DEPTH_MM, '16UC1'), windowed)
    np.testing.assert_allclose(image.focal, [290.0, 295.0])
    np.testing.assert_allclose(image.centre, [1.5, 1.5])
    with pytest.raises(CloudFormatError) as e:
        depth_image(_image(DEPTH_MM, '16UC1'), _info(size=(12, 8), p=windowed.p))
    assert e.value.reason == 'camera_info_mismatch'


def test_camera_info_sits_beside_its_image():
    assert camera_info_topic('/camera/depth/image_rect_raw') == '/camera/depth/camera_info'
    assert camera_info_topic('depth') == 'camera_info'
