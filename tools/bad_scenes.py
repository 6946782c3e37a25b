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
Depth images a camera driver may send as the scene: a catalogue of bad and oddly encoded ones.

Each comes with the one scene count the node must make of it (`scene_*` in /diagnostics); a runner
feeds them to a live node with `scene_type: depth_image`, each followed by the segmented cloud cut
from that frame. Whatever the frame, the cloud is answered (without the frame when it cannot be
used), and the next good frame is used again. The same catalogue drives
test/ros/test_scene_robustness.py and `python -m tools robustness`.
"""
from __future__ import annotations

from dataclasses import dataclass, replace
import time
from typing import Callable

import numpy as np
from pcrp_ros.spinning import wait_for
from tools.bad_clouds import changed

FRAME = 'camera_depth_optical_frame'
OBJECT_TOPIC, IMAGE_TOPIC = 'segmented_object', 'camera/depth/image_rect_raw'
INFO_TOPIC = 'camera/depth/camera_info'
VIEW_OBJECT, VIEW_SEED = 'drill', 5      # an object with no symmetry, seen whole, in free space
HELD_SECONDS, STEP = 10.0, 0.02          # how long, how often to look for the node holding a frame


def node_parameters() -> list:
    """Return the node's parameters for the battery: the camera's depth images as scenes."""
    from rclpy.parameter import Parameter
    return [Parameter('input_topics', value=[OBJECT_TOPIC]),
            Parameter('scene_topics', value=[IMAGE_TOPIC]),
            Parameter('scene_type', value='depth_image'),
            # reliable input, as the runner publishes: a frame lost on the way would count missing
            Parameter('qos_reliability', value='reliable')]


@dataclass(frozen=True)
class Frame:
    """One camera frame of a gallery object: its segmented cloud and the whole depth frame."""

    points: np.ndarray      # (N, 3) the object's pixels, optical frame, metres
    millimetres: np.ndarray  # (height, width) uint16 depth image, 0 where nothing was measured
    k: tuple                # fx, fy, cx, cy
    gallery_id: str


@dataclass(frozen=True)
class SceneCase:
    name: str
    what: str
    # (frame, header) -> (Image, CameraInfo to send before it or None: the last one stands)
    make: Callable
    counted: str            # the scene count the node must make: used, missing, rejected_<reason>


def camera_frame(model) -> Frame:
    """
    Show VIEW_OBJECT of the model's gallery to a 640 x 480 camera, a wall 0.3 m behind it.

    Raises RuntimeError unless the model answers that view with the object (the battery judges
    the next good frame by it).
    """
    from pcrp_core.evaluation.scenes import sample_scene
    from pcrp_core.sources import load_source

    obj = next(o for o in load_source('household', split='train') if o.gallery_id == VIEW_OBJECT)
    frame = frame_of(sample_scene(obj.mesh, VIEW_OBJECT, 0, 0, 'free', seed=VIEW_SEED))
    answer = model.estimate(frame.points, viewpoint=np.zeros(3))
    if answer.rejected or answer.gallery_id != VIEW_OBJECT:
        raise RuntimeError(f'the model answers its {VIEW_OBJECT} seen whole as '
                           f'{answer.gallery_id!r}')
    return frame


def frame_of(scene) -> Frame:
    """Return the Frame of a rendered view (evaluation.scenes.Scene): a wall 0.3 m behind it."""
    far = float(scene.points[:, 2].max()) + 0.3
    z = scene.depth_image().z
    mm = np.rint(np.where(np.isfinite(z), z, far) * 1000).astype('<u2')
    mm[::7, ::5] = 0                                         # pixels without a depth
    cam = scene.camera
    return Frame(scene.points.astype(np.float64), mm, (cam.fx, cam.fy, cam.cx, cam.cy),
                 scene.object_id)


def image(frame: Frame, header, depth=None, encoding: str = '16UC1', bigendian: bool = False,
          pad: int = 0):
    """Return a sensor_msgs/Image of the frame's depth (or `depth`), rows padded by `pad` bytes."""
    from sensor_msgs.msg import Image

    depth = frame.millimetres if depth is None else depth
    rows, cols = depth.shape
    data = depth.astype(depth.dtype.newbyteorder('>' if bigendian else '<'))
    data = np.pad(data.view(np.uint8).reshape(rows, -1), ((0, 0), (0, pad)))
    return Image(header=header, height=rows, width=cols, encoding=encoding,
                 is_bigendian=int(bigendian), step=data.shape[1], data=data.tobytes())


