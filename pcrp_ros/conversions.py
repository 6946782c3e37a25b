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
PointCloud2 <-> numpy and PoseResult -> geometry_msgs, without sensor_msgs_py.

Reading works on anything shaped like a PointCloud2 (rclpy messages and rosbags messages alike:
only the field names are used), so the node and the offline bag tools share one parser.

What counts as a valid cloud (anything else raises CloudFormatError with a ``reason``):
- fields named x, y and z exist, each of a PointField numeric type with count >= 1
  ('missing_field', 'bad_field_type'); only their first element is read;
- each of them fits inside point_step, and row_step >= width * point_step ('bad_layout');
- data holds at least row_step * height bytes ('truncated_data'). Longer data is accepted and
  the extra bytes ignored: the message definition fixes the size of a row, so trailing bytes
  cannot be mistaken for points, and refusing them would drop usable clouds from sloppy drivers.
Integer coordinates are converted to float as they are, with no unit scaling.
"""
from __future__ import annotations

import numpy as np

# sensor_msgs/PointField datatype constants, written out so this module needs no ROS import
# for reading (the bag tools may run where rclpy is importable but uninitialised).
INT8, UINT8, INT16, UINT16, INT32, UINT32, FLOAT32, FLOAT64 = range(1, 9)
_NUMPY_OF = {INT8: 'i1', UINT8: 'u1', INT16: 'i2', UINT16: 'u2', INT32: 'i4', UINT32: 'u4',
             FLOAT32: 'f4', FLOAT64: 'f8'}
_DATATYPE_OF = {np.dtype(v).newbyteorder('<'): k for k, v in _NUMPY_OF.items()}


class CloudFormatError(ValueError):
    """A PointCloud2 whose layout cannot be read. ``reason`` is a short stable key."""

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason = reason


def data_bytes(data) -> np.ndarray:
    """Return a message's data field as uint8, without a copy where it can."""
    try:
        return np.frombuffer(memoryview(data), dtype=np.uint8)
    except TypeError:  # a plain list of ints, as a hand-built message may hold
        return np.asarray(data, dtype=np.uint8)


def _field_views(msg, names=('x', 'y', 'z')) -> list[np.ndarray]:
    """(height, width) strided views of the named fields, after checking the layout."""
    fields = {}
    for f in msg.fields:
        fields.setdefault(f.name, f)  # the first of duplicated names wins
    missing = [n for n in names if n not in fields]
    if missing:
        raise CloudFormatError('missing_field', f"cloud has no field {', '.join(missing)} "
                                                f'(fields: {[f.name for f in msg.fields]})')
    height, width = int(msg.height), int(msg.width)
    point_step, row_step = int(msg.point_step), int(msg.row_step)
    order = '>' if msg.is_bigendian else '<'
    dtypes = []
    for n in names:
        f = fields[n]
        if f.datatype not in _NUMPY_OF or f.count < 1:
            raise CloudFormatError(
                'bad_field_type', f'field {n} has datatype {f.datatype} and count {f.count}'
            )
        dt = np.dtype(order + _NUMPY_OF[f.datatype])
        if f.offset + dt.itemsize > point_step:
            raise CloudFormatError(
                'bad_layout',
                f'field {n} at offset {f.offset} ({dt.itemsize} bytes) '
                f'does not fit in point_step {point_step}',
            )
        dtypes.append(dt)
    if height * width == 0:
        return [np.zeros((height, width), dtype=dt) for dt in dtypes]
    if row_step < width * point_step:
        raise CloudFormatError(
            'bad_layout',
            f'row_step {row_step} is less than width {width} x point_step {point_step}',
        )
    buf = data_bytes(msg.data)
    if len(buf) < row_step * height:
        raise CloudFormatError(
            'truncated_data',
            f'data has {len(buf)} bytes, row_step {row_step} x height {height} '
            f'needs {row_step * height}',
        )
    return [
        np.ndarray(
            (height, width),
            dtype=dt,
            buffer=buf,
            offset=fields[n].offset,
            strides=(row_step, point_step),
        )
        for n, dt in zip(names, dtypes)
    ]


def pointcloud2_to_xyz(msg, finite_only: bool = True) -> np.ndarray:
    """
    Read the cloud's points as an (N, 3) float64 array, in row-major order.

    NaN/Inf holes are dropped unless finite_only is false (then the caller can tell an all-NaN
    cloud from an empty one).
    """
    x, y, z = _field_views(msg)
    pts = np.stack([x.ravel(), y.ravel(), z.ravel()], axis=1).astype(np.float64)
    return pts[np.isfinite(pts).all(axis=1)] if finite_only else pts


def pointcloud2_to_grid(msg) -> np.ndarray:
    """Read an organized cloud's points as a (height, width, 3) float32 array, holes and all."""
    return np.stack(_field_views(msg), axis=-1).astype(np.float32, copy=False)


