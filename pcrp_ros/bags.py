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
Read and write rosbag2 files without a ROS install (the `rosbags` library).

Object clouds in, results out.

A bag made by `pcrp make-bag` holds, per cloud topic T, PointCloud2 messages on T and the
ground truth on T/ground_truth as std_msgs/String JSON ({"stamp": [sec, nanosec], "gallery_id",
"category", "rotation", "translation"}), the stamp matching the cloud's header.
"""
from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
from pcrp_ros.conversions import CloudFormatError, pack_points, pointcloud2_to_xyz
from pcrp_ros.depth_images import camera_info_topic
from pcrp_ros.mcap_salvage import salvage
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import get_typestore, Stores

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
CLOUD = 'sensor_msgs/msg/PointCloud2'
IMAGE = 'sensor_msgs/msg/Image'
CAMERA_INFO = 'sensor_msgs/msg/CameraInfo'
STRING = 'std_msgs/msg/String'
POSE = 'geometry_msgs/msg/PoseStamped'
log = logging.getLogger('pcrp.bags')
T = TYPESTORE.types


def header(sec: int, nanosec: int, frame: str):
    return T['std_msgs/msg/Header'](
        stamp=T['builtin_interfaces/msg/Time'](sec=sec, nanosec=nanosec), frame_id=frame
    )


def cloud_msg(points, hdr):
    fields, step, data = pack_points(points)
    n = len(data) // step
    return T[CLOUD](
        header=hdr,
        height=1,
        width=n,
        fields=[
            T['sensor_msgs/msg/PointField'](name=a, offset=o, datatype=d, count=c)
            for a, o, d, c in fields
        ],
        is_bigendian=False,
        point_step=step,
        row_step=step * n,
        data=np.frombuffer(data, dtype=np.uint8),
        is_dense=True,
    )


def pose_msg(result, hdr):
    q = result.quaternion
    tr = np.asarray(result.translation, dtype=float)
    pose = T['geometry_msgs/msg/Pose'](
        position=T['geometry_msgs/msg/Point'](x=tr[0], y=tr[1], z=tr[2]),
        orientation=T['geometry_msgs/msg/Quaternion'](x=q[0], y=q[1], z=q[2], w=q[3]),
    )
    return T[POSE](header=hdr, pose=pose)


class BagWriter:
    """Writes messages by topic, adding each topic's connection on first use."""

    def __init__(self, path, storage: str = 'sqlite3'):
        plugin = StoragePlugin.MCAP if storage == 'mcap' else StoragePlugin.SQLITE3
        self._writer = Writer(Path(path), version=9, storage_plugin=plugin)
        self._conns = {}

    def __enter__(self):
        self._writer.open()
        return self

    def __exit__(self, *exc):
        self._writer.close()

    def write(self, topic: str, msg, timestamp_ns: int) -> None:
        typ = msg.__msgtype__
        if topic not in self._conns:
            self._conns[topic] = self._writer.add_connection(topic, typ, typestore=TYPESTORE)
        self._writer.write(self._conns[topic], timestamp_ns, TYPESTORE.serialize_cdr(msg, typ))


