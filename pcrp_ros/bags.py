"""rosbag2 files without a ROS install (the `rosbags` library): object clouds in, results out.

A bag made by `pcrp make-bag` holds, per cloud topic T, PointCloud2 messages on T and the
ground truth on T/ground_truth as std_msgs/String JSON ({"stamp": [sec, nanosec], "gallery_id",
"category", "rotation", "translation"}), the stamp matching the cloud's header.
"""
from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
from rosbags.rosbag2 import Reader, StoragePlugin, Writer
from rosbags.typesys import Stores, get_typestore

from pcrp_ros.conversions import CloudFormatError, pack_points, pointcloud2_to_xyz

TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
CLOUD = "sensor_msgs/msg/PointCloud2"
STRING = "std_msgs/msg/String"
POSE = "geometry_msgs/msg/PoseStamped"
log = logging.getLogger("pcrp.bags")
T = TYPESTORE.types


def header(sec: int, nanosec: int, frame: str):
    return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](sec=sec, nanosec=nanosec), frame_id=frame)


def cloud_msg(points, hdr):
    fields, step, data = pack_points(points)
    n = len(data) // step
    return T[CLOUD](header=hdr, height=1, width=n,
                    fields=[T["sensor_msgs/msg/PointField"](name=a, offset=o, datatype=d, count=c) for a, o, d, c in fields],
                    is_bigendian=False, point_step=step, row_step=step * n,
                    data=np.frombuffer(data, dtype=np.uint8), is_dense=True)


def pose_msg(result, hdr):
    q = result.quaternion
    tr = np.asarray(result.translation, dtype=float)
    pose = T["geometry_msgs/msg/Pose"](position=T["geometry_msgs/msg/Point"](x=tr[0], y=tr[1], z=tr[2]),
                                       orientation=T["geometry_msgs/msg/Quaternion"](x=q[0], y=q[1], z=q[2], w=q[3]))
    return T[POSE](header=hdr, pose=pose)


class BagWriter:
    """Writes messages by topic, adding each topic's connection on first use."""

    def __init__(self, path, storage: str = "sqlite3"):
        plugin = StoragePlugin.MCAP if storage == "mcap" else StoragePlugin.SQLITE3
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


def read_bag(path, topics=None):
    """(clouds, truths, problems): clouds are dicts of topic, timestamp, header, points (or a
    format error); truths map (topic, sec, nanosec) to ground truth; problems list what could
    not be read. A damaged bag yields what was read before the damage."""
    clouds, truths, problems = [], {}, []
    try:
        with Reader(Path(path)) as reader:
            conns = [c for c in reader.connections if c.msgtype in (CLOUD, STRING)]
            other = sorted({c.topic for c in reader.connections} - {c.topic for c in conns})
            if other:
                problems.append(f"ignored topics of other types: {', '.join(other)}")
            try:
                for conn, ts, raw in reader.messages(connections=conns):
                    try:
                        msg = TYPESTORE.deserialize_cdr(raw, conn.msgtype)
                    except Exception as e:  # a damaged message: skip it, keep the rest
                        problems.append(f"{conn.topic} @ {ts}: unreadable message ({type(e).__name__})")
                        continue
                    if conn.msgtype == STRING and conn.topic.endswith("/ground_truth"):
                        gt = json.loads(msg.data)
                        truths[(conn.topic[: -len("/ground_truth")], *gt["stamp"])] = gt
                    elif conn.msgtype == CLOUD and (topics is None or conn.topic in topics):
                        try:
                            pts, err = pointcloud2_to_xyz(msg), None
                        except CloudFormatError as e:
                            pts, err = None, e
                        clouds.append({"topic": conn.topic, "timestamp": ts, "msg": msg, "points": pts, "error": err})
            except Exception as e:
                problems.append(f"stopped reading early: {type(e).__name__}: {e}")
    except Exception as e:
        problems.append(f"cannot open bag: {type(e).__name__}: {e}")
    return clouds, truths, problems