def pack_points(points, dtype=np.float32, extra_fields=None) -> tuple[list, int, bytes]:
    """
    Pack an unorganised cloud: fields [(name, offset, datatype, count)], point_step, bytes.

    The bytes are little-endian. extra_fields maps a name to an (N,) or (N, k) array, written
    after x, y, z in its own dtype.
    """
    pts = np.asarray(points, dtype=dtype).reshape(-1, 3)
    columns = [('x', pts[:, 0:1]), ('y', pts[:, 1:2]), ('z', pts[:, 2:3])]
    for name, values in (extra_fields or {}).items():
        values = np.asarray(values)
        columns.append((name, values.reshape(len(pts), -1)))
    fields, formats, offsets, offset = [], [], [], 0
    for name, values in columns:
        dt = values.dtype.newbyteorder('<')
        if dt not in _DATATYPE_OF:
            raise ValueError(f'field {name}: dtype {values.dtype} has no PointField datatype')
        count = values.shape[1]
        fields.append((name, offset, _DATATYPE_OF[dt], count))
        formats.append((dt, (count,)) if count > 1 else dt)
        offsets.append(offset)
        offset += dt.itemsize * count
    record = np.dtype(
        {
            'names': [c[0] for c in columns],
            'formats': formats,
            'offsets': offsets,
            'itemsize': offset,
        }
    )
    out = np.empty(len(pts), dtype=record)
    for name, values in columns:
        out[name] = values if values.shape[1] > 1 else values[:, 0]
    return fields, offset, out.tobytes()


def xyz_to_pointcloud2(points, header, dtype=np.float32, extra_fields=None):
    """Make an unorganised (height 1), little-endian sensor_msgs/PointCloud2 of the points."""
    from sensor_msgs.msg import PointCloud2, PointField

    fields, point_step, data = pack_points(points, dtype, extra_fields)
    n = len(data) // point_step if point_step else 0
    msg = PointCloud2()
    msg.header = header
    msg.height, msg.width = 1, n
    msg.fields = [
        PointField(name=name, offset=off, datatype=dt, count=count)
        for name, off, dt, count in fields
    ]
    msg.is_bigendian = False
    msg.point_step, msg.row_step = point_step, point_step * n
    msg.data = data
    msg.is_dense = bool(np.isfinite(np.asarray(points, dtype=np.float64)).all())
    return msg


def pose_to_msg(result):
    """geometry_msgs/Pose of a PoseResult. Pose has no scale: it is dropped (1 in metric mode)."""
    from geometry_msgs.msg import Pose

    q = np.asarray(result.quaternion, dtype=np.float64)
    q = q / np.linalg.norm(q)
    pose = Pose()
    pose.position.x, pose.position.y, pose.position.z = (
        float(v) for v in np.asarray(result.translation)
    )
    pose.orientation.x, pose.orientation.y, pose.orientation.z, pose.orientation.w = (
        float(v) for v in q
    )
    return pose


def pose_stamped(result, header):
    from geometry_msgs.msg import PoseStamped

    return PoseStamped(header=header, pose=pose_to_msg(result))


def aligned_points(result, gallery_points) -> np.ndarray:
    """Gallery points moved into the query's frame by the result's pose."""
    g = np.asarray(gallery_points, dtype=np.float64)
    return result.scale * g @ np.asarray(result.rotation, dtype=np.float64).T + np.asarray(
        result.translation
    )


def detections_msg(result, header, gallery_points=None):
    """
    Make a vision_msgs/Detection3DArray of one detection (None without vision_msgs).

    gallery_points: the answered object's points in its own frame. Its bounding box then goes in
    bbox: the object's box, turned with it, centred where the box's centre lands (an object's
    origin is seldom its box's centre: a mug's is often its base); else only the pose, size 0.
    """
    try:
        from vision_msgs.msg import Detection3D, Detection3DArray, ObjectHypothesisWithPose
    except ImportError:
        return None
    hyp = ObjectHypothesisWithPose()
    hyp.hypothesis.class_id = result.gallery_id
    hyp.hypothesis.score = float(result.confidence)   # how likely the answer is right
    hyp.pose.pose = pose_to_msg(result)
    det = Detection3D(header=header)
    det.results = [hyp]
    det.bbox.center = pose_to_msg(result)
    if gallery_points is not None and len(gallery_points):
        g = np.asarray(gallery_points, dtype=np.float64)
        lo, hi = g.min(axis=0), g.max(axis=0)
        centre = aligned_points(result, ((lo + hi) / 2)[None])[0]
        p = det.bbox.center.position
        p.x, p.y, p.z = (float(v) for v in centre)
        s = det.bbox.size
        s.x, s.y, s.z = (float(v) for v in result.scale * (hi - lo))
    det.id = result.gallery_id
    return Detection3DArray(header=header, detections=[det])