def camera_info(frame: Frame, header, size=None, k=None):
    """Return the frame's CameraInfo (or one of another size or intrinsics)."""
    from sensor_msgs.msg import CameraInfo

    fx, fy, cx, cy = frame.k
    rows, cols = frame.millimetres.shape if size is None else size
    k = [fx, 0.0, cx, 0.0, fy, cy, 0.0, 0.0, 1.0] if k is None else k
    return CameraInfo(header=header, width=cols, height=rows, k=k)


def _metres(frame: Frame, fill=None):
    z = frame.millimetres.astype(np.float32) / 1000.0
    z[frame.millimetres == 0] = np.nan
    return z if fill is None else np.full_like(z, fill)


def _restamped(header, frame_id=None, nanosec=None):
    from std_msgs.msg import Header
    from builtin_interfaces.msg import Time
    return Header(stamp=Time(sec=header.stamp.sec, nanosec=header.stamp.nanosec
                             if nanosec is None else nanosec),
                  frame_id=header.frame_id if frame_id is None else frame_id)


def _cut_short(msg):
    return changed(msg, data=msg.data[:1000])


def _good(f, h):
    return image(f, h), camera_info(f, h)


def _doubled(f: Frame) -> Frame:
    """Return the frame as a camera of twice the resolution sees it."""
    fx, fy, cx, cy = f.k
    # pixel u's centre becomes the middle of pixels 2u and 2u + 1
    return replace(f, millimetres=np.repeat(np.repeat(f.millimetres, 2, 0), 2, 1),
                   k=(2 * fx, 2 * fy, 2 * cx + 0.5, 2 * cy + 0.5))


CASES = [
    # first, while the node has had no CameraInfo on the topic
    SceneCase('no_camera_info', 'a depth image before any CameraInfo came',
              lambda f, h: (image(f, h), None), 'rejected_no_camera_info'),
    SceneCase('good', '16UC1 millimetres with its CameraInfo', _good, 'used'),
    SceneCase('metres', '32FC1 metres, NaN where nothing was measured',
              lambda f, h: (image(f, h, _metres(f), '32FC1'), None), 'used'),
    SceneCase('mono16', 'mono16 millimetres', lambda f, h: (image(f, h, encoding='mono16'), None),
              'used'),
    SceneCase('big_endian', '16UC1, big-endian data',
              lambda f, h: (image(f, h, bigendian=True), None), 'used'),
    SceneCase('row_padding', '16 bytes of padding after each row',
              lambda f, h: (image(f, h, pad=16), None), 'used'),
    SceneCase('nothing_measured', 'every pixel 0 (no depth anywhere)',
              lambda f, h: (image(f, h, np.zeros_like(f.millimetres)), None), 'used'),
    SceneCase('all_nan', '32FC1, every pixel NaN',
              lambda f, h: (image(f, h, _metres(f, np.nan), '32FC1'), None), 'used'),
    SceneCase('negative', '32FC1, every pixel -1 m',
              lambda f, h: (image(f, h, _metres(f, -1.0), '32FC1'), None), 'used'),
    SceneCase('rgb8', 'a colour image (rgb8) on the depth topic',
              lambda f, h: (changed(image(f, h), encoding='rgb8'), None), 'rejected_bad_encoding'),
    SceneCase('step_small', 'step smaller than width x 2 bytes',
              lambda f, h: (changed(image(f, h), step=100), None), 'rejected_bad_layout'),
    SceneCase('data_short', 'data shorter than step x height',
              lambda f, h: (_cut_short(image(f, h)), None),
              'rejected_truncated_data'),
    SceneCase('info_other_size', 'CameraInfo of 320 x 240 for a 640 x 480 image',
              lambda f, h: (image(f, h), camera_info(f, h, size=(240, 320))),
              'rejected_camera_info_mismatch'),
    SceneCase('info_no_focal', 'CameraInfo K all zeros (an uncalibrated driver)',
              lambda f, h: (image(f, h), camera_info(f, h, k=[0.0] * 9)),
              'rejected_camera_info_mismatch'),
    SceneCase('info_nan', 'CameraInfo K of NaN',
              lambda f, h: (image(f, h), camera_info(f, h, k=[float('nan')] * 9)),
              'rejected_camera_info_mismatch'),
    SceneCase('info_other_frame', "CameraInfo in another camera's frame",
              lambda f, h: (image(f, h), camera_info(f, _restamped(h, 'other_optical_frame'))),
              'rejected_camera_info_mismatch'),
    SceneCase('image_other_frame', "the image in another frame than the cloud's",
              lambda f, h: (image(f, _restamped(h, 'other_optical_frame')), None),
              'rejected_other_frame'),
    SceneCase('other_stamp', 'the image stamped 1 ms off the cloud (a segmenter that restamps)',
              lambda f, h: (image(f, _restamped(h, nanosec=h.stamp.nanosec + 1_000_000)), None),
              'missing'),
    SceneCase('large', 'a 1280 x 960 image (2.5 MB) with its CameraInfo',
              lambda f, h: _good(_doubled(f), h), 'used'),
    SceneCase('tiny', 'an 8 x 6 image with a CameraInfo to match',
              lambda f, h: (image(f, h, f.millimetres[::80, ::80]),
                            camera_info(replace(f, millimetres=f.millimetres[::80, ::80],
                                                k=tuple(np.array(f.k) / 80)), h)),
              'used'),
]


