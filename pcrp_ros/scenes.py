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
The camera's whole depth frames (scenes) the node answers segmented clouds with.

Depth clouds (PointCloud2) or depth images (sensor_msgs/Image, with their CameraInfo). A
segmenter stamps each object cloud with the stamp of the depth frame it cut it from, so the scene
of a cloud is the scene message of the same stamp and frame. Scene messages are kept as they
came, the last SCENE_BUFFER of each topic, and read only when a cloud is matched with one.
"""

from __future__ import annotations

import collections
import threading

import numpy as np
from pcrp_core import DepthImage
from pcrp_ros.conversions import CloudFormatError, pointcloud2_to_grid, pointcloud2_to_xyz
from pcrp_ros.depth_images import depth_image

# Scene messages kept per topic. A segmented cloud follows its depth frame by the segmenter's
# latency: four frames is 130 ms at 30 Hz. A cloud takes its match when it is queued, so the
# time it then waits to be answered does not count. A depth cloud is 5-10 MB: no more are kept.
SCENE_BUFFER = 4


class SceneBuffer:
    """The last SCENE_BUFFER messages of each scene topic, safe to use from several threads."""

    def __init__(self, size: int = SCENE_BUFFER):
        self.size = size
        self._lock = threading.Lock()
        self._messages = {}

    def add(self, topic: str, msg) -> None:
        with self._lock:
            kept = self._messages.get(topic)
            if kept is None:
                kept = self._messages[topic] = collections.deque(maxlen=self.size)
            kept.append(msg)

    def find(self, topic: str, header):
        """
        Return the topic's message stamped as the header, in its frame if one is; else None.

        One of the same stamp in another frame is returned when there is no other: the caller
        says why it cannot be used.
        """
        with self._lock:
            candidates = list(self._messages.get(topic, ()))
        same_stamp = [m for m in reversed(candidates) if same_stamp_as(m.header, header)]
        in_frame = [m for m in same_stamp if m.header.frame_id == header.frame_id]
        return (in_frame or same_stamp or [None])[0]

    def clear(self) -> None:
        with self._lock:
            self._messages.clear()


def same_stamp_as(a, b) -> bool:
    return (a.stamp.sec, a.stamp.nanosec) == (b.stamp.sec, b.stamp.nanosec)


def in_frame(msg, frame_id: str) -> None:
    """Raise CloudFormatError other_frame unless the scene message is in frame_id."""
    if msg.header.frame_id != frame_id:
        raise CloudFormatError('other_frame', f'scene in frame {msg.header.frame_id!r}, '
                                              f'the cloud in {frame_id!r}')


def read_scene(msg, frame_id: str):
    """
    Read a scene message: a DepthImage if it is a pinhole camera's organized cloud, else points.

    The points are the finite ones, (M, 3) float64. A depth image is cut to what is in reach of an
    object by a slice, where a list of points costs a pass over all of them (depth_image.py).
    CloudFormatError with a reason when it cannot serve a cloud in frame_id: the conversion's own,
    other_frame, empty or no_finite_points.
    """
    in_frame(msg, frame_id)
    if msg.height > 1 and msg.width > 1:
        image = DepthImage.from_organized(pointcloud2_to_grid(msg))
        if image is not None:
            return image
    points = pointcloud2_to_xyz(msg, finite_only=False)
    if not len(points):
        raise CloudFormatError('empty', 'scene has no points')
    finite = points[np.isfinite(points).all(axis=1)]
    if not len(finite):
        raise CloudFormatError('no_finite_points',
                               f"none of the scene's {len(points)} points is finite")
    return finite


def read_frame(msg, frame_id: str, camera_info=None):
    """
    Read a scene message for a cloud in frame_id: a depth cloud, or a depth image with its camera.

    A depth image (it has an encoding) is read with camera_info, its camera's CameraInfo.
    CloudFormatError with a reason when it cannot be used.
    """
    if not hasattr(msg, 'encoding'):
        return read_scene(msg, frame_id)
    in_frame(msg, frame_id)
    return depth_image(msg, camera_info)


def unusable(e: Exception) -> tuple[str, str]:
    """Return (outcome, why) of a scene that raised e: rejected_<reason> as counted, and why."""
    if isinstance(e, CloudFormatError):
        return f'rejected_{e.reason}', str(e)
    return 'rejected_internal_error', f'{type(e).__name__}: {e}'


class Scenes:
    """
    The depth frames each input topic's clouds are answered with, and what of one a cloud uses.

    topic_of: input topic -> its scene topic; the messages kept as they came (buffer); each scene
    topic's last CameraInfo, for depth images (camera_info).
    """

    def __init__(self, topic_of: dict, size: int = SCENE_BUFFER):
        self.topic_of = dict(topic_of)
        self.buffer = SceneBuffer(size)
        self.camera_info = {}   # scene topic -> its camera's last CameraInfo

    def on_camera_info(self, scene_topic: str, msg) -> None:
        self.camera_info[scene_topic] = msg

    def clear(self) -> None:
        self.buffer.clear()
        self.camera_info.clear()

    def on_arrival(self, topic: str, header):
        """Return the scene message of a cloud arriving on topic, if it has come (kept, unread)."""
        scene_topic = self.topic_of.get(topic)
        return None if scene_topic is None else self.buffer.find(scene_topic, header)

    def message(self, topic: str, header, kept):
        """Return a cloud's scene message: the one kept on arrival, else one come since."""
        if kept is not None and kept.header.frame_id == header.frame_id:
            return kept
        return self.buffer.find(self.topic_of[topic], header) or kept

    def scene(self, topic: str, header, points, kept, model, viewpoint) -> tuple:
        """
        Return (scene, outcome, why): what of a cloud's scene its estimate can use, and the count.

        outcome is None when the topic has no scene topic, else what StreamStats.scene counts:
        used, unused (the model would use none), missing, or rejected_<reason>; why says why a
        scene was missing or unusable (None otherwise). Nothing a scene message holds is raised.
        """
        if topic not in self.topic_of:
            return None, None, None
        if not model.uses_views(viewpoint):
            return None, 'unused', None   # not read at all: the estimate would ignore it
        msg = self.message(topic, header, kept)
        if msg is None:
            return None, 'missing', (
                f'none of the last {self.buffer.size} is stamped as the cloud (a segmenter must '
                'stamp each cloud as the depth cloud it cut it from)')
        try:
            seen = read_frame(msg, header.frame_id, self.camera_info.get(self.topic_of[topic]))
            scene = model.scene_in_reach(points, seen, viewpoint)
        except Exception as e:   # nothing one message holds may cost the cloud its answer
            outcome, why = unusable(e)
            return None, outcome, why
        if scene is None:
            return None, 'unused', None
        if isinstance(scene, np.ndarray):
            # depth clouds are float32: halves what reaches a worker process, and loses nothing
            scene = scene.astype(np.float32)
        return scene, 'used', None
