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
The camera's whole depth clouds (scenes) the node answers segmented clouds with.

A segmenter stamps each object cloud with the stamp of the depth frame it cut it from, so the
scene of a cloud is the scene message of the same stamp and frame. Scene messages are kept as
they came, the last SCENE_BUFFER of each topic, and read only when a cloud is matched with one.
"""

from __future__ import annotations

import collections
import threading

import numpy as np
from pcrp_ros.conversions import CloudFormatError, pointcloud2_to_xyz

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


def scene_points(msg, frame_id: str) -> np.ndarray:
    """
    Read a scene message's finite points, (M, 3) float64.

    CloudFormatError with a reason when it cannot serve a cloud in frame_id: the conversion's
    own, other_frame, empty or no_finite_points.
    """
    if msg.header.frame_id != frame_id:
        raise CloudFormatError('other_frame', f'scene in frame {msg.header.frame_id!r}, '
                                              f'the cloud in {frame_id!r}')
    points = pointcloud2_to_xyz(msg, finite_only=False)
    if not len(points):
        raise CloudFormatError('empty', 'scene has no points')
    finite = points[np.isfinite(points).all(axis=1)]
    if not len(finite):
        raise CloudFormatError('no_finite_points',
                               f"none of the scene's {len(points)} points is finite")
    return finite


class Scenes:
    """
    The depth clouds each input topic's clouds are answered with, and what of one a cloud uses.

    topic_of: input topic -> its scene topic; the messages kept as they came (buffer).
    """

    def __init__(self, topic_of: dict, size: int = SCENE_BUFFER):
        self.topic_of = dict(topic_of)
        self.buffer = SceneBuffer(size)

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
            scene = model.scene_in_reach(points, scene_points(msg, header.frame_id), viewpoint)
        except CloudFormatError as e:
            return None, f'rejected_{e.reason}', str(e)
        except Exception as e:   # nothing one message holds may cost the cloud its answer
            return None, 'rejected_internal_error', f'{type(e).__name__}: {e}'
        if scene is None:
            return None, 'unused', None
        # depth clouds are float32: halves what reaches a worker process, and loses nothing
        return scene.astype(np.float32), 'used', None
