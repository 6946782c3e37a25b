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
What a segmenter may send: a catalogue of bad (and oddly encoded good) PointCloud2 messages.

Each comes with what the node is allowed to do with it; a runner feeds them to a live node.

The same catalogue drives the test suite and `python -m tools robustness`, so every row of
docs/results/ROBUSTNESS.md is also a passing test. Each case is built from one good cloud: what
a depth camera sees of a gallery object, in the camera's optical frame (z forward).
"""
from __future__ import annotations

import copy
from dataclasses import dataclass
import time
from typing import Callable

import numpy as np
from pcrp_core.geometry import rotation_angle_deg
from pcrp_core.sources.views import random_rotation, sensor_view
from pcrp_ros.conversions import FLOAT32, xyz_to_pointcloud2

ANSWERED = 'answered'        # pose published, with the right gallery ID and a small rotation error
# pose published, not the source object's (allowed only where there is none to hold it to: a
# sphere, a cube)
ANY_ANSWER = 'answered_any'


@dataclass(frozen=True)
class GoodCloud:
    points: np.ndarray       # (N, 3) in the camera frame
    gallery_id: str
    rotation: np.ndarray     # true rotation of the gallery object in the camera frame


@dataclass(frozen=True)
class Case:
    name: str
    what: str
    make: Callable[[GoodCloud, object], object]     # (good cloud, header) -> PointCloud2
    allowed: frozenset  # outcomes: ANSWERED, ANY_ANSWER or "rejected:<reason>"


def good_cloud(model, seed: int = 3, gallery_index: int = 0) -> GoodCloud:
    """One side of a gallery object at a random pose about three radii in front of the camera."""
    rng = np.random.default_rng(seed)
    gid = model.gallery_ids[gallery_index]
    pts = model.gallery_cloud(gid).astype(np.float64)
    pts = pts - pts.mean(0)
    radius = float(np.linalg.norm(pts, axis=1).max())
    R = random_rotation(rng)
    posed = pts @ R.T + [0.1 * radius, -0.1 * radius, 3.0 * radius]
    return GoodCloud(
        sensor_view(posed, np.zeros(3), rng, 0.003 * radius).astype(np.float64), gid, R
    )


def judged_good_cloud(model, max_error: float = 10.0, seeds=range(3, 9)) -> GoodCloud:
    """
    Return a good_cloud of the first gallery object the model answers right from every side tried.

    CaseRunner judges an answer by its rotation alone, which a symmetric object fails at any of
    its equivalent poses (the shipped model's first object is a can), and so does an object that
    is symmetric only from some sides (a mug with its handle hidden): the answer then flips between
    equally good poses at the slightest change to the cloud. An object answered right within
    max_error at each of several random rotations (seeds), each also jittered by 0.1 mm and
    rounded to float32 as a PointCloud2 carries it, has no such side. The catalogue also moves
    the cloud 1 km away (one_km) and judges it the same way; the shipped model answers some
    objects that far off as a look-alike (its hammer as its spatula), so that is tried too.
    """
    def right(points, g):
        r = model.estimate(points, viewpoint=np.zeros(3))
        return (not r.rejected and r.gallery_id == g.gallery_id
                and rotation_angle_deg(r.rotation, g.rotation) <= max_error)

    def jittered(g):
        pts = g.points + 1e-4 * np.random.default_rng(1).normal(size=g.points.shape)
        return pts.astype(np.float32).astype(np.float64)

    for i in range(len(model.gallery_ids)):
        clouds = [good_cloud(model, seed=s, gallery_index=i) for s in seeds]
        if (all(right(g.points, g) and right(jittered(g), g) for g in clouds)
                and right(clouds[0].points + [0.0, 0.0, 1000.0], clouds[0])):
            return clouds[0]
    raise RuntimeError('the model answers none of its objects right from every side tried')


# -- builders -------------------------------------------------------------------------------------
def _msg(points, header, dtype=np.float32, extra=None):
    return xyz_to_pointcloud2(points, header, dtype, extra)


def changed(msg, **changes):
    """Return a copy of a message with some of its fields changed."""
    out = copy.copy(msg)
    for k, v in changes.items():
        setattr(out, k, v)
    return out


def _organised_with_holes(g, h):
    rng = np.random.default_rng(0)
    width = 32
    n = len(g.points)
    grid = np.full((int(np.ceil(n * 1.5 / width)) * width, 3), np.nan)
    slots = np.sort(rng.choice(len(grid), n, replace=False))
    grid[slots] = g.points
    msg = _msg(grid, h)
    return changed(
        msg,
        height=len(grid) // width,
        width=width,
        row_step=msg.point_step * width,
        is_dense=False,
    )


def _big_endian(g, h):
    msg = _msg(g.points, h)
    data = np.frombuffer(bytes(msg.data), dtype='<f4').astype('>f4').tobytes()
    return changed(msg, is_bigendian=True, data=data)


def _reordered_with_extras(g, h):
    # rgb and intensity first, then z, x, y: readers must go by field name and offset, not position
    from sensor_msgs.msg import PointField
    n = len(g.points)
    rec = np.zeros(
        n, dtype=[('rgb', '<u4'), ('intensity', '<f4'), ('z', '<f4'), ('x', '<f4'), ('y', '<f4')]
    )
    rec['x'], rec['y'], rec['z'] = g.points.T
    rec['intensity'] = 1.0
    rec['rgb'] = 0xFF8800
    msg = _msg(g.points, h)
    fields = [
        PointField(
            name=name,
            offset=rec.dtype.fields[name][1],
            datatype=FLOAT32 if name != 'rgb' else 7,
            count=1,
        )
        for name in rec.dtype.names
    ]
    return changed(
        msg, fields=fields, point_step=rec.itemsize, row_step=rec.itemsize * n, data=rec.tobytes()
    )


def _padded_rows(g, h):
    n = len(g.points)
    width = 16
    n -= n % width
    msg = _msg(g.points[:n], h)
    rows = np.frombuffer(bytes(msg.data), dtype=np.uint8).reshape(
        n // width, width * msg.point_step
    )
    padded = np.concatenate([rows, np.zeros((len(rows), 8), np.uint8)], axis=1)
    return changed(
        msg, height=len(rows), width=width, row_step=padded.shape[1], data=padded.tobytes()
    )


def _integer(g, h, dtype, scale):
    info = np.iinfo(dtype)
    return _msg(np.clip(np.round(g.points * scale), info.min, info.max), h, dtype=dtype)


def _million(g, h):
    rng = np.random.default_rng(0)
    idx = rng.integers(len(g.points), size=1_000_000)
    return _msg(g.points[idx] + rng.normal(scale=1e-4, size=(len(idx), 3)), h)


def _duplicated(g, h):
    return _msg(np.concatenate([g.points, g.points]), h)


def _speck_behind(g, h):
    # what a loose cluster takes in beside the object: a tenth as many points again, half a metre
    # behind it; kept, they made the shipped model reject its hammer (turned 180 degrees)
    rng = np.random.default_rng(5)
    centre = g.points.mean(axis=0) * [1.0, 1.0, 0.0] + [0.0, 0.0, g.points[:, 2].max() + 0.5]
    return _msg(np.vstack([g.points, centre + rng.normal(0.0, 0.01, (40, 3))]), h)


def _shape(kind):
    def make(g, h):
        rng = np.random.default_rng(0)
        d = rng.normal(size=(1024, 3))
        if kind == 'sphere':
            pts = d / np.linalg.norm(d, axis=1, keepdims=True)
        else:
            pts = rng.uniform(-1, 1, size=(1024, 3))
            face = rng.integers(3, size=1024)
            pts[np.arange(1024), face] = np.sign(d[:, 0])
        radius = np.linalg.norm(g.points - g.points.mean(0), axis=1).max()
        return _msg(pts * 0.6 * radius + g.points.mean(0), h)
    return make


def _degenerate(kind):
    def make(g, h):
        c = g.points.mean(0)
        if kind == 'equal':
            return _msg(np.tile(c, (500, 1)), h)
        s = np.linspace(-0.2, 0.2, 500)[:, None]
        if kind == 'line':
            return _msg(c + s * [1.0, 0.5, 0.2], h)
        rng = np.random.default_rng(0)
        return _msg(
            c
            + rng.uniform(-0.2, 0.2, (500, 1)) * [1, 0, 0]
            + rng.uniform(-0.2, 0.2, (500, 1)) * [0, 1, 0.3],
            h,
        )
    return make


def _rejected(*reasons):
    return frozenset(f'rejected:{r}' for r in reasons)


_ANSWER = frozenset({ANSWERED})
# a cloud in other units is answered right (a model of unknown scale) or refused as unsure, never
# posed wrongly with confidence: no gallery object a metric model holds is a thousand times larger
_UNITS = frozenset({ANSWERED, 'rejected:low_confidence'})
_SHAPELESS = frozenset({ANY_ANSWER, 'rejected:low_confidence', 'rejected:degenerate'})

CASES = [
    Case(
        'empty', 'no points (width 0)', lambda g, h: _msg(np.zeros((0, 3)), h), _rejected('empty')
    ),
    Case(
        'too_few',
        '5 points, fewer than min_points',
        lambda g, h: _msg(g.points[:5], h),
        _rejected('too_few_points'),
    ),
    Case(
        'all_nan',
        'every coordinate NaN',
        lambda g, h: _msg(np.full((300, 3), np.nan), h),
        _rejected('no_finite_points'),
    ),
    Case(
        'all_inf',
        'every coordinate +-Inf',
        lambda g, h: _msg(np.full((300, 3), np.inf) * [1, -1, 1], h),
        _rejected('no_finite_points'),
    ),
    Case(
        'nan_holes',
        'organised 32-wide, a third NaN holes, is_dense false',
        _organised_with_holes,
        _ANSWER,
    ),
    Case(
        'missing_z',
        'no z field',
        lambda g, h: changed(_msg(g.points, h), fields=_msg(g.points, h).fields[:2]),
        _rejected('missing_field'),
    ),
    Case(
        'unknown_datatype',
        'x of PointField datatype 42',
        lambda g, h: _bad_datatype(g, h),
        _rejected('bad_field_type'),
    ),
    Case(
        'float64', 'x, y, z as float64', lambda g, h: _msg(g.points, h, dtype=np.float64), _ANSWER
    ),
    Case(
        'int16_mm',
        'x, y, z as int16 millimetres',
        lambda g, h: _integer(g, h, np.int16, 1000.0),
        _UNITS,
    ),
    Case(
        'uint8',
        'x, y, z as uint8 (whole units)',
        lambda g, h: _integer(g, h, np.uint8, 1.0),
        _rejected('too_few_points', 'degenerate'),
    ),
    Case('big_endian', 'float32, big-endian data', _big_endian, _ANSWER),
    Case('extra_fields', 'rgb and intensity first, then z, x, y', _reordered_with_extras, _ANSWER),
    Case(
        'point_step_small',
        'point_step smaller than the fields need',
        lambda g, h: changed(_msg(g.points, h), point_step=8),
        _rejected('bad_layout'),
    ),
    Case(
        'data_short',
        'data shorter than row_step x height',
        lambda g, h: changed(_msg(g.points, h), data=bytes(_msg(g.points, h).data)[:1000]),
        _rejected('truncated_data'),
    ),
    Case(
        'data_long',
        'data 100 bytes longer than row_step x height',
        lambda g, h: changed(_msg(g.points, h), data=bytes(_msg(g.points, h).data) + bytes(100)),
        _ANSWER,
    ),
    Case(
        'row_step_small',
        'row_step less than width x point_step',
        lambda g, h: changed(_msg(g.points, h), row_step=12),
        _rejected('bad_layout'),
    ),
    Case('row_padding', 'organised, 8 bytes of padding after each row', _padded_rows, _ANSWER),
    Case('million_points', '1,000,000 points', _million, _ANSWER),
    Case(
        'one_km',
        'the object 1 km from the camera (float64)',
        lambda g, h: _msg(g.points + [0.0, 0.0, 1000.0], h, dtype=np.float64),
        _ANSWER,
    ),
    Case(
        'millimetres',
        'float32 millimetres (model in metres)',
        lambda g, h: _msg(g.points * 1000.0, h),
        _UNITS,
    ),
    Case(
        'all_equal', '500 copies of one point', _degenerate('equal'), _rejected('too_few_points')
    ),
    Case('line', '500 points on a line', _degenerate('line'), _rejected('degenerate')),
    Case('plane', '500 points on a plane', _degenerate('plane'), _SHAPELESS),
    Case('duplicated', 'every point sent twice', _duplicated, _ANSWER),
    Case('speck_behind', '40 points of something else, a 1 cm blob 0.5 m behind the object',
         _speck_behind, _ANSWER),
    Case('sphere', "a sphere's surface (no preferred orientation)", _shape('sphere'), _SHAPELESS),
    Case('cube', "a cube's surface (24 equal orientations)", _shape('cube'), _SHAPELESS),
]


def _bad_datatype(g, h):
    msg = _msg(g.points, h)
    fields = [copy.copy(f) for f in msg.fields]
    fields[0].datatype = 42
    return changed(msg, fields=fields)


# -- running them through a live node -------------------------------------------------------------
@dataclass
class Outcome:
    case: str
    outcome: str             # answered / answered_any / rejected:<reason> / lost
    seconds: float           # from publication to the node's decision
    gallery_id: str = ''
    rotation_error: float = float('nan')
    next_good: str = ''      # what happened to the good cloud sent right after it


def _rotation_error(q, R_true) -> float:
    from scipy.spatial.transform import Rotation
    R = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
    return rotation_angle_deg(R, R_true)


class CaseRunner:
    """
    Publishes cases one at a time to a node in this process and reads its verdict.

    The verdict comes from the node's own counters (so a rejection is seen even though it publishes
    nothing).
    """

    def __init__(
        self,
        node,
        client,
        good: GoodCloud,
        topic: str = 'segmented_object',
        max_error: float = 10.0,
    ):
        from geometry_msgs.msg import PoseStamped
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import PointCloud2
        from std_msgs.msg import String

        self.node, self.good, self.max_error = node, good, max_error
        self.stats = node.stats[topic]
        self.poses, self.ids = [], []
        client.create_subscription(PoseStamped, f'/{topic}/pose', self.poses.append, 10)
        client.create_subscription(String, f'/{topic}/gallery_id', self.ids.append, 10)
        # reliable, so a big cloud is not lost to fragmentation; the node's best-effort input
        # accepts it
        self.pub = client.create_publisher(PointCloud2, f'/{topic}', QoSProfile(depth=2))
        self._sec = 1

    def ready(self, timeout: float = 60.0) -> bool:
        """
        Wait until matched both ways: the node has answered a good cloud.

        (The publisher may see the subscription before the node's reader sees the publisher; a
        cloud sent in that gap is lost, so the first is resent until one gets through.)
        """
        end = time.monotonic() + timeout
        while time.monotonic() < end and not self.pub.get_subscription_count():
            time.sleep(0.05)
        while time.monotonic() < end:
            if (
                self.send(lambda g, h: xyz_to_pointcloud2(g.points, h), timeout=3.0).outcome
                == ANSWERED
            ):
                return self._settled(end)
        return False

    def _settled(self, deadline: float) -> bool:
        """Nothing still queued or in work (a resent cloud may be)."""
        c = self.stats.counts
        while time.monotonic() < deadline:
            if c['received'] == c['answered'] + c['rejected'] + c['dropped_stale']:
                time.sleep(0.2)   # the worker counts after publishing: let its last poses arrive
                return True
            time.sleep(0.05)
        return False

    def _header(self):
        from builtin_interfaces.msg import Time
        from std_msgs.msg import Header
        self._sec += 1
        return Header(stamp=Time(sec=self._sec, nanosec=0), frame_id='camera_optical_frame')

    def send(self, make, timeout: float = 60.0) -> Outcome:
        before = dict(self.stats.counts), dict(self.stats.rejections)
        n_poses = len(self.poses)
        header = self._header()
        msg = make(self.good, header)
        t0 = time.monotonic()
        self.pub.publish(msg)
        decided = lambda: sum(self.stats.counts[k] - before[0].get(k, 0)  # noqa: E731
                              for k in ('answered', 'rejected', 'dropped_stale'))
        while time.monotonic() - t0 < timeout and not decided():
            time.sleep(0.02)
        seconds = time.monotonic() - t0
        if not decided():
            return Outcome('', 'lost', seconds)
        if self.stats.counts['answered'] > before[0].get('answered', 0):
            end = time.monotonic() + 5.0
            while len(self.poses) <= n_poses and time.monotonic() < end:
                time.sleep(0.02)
            pose = next(
                (p for p in self.poses[n_poses:] if p.header.stamp.sec == header.stamp.sec), None
            )
            while len(self.ids) < len(self.poses) and time.monotonic() < end:
                time.sleep(0.02)
            gid = self.ids[-1].data if self.ids else ''
            err = (
                _rotation_error(pose.pose.orientation, self.good.rotation)
                if pose is not None
                else float('nan')
            )
            right = gid == self.good.gallery_id and err <= self.max_error
            return Outcome('', ANSWERED if right else ANY_ANSWER, seconds, gid, err)
        reasons = {r for r, v in self.stats.rejections.items() if v > before[1].get(r, 0)}
        return Outcome('', f'rejected:{min(reasons)}' if reasons else 'dropped_stale', seconds)

    def run(self, case: Case) -> Outcome:
        out = self.send(case.make)
        out.case = case.name
        out.next_good = self.send(lambda g, h: xyz_to_pointcloud2(g.points, h)).outcome
        return out


def accepted(case: Case, out: Outcome) -> bool:
    """Say whether the node did what the case allows and answered the next good cloud."""
    ok = out.outcome in case.allowed or (out.outcome == ANSWERED and ANY_ANSWER in case.allowed)
    return ok and out.next_good == ANSWERED
