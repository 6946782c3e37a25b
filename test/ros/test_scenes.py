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
scene_topics: clouds answered with the depth cloud of their stamp and frame, over real DDS.

A partly hidden household object (the shipped model's cone, a quarter of it behind an occluder)
is published with the camera's whole depth cloud, organized and with NaN holes. Its answer is
surer with the scene than without; every scene that cannot be used leaves the cloud answered.
"""

from builtin_interfaces.msg import Time
from helpers import hidden_cone, surer
import numpy as np
from pcrp_core import DepthImage, PCRP
from pcrp_ros.conversions import pointcloud2_to_xyz, xyz_to_pointcloud2
from pcrp_ros.node import PcrpNode
from pcrp_ros.parameters import NodeSettings
from pcrp_ros.workers import ProcessEstimator
import pytest
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile, ReliabilityPolicy
# sets ROS_DOMAIN_ID and the discovery range before any context is made
from rosutil import own_domain_env, ros_context, spinning, wait_for
from sensor_msgs.msg import CameraInfo, Image, PointCloud2
from std_msgs.msg import Header
from tools import bad_scenes

OBJECT, DEPTH = 'scene_test/object', 'scene_test/depth'
FRAME = 'camera_depth_optical_frame'
# reliable both ways: every message of a case arrives, so each count below is exact
RELIABLE = QoSProfile(depth=10, reliability=ReliabilityPolicy.RELIABLE)


@pytest.fixture(scope='module')
def model():
    return PCRP.load(None)


@pytest.fixture(scope='module')
def view():
    scene = hidden_cone()
    assert scene.occluder is not None
    return scene


def _header(sec, frame=FRAME):
    return Header(stamp=Time(sec=sec, nanosec=500), frame_id=frame)


def _depth_cloud(view, header, width=64):
    """Make the whole depth cloud as a driver publishes it: organized, NaN holes, a wall behind."""
    far = float(view.points[:, 2].max()) + 0.3
    u, v = np.meshgrid(np.linspace(-1.2, 1.2, 60), np.linspace(-0.9, 0.9, 45))
    wall = np.stack([u.ravel() * far, v.ravel() * far, np.full(u.size, far)], axis=1)
    points = np.concatenate([view.points, view.occluder, wall]).astype(np.float32)
    points[::7] = np.nan                                     # pixels without a depth
    height = -(-len(points) // width)
    holes = np.full((height * width - len(points), 3), np.nan, dtype=np.float32)
    msg = xyz_to_pointcloud2(np.concatenate([points, holes]), header)
    msg.height, msg.width, msg.row_step = height, width, width * msg.point_step
    return msg


class Stream:
    """The node's object and scene topics, and what its model was asked to estimate."""

    def __init__(self, node, client, model):
        self.node, self.stats = node, node.stats[OBJECT]
        self.objects = client.create_publisher(PointCloud2, f'/{OBJECT}', RELIABLE)
        self.scenes = client.create_publisher(PointCloud2, f'/{DEPTH}', RELIABLE)
        self.calls = []   # (scene given, PoseResult)
        self.fail_with_scene = False
        estimate = model.estimate

        def recorded(points, **kwargs):
            if self.fail_with_scene and kwargs.get('scene') is not None:
                raise RuntimeError('a core that trips over this scene')
            result = estimate(points, **kwargs)
            self.calls.append((kwargs.get('scene'), result))
            return result
        model.estimate = recorded

    def ready(self):
        return wait_for(lambda: self.objects.get_subscription_count()
                        and self.scenes.get_subscription_count(), 10)

    def send(self, cloud, sec, scene=None, frame=FRAME):
        """Publish the scene (if any), then the cloud once the node holds it; await the answer."""
        if scene is not None:
            self.scenes.publish(scene)
            buffered = self.node.answerer.scenes.buffer
            assert wait_for(lambda: buffered.find(DEPTH, scene.header) is not None, 10)
        before = self.stats.counts['answered']
        self.objects.publish(xyz_to_pointcloud2(cloud, _header(sec, frame)))
        assert wait_for(lambda: self.stats.counts['answered'] > before, 60), \
            (dict(self.stats.counts), dict(self.stats.rejections))
        return self.calls[-1]

    def scene_counts(self):
        return {k: v for k, v in self.stats.snapshot().items() if k.startswith('scene_')}


@pytest.fixture(scope='module')
def stream(model):
    with ros_context() as ctx:
        node = PcrpNode(model=model, context=ctx, parameter_overrides=[
            Parameter('input_topics', value=[OBJECT]), Parameter('scene_topics', value=[DEPTH]),
            Parameter('qos_reliability', value='reliable'), Parameter('qos_depth', value=10),
            # every estimate published, however unsure: the counts below are of answers
            Parameter('min_confidence', value=0.0)])
        client = rclpy.create_node('scene_client', context=ctx)
        s = Stream(node, client, model)
        with spinning(ctx, node, client):
            assert s.ready()
            yield s
        del model.estimate   # the recording wrapper


def test_a_cloud_is_answered_with_the_scene_of_its_stamp_and_frame(stream, model, view):
    alone, _ = stream.send(view.points, 1)
    assert alone is None and stream.scene_counts() == {'scene_missing': 1}
    without = stream.calls[-1][1]

    depth = _depth_cloud(view, _header(2))
    given, answer = stream.send(view.points, 2, depth)
    assert stream.scene_counts() == {'scene_missing': 1, 'scene_used': 1}
    # the part of the depth cloud in reach of the object, as the core crops it
    screened = model.screen(view.points.astype(np.float64))
    expected = model.scene_in_reach(screened, pointcloud2_to_xyz(depth), np.zeros(3))
    np.testing.assert_allclose(given, expected, atol=1e-6)
    assert len(view.occluder) < len(given) < len(pointcloud2_to_xyz(depth))   # the wall cropped
    # what the occluder hid is no longer counted missing
    assert answer.gallery_id == without.gallery_id == 'cone'
    assert surer(answer.confidence, without.confidence), (
        answer.confidence, without.confidence)
    statuses = {s.name: s for s in stream.node.answerer.diagnostics().status}
    values = {kv.key: kv.value for kv in statuses[f'/pcrp_node: /{OBJECT}'].values}
    assert values['scene_used'] == '1' and values['scene_missing'] == '1'
    assert values['scene_topic'] == f'/{DEPTH}'


def _camera_frame(view, header):
    """
    Make the depth cloud a camera driver publishes: a pinhole camera's, organized, a wall behind.

    The depth image of the object and its occluder; every other pixel sees the wall.
    """
    image = view.depth_image()
    far = float(view.points[:, 2].max()) + 0.3
    z = np.where(np.isfinite(image.z), image.z, far)
    z[::7, ::5] = np.nan                                     # pixels without a depth
    rows, cols = np.indices(z.shape)
    (fx, fy), (cx, cy) = image.focal, image.centre
    grid = np.stack([(cols - cx) / fx * z, (rows - cy) / fy * z, z], axis=-1)
    msg = xyz_to_pointcloud2(grid.reshape(-1, 3).astype(np.float32), header)
    msg.height, msg.width, msg.row_step = z.shape[0], z.shape[1], z.shape[1] * msg.point_step
    return msg


def test_a_cameras_depth_cloud_is_read_and_cut_as_the_image_it_is(stream, model, view):
    _, without = stream.send(view.points, 20)
    before = stream.scene_counts().get('scene_used', 0)
    depth = _camera_frame(view, _header(21))
    given, answer = stream.send(view.points, 21, depth)
    assert stream.scene_counts()['scene_used'] == before + 1
    assert isinstance(given, DepthImage)
    np.testing.assert_allclose(given.focal, view.camera.fx, rtol=1e-5)
    # cut to the object's reach: at most the image, fewer pixels than the camera has
    assert 0 < given.z.size < depth.width * depth.height
    assert answer.gallery_id == 'cone'
    assert surer(answer.confidence, without.confidence), (
        answer.confidence, without.confidence)


def _without_z(msg):
    msg.fields = [f for f in msg.fields if f.name != 'z']
    return msg


def _truncated(msg):
    msg.data = bytes(msg.data)[:len(msg.data) // 3]
    return msg


BAD_SCENES = [
    # (outcome counted, the scene published for the cloud's stamp: None for none)
    ('missing', lambda view, h: None),
    ('missing', lambda view, h: _depth_cloud(view, Header(stamp=Time(sec=h.stamp.sec + 100),
                                                          frame_id=FRAME))),
    ('rejected_other_frame', lambda view, h: _depth_cloud(view, _header(h.stamp.sec, 'other'))),
    ('rejected_missing_field', lambda view, h: _without_z(_depth_cloud(view, h))),
    ('rejected_truncated_data', lambda view, h: _truncated(_depth_cloud(view, h))),
    ('rejected_empty', lambda view, h: xyz_to_pointcloud2(np.zeros((0, 3)), h)),
    ('rejected_no_finite_points',
     lambda view, h: xyz_to_pointcloud2(np.full((50, 3), np.nan), h)),
]


def test_a_cloud_whose_scene_is_missing_or_unusable_is_answered_without_it_and_counted(
        stream, view):
    said = []
    node = stream.node
    logger = node.get_logger()

    class Recorder:
        def warning(self, text):
            said.append(text)

        def __getattr__(self, name):
            return getattr(logger, name)
    node.get_logger = Recorder
    assert node.set_parameters([Parameter('log_throttle_sec', value=60.0)])[0].successful
    try:
        for k, (outcome, make) in enumerate(BAD_SCENES):
            sec = 100 + k
            before = stream.scene_counts()
            scene, _ = stream.send(view.points, sec, make(view, _header(sec)))
            assert scene is None, outcome
            after = stream.scene_counts()
            assert after.pop(f'scene_{outcome}') == before.pop(f'scene_{outcome}', 0) + 1
            assert after == before, outcome
        # a scene the estimate fails with: the cloud is estimated again without it
        stream.fail_with_scene = True
        scene, answer = stream.send(view.points, 120, _depth_cloud(view, _header(120)))
        assert scene is None and answer.gallery_id == 'cone'
        assert stream.scene_counts()['scene_rejected_internal_error'] == 1
        stream.fail_with_scene = False
        # each kind logged once a throttle period, saying what was wrong
        for outcome in [*dict(BAD_SCENES), 'rejected_internal_error']:
            lines = [t for t in said if f'({outcome}, ' in t]
            if outcome == 'missing':   # twice here, and maybe logged by the test before
                assert len(lines) <= 1, said
            else:
                assert len(lines) == 1, said
            assert all(f'/{DEPTH}:' in t for t in lines), said
        assert any('a core that trips' in t for t in said)
        # the stream goes on: a good scene is used again; none is read when no view uses it
        scene, _ = stream.send(view.points, 130, _depth_cloud(view, _header(130)))
        assert scene is not None
        assert node.set_parameters([Parameter('sensor_at_origin', value=False)])[0].successful
        try:
            scene, _ = stream.send(view.points, 131, _depth_cloud(view, _header(131)))
        finally:
            node.set_parameters([Parameter('sensor_at_origin', value=True)])
        assert scene is None and stream.scene_counts()['scene_unused'] == 1
    finally:
        del node.get_logger
        node.set_parameters([Parameter('log_throttle_sec', value=5.0)])
    assert stream.stats.counts['rejected'] == 0
    assert stream.stats.counts['answered'] == stream.stats.counts['received']


@pytest.mark.parametrize('inputs, scenes, expected', [
    (['a', 'b'], [], {}),
    (['a', 'b'], ['depth'], {'a': 'depth', 'b': 'depth'}),
    (['a', 'b'], ['d1', 'd2'], {'a': 'd1', 'b': 'd2'}),
])
def test_scene_topics_are_one_shared_or_one_per_input_topic(inputs, scenes, expected):
    settings = NodeSettings(input_topics=inputs, scene_topics=scenes)
    assert settings.scene_topic_of() == expected


def test_scene_topics_of_another_length_stop_the_node_with_one_clear_line():
    import subprocess
    import sys
    with pytest.raises(ValueError, match=r'scene_topics: expected one topic shared by every '
                                         r'input topic or one per input topic \(3'):
        NodeSettings(input_topics=['a', 'b', 'c'], scene_topics=['d1', 'd2'])
    env = own_domain_env(70)
    out = subprocess.run(
        [sys.executable, '-m', 'pcrp_ros.node', '--ros-args', '-p', 'scene_topics:=[d1, d2]'],
        capture_output=True, text=True, timeout=120, env=env)
    assert out.returncode == 1 and 'Traceback' not in out.stderr, out.stderr
    error = [line for line in out.stderr.splitlines() if 'pcrp_node: error:' in line]
    assert len(error) == 1 and 'scene_topics' in error[0] and "['d1', 'd2']" in error[0], \
        out.stderr


def test_worker_processes_are_sent_the_cropped_scene_and_use_it(model, view, monkeypatch):
    sent = []
    estimate = ProcessEstimator.estimate

    def recorded(self, points, viewpoint, up, params, scene=None):
        sent.append(scene)
        return estimate(self, points, viewpoint, up, params, scene)
    monkeypatch.setattr(ProcessEstimator, 'estimate', recorded)
    topic, depth_topic = 'scene_workers/object', 'scene_workers/depth'
    with ros_context() as ctx:
        node = PcrpNode(context=ctx, parameter_overrides=[
            Parameter('workers', value=2), Parameter('input_topics', value=[topic]),
            Parameter('scene_topics', value=[depth_topic]),
            Parameter('scene_type', value='points'),   # told, not looked up
            Parameter('qos_reliability', value='reliable'),
            Parameter('min_confidence', value=0.0)])
        client = rclpy.create_node('scene_workers_client', context=ctx)
        objects = client.create_publisher(PointCloud2, f'/{topic}', RELIABLE)
        scenes = client.create_publisher(PointCloud2, f'/{depth_topic}', RELIABLE)
        stats = node.stats[topic]
        depth = _depth_cloud(view, _header(3))
        with spinning(ctx, node, client):
            assert wait_for(lambda: objects.get_subscription_count()
                            and scenes.get_subscription_count(), 10)
            scenes.publish(depth)
            kept = node.answerer.scenes.buffer
            assert wait_for(lambda: kept.find(depth_topic, depth.header), 10)
            objects.publish(xyz_to_pointcloud2(view.points, _header(3)))
            assert wait_for(lambda: stats.counts['answered'] == 1, 120), dict(stats.counts)
        assert stats.snapshot()['scene_used'] == 1
        confidence = stats.confidence[-1]
    screened = model.screen(view.points.astype(np.float64))
    crop = model.scene_in_reach(screened, pointcloud2_to_xyz(depth), np.zeros(3))
    assert len(sent) == 1 and sent[0].dtype == np.float32
    np.testing.assert_allclose(sent[0], crop, atol=1e-6)
    # the worker's answer is the one with the scene, not the one without
    with_scene = model.estimate(screened, viewpoint=np.zeros(3), scene=sent[0]).confidence
    without = model.estimate(screened, viewpoint=np.zeros(3)).confidence
    assert abs(confidence - with_scene) < 0.02 < abs(confidence - without), \
        (confidence, with_scene, without)


def _depth_image(view, header, encoding='16UC1'):
    """Make the depth image a camera driver publishes (millimetres), a wall behind the object."""
    return bad_scenes.image(bad_scenes.frame_of(view), header, encoding=encoding)


def _camera_info(view, header):
    return bad_scenes.camera_info(bad_scenes.frame_of(view), header)


def test_depth_images_are_answered_with_their_camera_info_and_bad_ones_counted(view):
    topic, depth_topic = 'scene_images/object', 'scene_images/depth/image_rect_raw'
    model, given = PCRP.load(None), []
    estimate = model.estimate

    def recorded(points, **kwargs):
        given.append(kwargs.get('scene'))
        return estimate(points, **kwargs)
    model.estimate = recorded
    with ros_context() as ctx:
        node = PcrpNode(model=model, context=ctx, parameter_overrides=[
            Parameter('input_topics', value=[topic]),
            Parameter('scene_topics', value=[depth_topic]),   # scene_type auto: images
            Parameter('qos_reliability', value='reliable'),
            Parameter('min_confidence', value=0.0)])
        client = rclpy.create_node('scene_images_client', context=ctx)
        objects = client.create_publisher(PointCloud2, f'/{topic}', RELIABLE)
        stats, scenes = node.stats[topic], node.answerer.scenes

        def send(sec, image, info=None):
            if info is not None:
                infos.publish(info)
                assert wait_for(lambda: scenes.camera_info, 10)
            images.publish(image)
            assert wait_for(lambda: scenes.buffer.find(depth_topic, image.header), 10)
            before = stats.counts['answered']
            objects.publish(xyz_to_pointcloud2(view.points, _header(sec)))
            assert wait_for(lambda: stats.counts['answered'] > before, 60), dict(stats.counts)
            return given[-1], stats.confidence[-1]

        with spinning(ctx, node, client):
            # no camera yet, so no type to subscribe with: answered without a scene, and counted
            assert wait_for(lambda: objects.get_subscription_count(), 10)
            objects.publish(xyz_to_pointcloud2(view.points, _header(0)))
            assert wait_for(lambda: stats.counts['answered'] == 1, 60), dict(stats.counts)
            assert given[-1] is None and stats.snapshot()['scene_missing'] == 1
            # the camera comes up: its image topic is subscribed as images, CameraInfo beside it
            images = client.create_publisher(Image, f'/{depth_topic}', RELIABLE)
            infos = client.create_publisher(
                CameraInfo, '/scene_images/depth/camera_info', RELIABLE)
            assert wait_for(lambda: images.get_subscription_count()
                            and infos.get_subscription_count(), 10)
            # no CameraInfo yet: answered without the image, and counted
            scene, without = send(1, _depth_image(view, _header(1)))
            assert scene is None and stats.snapshot()['scene_rejected_no_camera_info'] == 1
            info = _camera_info(view, _header(2))
            scene, _ = send(2, _depth_image(view, _header(2), 'rgb8'), info)
            assert scene is None and stats.snapshot()['scene_rejected_bad_encoding'] == 1
            scene, confidence = send(3, _depth_image(view, _header(3)))
            assert isinstance(scene, DepthImage) and stats.snapshot()['scene_used'] == 1
            np.testing.assert_allclose(scene.focal, view.camera.fx)
            assert surer(confidence, without), (confidence, without)
