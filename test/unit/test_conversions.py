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

"""PointCloud2 <-> numpy for every layout a driver or segmenter may send."""
from hypothesis import given, settings, strategies as st
import numpy as np
from pcrp_ros.conversions import CloudFormatError, pointcloud2_to_xyz, xyz_to_pointcloud2
import pytest
from sensor_msgs.msg import PointCloud2, PointField
from std_msgs.msg import Header

TYPES = {
    PointField.FLOAT32: 'f4',
    PointField.FLOAT64: 'f8',
    PointField.INT16: 'i2',
    PointField.UINT8: 'u1',
    PointField.INT32: 'i4',
}


def build(
    points,
    xyz_type=PointField.FLOAT32,
    big_endian=False,
    order=('x', 'y', 'z'),
    extra=0,
    pad=0,
    height=1,
    row_pad=0,
):
    """Write a cloud by hand, independently of the module under test."""
    dt = np.dtype(TYPES[xyz_type]).newbyteorder('>' if big_endian else '<')
    names, formats, offsets, off = [], [], [], extra   # `extra` bytes of another field first
    for n in order:
        names.append(n)
        formats.append(dt)
        offsets.append(off)
        off += dt.itemsize
    step = off + pad
    rec = np.zeros(
        len(points),
        dtype={'names': names, 'formats': formats, 'offsets': offsets, 'itemsize': step},
    )
    for k, n in enumerate('xyz'):
        rec[n] = points[:, k]
    width = len(points) // height
    rows = rec.tobytes()
    row_step = width * step + row_pad
    data = b''.join(
        rows[r * width * step:(r + 1) * width * step] + b'\0' * row_pad for r in range(height)
    )
    fields = [
        PointField(name=n, offset=o, datatype=xyz_type, count=1) for n, o in zip(names, offsets)
    ]
    if extra:
        fields.append(PointField(name='intensity', offset=0, datatype=PointField.FLOAT32, count=1))
    return PointCloud2(
        header=Header(frame_id='f'),
        height=height,
        width=width,
        fields=fields,
        is_bigendian=big_endian,
        point_step=step,
        row_step=row_step,
        data=data,
        is_dense=False,
    )


@settings(max_examples=60, deadline=None)
@given(n=st.integers(1, 40), xyz_type=st.sampled_from([PointField.FLOAT32, PointField.FLOAT64]),
       big=st.booleans(), order=st.permutations(['x', 'y', 'z']), extra=st.sampled_from([0, 4]),
       pad=st.integers(0, 9), rows=st.sampled_from([1, 2]), row_pad=st.integers(0, 5))
def test_random_valid_layouts_round_trip(n, xyz_type, big, order, extra, pad, rows, row_pad):
    pts = np.random.default_rng(n).normal(size=(n * rows, 3)).astype(np.float32)
    got = pointcloud2_to_xyz(build(pts, xyz_type, big, tuple(order), extra, pad, rows, row_pad))
    np.testing.assert_array_equal(got, pts.astype(np.float64))


@pytest.mark.parametrize('xyz_type', [PointField.INT16, PointField.UINT8, PointField.INT32])
def test_integer_coordinates_are_read_as_they_are(xyz_type):
    pts = np.array([[1, 2, 3], [4, 5, 6]], dtype=float)
    np.testing.assert_array_equal(pointcloud2_to_xyz(build(pts, xyz_type)), pts)


def test_organised_clouds_with_nan_holes_drop_the_holes():
    pts = np.random.default_rng(0).normal(size=(12, 3)).astype(np.float32)
    pts[[2, 7]] = np.nan
    pts[5, 1] = np.inf
    got = pointcloud2_to_xyz(build(pts, height=3, row_pad=3))
    assert got.shape == (9, 3)


def test_writer_output_reads_back_with_extra_fields():
    pts = np.random.default_rng(1).normal(size=(30, 3))
    msg = xyz_to_pointcloud2(
        pts, Header(frame_id='cam'), np.float64, {'intensity': np.ones(30, np.float32)}
    )
    np.testing.assert_array_equal(pointcloud2_to_xyz(msg), pts)
    assert msg.header.frame_id == 'cam' and len(msg.fields) == 4


@pytest.mark.parametrize('damage, reason', [
    (lambda m: setattr(m, 'fields', [f for f in m.fields if f.name != 'y']), 'missing_field'),
    (lambda m: setattr(m, 'point_step', 8), 'bad_layout'),
    (lambda m: setattr(m, 'row_step', 4), 'bad_layout'),
    (lambda m: setattr(m, 'data', bytes(m.data)[:-5]), 'truncated_data'),
])
def test_bad_layouts_raise_with_their_reason(damage, reason):
    msg = build(np.ones((10, 3), np.float32))
    damage(msg)
    with pytest.raises(CloudFormatError) as err:
        pointcloud2_to_xyz(msg)
    assert err.value.reason == reason


def test_longer_data_is_accepted_and_empty_clouds_give_no_points():
    msg = build(np.ones((10, 3), np.float32))
    msg.data = bytes(msg.data) + b'\0' * 7
    assert pointcloud2_to_xyz(msg).shape == (10, 3)
    assert pointcloud2_to_xyz(build(np.zeros((0, 3), np.float32))).shape == (0, 3)