@dataclass
class SceneOutcome:
    case: str
    counted: str            # the scene count the node made of the frame
    cloud: str              # what became of the cloud cut from it: answered / rejected:<reason>
    seconds: float
    next_good: str = ''     # the next good frame's scene count and its cloud's fate


class SceneCaseRunner:
    """
    Publish a frame and the cloud cut from it to a node in this process; read its counts.

    The node must subscribe OBJECT_TOPIC with scene_topics [IMAGE_TOPIC] and scene_type
    depth_image; the runner waits for the node to hold each frame before it sends the cloud.
    """

    def __init__(self, node, client, frame: Frame):
        from rclpy.qos import QoSProfile
        from sensor_msgs.msg import CameraInfo, Image, PointCloud2

        self.node, self.frame = node, frame
        self.stats = node.stats[OBJECT_TOPIC]
        self.scenes = node.answerer.scenes
        qos = QoSProfile(depth=4)   # reliable: a lost frame would be counted as missing
        self.clouds = client.create_publisher(PointCloud2, f'/{OBJECT_TOPIC}', qos)
        self.images = client.create_publisher(Image, f'/{IMAGE_TOPIC}', qos)
        self.infos = client.create_publisher(CameraInfo, f'/{INFO_TOPIC}', qos)
        self._sec = 100

    def ready(self, timeout: float = 30.0) -> bool:
        """Wait until the node and the runner see each other on all three topics."""
        pubs = (self.clouds, self.images, self.infos)
        return wait_for(lambda: all(p.get_subscription_count() for p in pubs) and all(
            self.node.count_publishers(p.topic_name) for p in pubs), timeout, STEP)

    def _header(self):
        from builtin_interfaces.msg import Time
        from std_msgs.msg import Header
        self._sec += 1
        return Header(stamp=Time(sec=self._sec, nanosec=500), frame_id=FRAME)

    def send(self, make, timeout: float = 60.0) -> SceneOutcome:
        from pcrp_ros.conversions import xyz_to_pointcloud2
        header = self._header()
        msg, info = make(self.frame, header)
        topic = IMAGE_TOPIC
        if info is not None:
            self.infos.publish(info)
            wait_for(lambda: self.scenes.camera_info.get(topic) is not None
                     and self.scenes.camera_info[topic].header.stamp == info.header.stamp,
                     HELD_SECONDS, STEP)
        self.images.publish(msg)
        wait_for(lambda: self.scenes.buffer.find(topic, msg.header) is not None, HELD_SECONDS,
                 STEP)
        counts, scenes = dict(self.stats.counts), dict(self.stats.scenes)
        t0 = time.monotonic()
        self.clouds.publish(xyz_to_pointcloud2(self.frame.points, header))
        decided = lambda: sum(self.stats.counts[k] - counts.get(k, 0)  # noqa: E731
                              for k in ('answered', 'rejected', 'dropped_stale'))
        wait_for(decided, timeout, STEP)
        seconds = time.monotonic() - t0
        counted = [k for k, v in self.stats.scenes.items() if v > scenes.get(k, 0)]
        if self.stats.counts['answered'] > counts.get('answered', 0):
            cloud = 'answered'
        else:
            cloud = 'rejected' if decided() else 'lost'
        return SceneOutcome('', ', '.join(sorted(counted)) or 'none', cloud, seconds)

    def run(self, case: SceneCase) -> SceneOutcome:
        out = self.send(case.make)
        out.case = case.name
        good = self.send(_good)
        out.next_good = f'{good.counted}, {good.cloud}'
        return out


def accepted(case: SceneCase, out: SceneOutcome) -> bool:
    """Say whether the frame was counted as the case says, its cloud answered, the next used."""
    return (out.counted == case.counted and out.cloud == 'answered'
            and out.next_good == 'used, answered')