def _messages(path: Path, problems: list[str], kinds=(CLOUD,), skip=()):
    """
    (topic, msgtype, timestamp, raw CDR) of the bag's messages of the types kinds and ground truth.

    skip: topics neither read nor reported as ignored (what another pass reads). A bag rosbags
    cannot open whole is read as far as it goes when it is MCAP (a recording cut short); an
    SQLite file cut short cannot be read at all (its page count no longer matches).
    """
    def wanted(topic: str, msgtype: str) -> bool:
        return msgtype in kinds or (msgtype == STRING and topic.endswith('/ground_truth'))

    try:
        with Reader(path) as reader:
            types = {c.topic: c.msgtype for c in reader.connections}
            other = sorted(t for t, m in types.items() if not wanted(t, m) and t not in skip)
            if other:
                problems.append(f"ignored topics of other types: {', '.join(other)}")
            try:
                for conn, ts, raw in reader.messages(connections=[
                        c for c in reader.connections
                        if wanted(c.topic, c.msgtype) and c.topic not in skip]):
                    yield conn.topic, conn.msgtype, ts, raw
            except Exception as e:
                problems.append(f'stopped reading early: {type(e).__name__}: {e}')
            return
    except Exception as e:
        problems.append(f'cannot open bag: {type(e).__name__}: {e}')
    files = (
        sorted(path.glob('*.mcap')) if path.is_dir() else [path] if path.suffix == '.mcap' else []
    )
    for f in files:
        n = 0
        for topic, msgtype, ts, raw in salvage(f, problems):
            n += 1
            if wanted(topic, msgtype) and topic not in skip:
                yield topic, msgtype, ts, raw
        problems.append(f'{f.name}: salvaged {n} messages from the damaged file')


def _decoded(messages, problems: list[str]):
    """Yield (topic, msgtype, timestamp, message) of raw ones; a damaged one is noted, skipped."""
    for topic, msgtype, ts, raw in messages:
        try:
            msg = TYPESTORE.deserialize_cdr(raw, msgtype)
        except Exception as e:  # a damaged message: skip it, keep the rest
            problems.append(f'{topic} @ {ts}: unreadable message ({type(e).__name__})')
            continue
        yield topic, msgtype, ts, msg


def read_bag(path, topics=None, leave=()):
    """
    Read (clouds, truths, problems) from a bag; a damaged bag yields what could be read.

    clouds are dicts of topic, timestamp, msg, points (or a format error); truths map (topic,
    sec, nanosec) to ground truth; problems list what could not be read. leave: topics not read
    at all (a camera's depth frames, which scene_messages reads one at a time).
    """
    clouds, truths, problems = [], {}, []
    skipped = {}
    for topic, msgtype, ts, msg in _decoded(_messages(Path(path), problems, skip=leave),
                                            problems):
        if msgtype == STRING:
            gt = json.loads(msg.data)
            truths[(topic[: -len('/ground_truth')], *gt['stamp'])] = gt
        elif topics is not None and topic not in topics:
            skipped[topic] = skipped.get(topic, 0) + 1
        else:
            try:
                pts, err = pointcloud2_to_xyz(msg, finite_only=False), None
            except CloudFormatError as e:
                pts, err = None, e
            clouds.append(
                {'topic': topic, 'timestamp': ts, 'msg': msg, 'points': pts, 'error': err}
            )
    if skipped:
        problems.append('skipped clouds on topics not asked for: '
                        + ', '.join(f'{t} ({n})' for t, n in sorted(skipped.items())))
    absent = sorted(set(topics or ()) - {c['topic'] for c in clouds})
    if absent:
        problems.append(f"no clouds on the topics asked for: {', '.join(absent)}")
    if not clouds and not absent:
        problems.append('no PointCloud2 messages found')
    return clouds, truths, problems


def scene_messages(path, topic: str, problems: list[str]):
    """
    Yield (message, CameraInfo) of the bag's depth frames on topic, one at a time (they are large).

    Depth clouds, or depth images each with the last CameraInfo recorded before it on the
    camera_info topic beside it (None when there was none yet).
    """
    info_topic, info, found = camera_info_topic(topic), None, False
    wanted = ((topic, CLOUD), (topic, IMAGE), (info_topic, CAMERA_INFO))
    frames = (m for m in _messages(Path(path), [], kinds=(CLOUD, IMAGE, CAMERA_INFO))
              if m[:2] in wanted)   # only these are worth deserializing
    for t, _, _, msg in _decoded(frames, problems):
        if t == info_topic:
            info = msg
        else:
            found = True
            yield msg, info
    if not found:
        problems.append(f'no depth clouds or images on the scene topic {topic}')
