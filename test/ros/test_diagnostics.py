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

"""What /diagnostics says: names that tell instances apart, levels, confidences, stage times."""

import sys
import threading
import types

from builtin_interfaces.msg import Time
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus
import numpy as np
from pcrp_core import PCRP
from pcrp_core.result import PoseResult
from pcrp_ros.answering import Waiting
from pcrp_ros.conversions import detections_msg, xyz_to_pointcloud2
from pcrp_ros.node import PcrpNode
from pcrp_ros.stats import DROP_WARN, RECENT, StreamStats, WARN_STREAK
import pytest
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosutil import publish_until, ros_context, spinning, wait_for
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header


@pytest.fixture(scope='module')
def model():
    return PCRP.load(None)


def _values(status):
    return {kv.key: kv.value for kv in status.values}


def test_instances_in_two_namespaces_publish_different_names(model):
    with ros_context() as ctx:
        nodes = [PcrpNode(model=model, context=ctx, namespace=ns) for ns in ('r1', 'r2')]
        try:
            names = [[s.name for s in n.answerer.diagnostics().status] for n in nodes]
        finally:
            for n in nodes:
                n.destroy_node()
    assert names == [['/r1/pcrp_node: model', '/r1/pcrp_node: /r1/segmented_object'],
                     ['/r2/pcrp_node: model', '/r2/pcrp_node: /r2/segmented_object']]


def test_levels_follow_what_was_decided():
    s = StreamStats()
    assert s.status() == (True, '0 answered of 0')
    s.count('received')
    ok, text = s.status()
    assert ok and 'answering the first cloud' in text
    s.count('rejected', 'too_few_points')
    ok, text = s.status()
    assert not ok and 'none answered yet' in text and 'too_few_points 1' in text
    s.count('received')
    s.count('answered')
    assert s.status()[0]
    for _ in range(WARN_STREAK - 1):
        s.count('rejected', 'low_confidence')
    assert s.status()[0], 'a few rejections between answers are no warning'
    s.count('rejected', 'low_confidence')
    ok, text = s.status()
    assert not ok and f'last {WARN_STREAK} rejected' in text
    s.count('answered')
    assert s.status()[0]
    # a node that falls behind: newer clouds push the waiting ones out unanswered
    for _ in range(DROP_WARN - 1):
        s.count('dropped_stale')
        s.count('answered')
    assert s.status()[0], 'a few clouds dropped in bursts are no warning'
    s.count('dropped_stale')
    ok, text = s.status()
    assert not ok and f'falling behind, {DROP_WARN} of the last' in text
    s.count('answered')
    assert not s.status()[0], 'an answer between drops is not keeping up'
    for _ in range(RECENT):
        s.count('answered')
    assert s.status()[0], 'once it keeps up again'


def test_a_topic_is_ok_while_its_first_cloud_is_answered_then_reports_what_it_saw(
        model, monkeypatch):
    topic = 'diagnosed_object'
    gate, started = threading.Event(), threading.Event()
    estimate = model.estimate

    def held(*args, **kwargs):
        started.set()
        assert gate.wait(60)
        return estimate(*args, **kwargs)
    monkeypatch.setattr(model, 'estimate', held)
    cloud = model.gallery_cloud(model.gallery_ids[9]).astype(np.float64) + [0.0, 0.0, 2.0]
    with ros_context() as ctx:
        node = PcrpNode(model=model, context=ctx, parameter_overrides=[
            Parameter('input_topics', value=[topic]), Parameter('sensor_at_origin', value=False)])
        client = rclpy.create_node('diagnostics_client', context=ctx)
        arrays = []
        client.create_subscription(DiagnosticArray, '/diagnostics', arrays.append, 10)
        pub = client.create_publisher(PointCloud2, f'/{topic}', QoSProfile(depth=2))
        name = f'/pcrp_node: /{topic}'

        def latest():
            for arr in reversed(arrays):
                for s in arr.status:
                    if s.name == name:
                        return s
        with spinning(ctx, node, client):
            assert wait_for(lambda: pub.get_subscription_count(), 10)
            msg = xyz_to_pointcloud2(cloud, Header(stamp=Time(sec=1), frame_id='cam'))
            assert publish_until(pub, msg, started.is_set, timeout=30)
            seen = len(arrays)
            assert wait_for(lambda: len(arrays) > seen + 1, 10)   # a status made meanwhile
            busy = latest()
            assert busy.level == DiagnosticStatus.OK and 'first cloud' in busy.message
            gate.set()
            stats = node.stats[topic]
            assert wait_for(lambda: stats.counts['answered'] >= 1, 60)
            seen = len(arrays)
            assert wait_for(lambda: len(arrays) > seen + 1, 10)
            done = latest()
        values = _values(done)
        assert done.level == DiagnosticStatus.OK
        assert 0.0 <= float(values['confidence_last']) <= 1.0
        assert values['confidence_last'] == values['confidence_mean']   # one answer so far
        # every stage the core timed, as p50 and p95 in ms
        assert {'stage_total_p50_ms', 'stage_total_p95_ms', 'stage_features_p50_ms'} <= set(values)
        assert float(values['stage_total_p95_ms']) >= float(values['stage_features_p95_ms']) > 0


def test_detections_carry_the_confidence_as_their_score(monkeypatch):
    class Box:
        def __init__(self, **kwargs):
            self.__dict__.update(kwargs)

    class Hypothesis:
        def __init__(self):
            self.hypothesis = Box(class_id='', score=0.0)
            self.pose = Box(pose=None)

    class Detection:
        def __init__(self, header=None):
            self.header, self.results, self.id = header, [], ''
            self.bbox = Box(center=None, size=Box(x=0.0, y=0.0, z=0.0))
    fake = types.ModuleType('vision_msgs.msg')
    fake.Detection3D, fake.ObjectHypothesisWithPose = Detection, Hypothesis
    fake.Detection3DArray = Box
    monkeypatch.setitem(sys.modules, 'vision_msgs', types.ModuleType('vision_msgs'))
    monkeypatch.setitem(sys.modules, 'vision_msgs.msg', fake)
    result = PoseResult('chair_0001', 'chair', np.eye(3), np.zeros(3), score=0.9, confidence=0.37)
    out = detections_msg(result, Header(frame_id='cam'))
    hyp = out.detections[0].results[0].hypothesis
    assert hyp.score == pytest.approx(0.37) and hyp.class_id == 'chair_0001'
    # with the object's points, the box is the object's: a mug 8 x 8 x 10 cm whose origin is at
    # its base, answered lying on its side 1 m ahead, has its box's centre 5 cm off the origin
    mug = np.array([[x, y, z] for x in (-0.04, 0.04) for y in (-0.04, 0.04) for z in (0.0, 0.1)])
    R = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])   # z turned onto -y
    lying = PoseResult('mug', 'mug', R, np.array([0.0, 0.0, 1.0]), confidence=0.9)
    box = detections_msg(lying, Header(frame_id='cam'), mug).detections[0].bbox
    c = box.center.position
    np.testing.assert_allclose([c.x, c.y, c.z], [0.0, -0.05, 1.0], atol=1e-12)
    np.testing.assert_allclose([box.size.x, box.size.y, box.size.z], [0.08, 0.08, 0.1])
    o = box.center.orientation
    np.testing.assert_allclose(np.abs([o.x, o.y, o.z, o.w]), np.abs(lying.quaternion), atol=1e-12)


def test_a_rejected_answer_publishes_nothing_but_its_timings_count(model, monkeypatch):
    rejected = PoseResult('chair_0001', 'chair', np.eye(3), np.zeros(3), confidence=0.2,
                          rejected=True, reason='confidence 0.20 below 0.50',
                          timings={'features': 0.01, 'total': 0.3}, stray_share=0.04)
    monkeypatch.setattr(model, 'estimate', lambda *args, **kwargs: rejected)

    class Recorder:
        def __init__(self):
            self.sent = []

        def publish(self, msg):
            self.sent.append(msg)
    with ros_context() as ctx:
        node = PcrpNode(model=model, context=ctx)
        try:
            answerer = node.answerer
            recorders = {k: Recorder() for k in answerer._pubs['segmented_object']}
            monkeypatch.setitem(answerer._pubs, 'segmented_object', recorders)
            answerer.answer('segmented_object', Waiting(Header(), np.zeros((40, 3)), 0.0),
                            answerer.engine)
            assert all(not r.sent for r in recorders.values())
            snap = node.stats['segmented_object'].snapshot()
            assert snap['rejected_low_confidence'] == 1 and 'answered' not in snap
            assert snap['stage_total_p50_ms'] == pytest.approx(300.0)
            assert 'confidence_last' not in snap   # confidences are of published answers
            # strays are counted for every estimate, rejected or not
            assert snap['with_strays'] == 1 and snap['stray_share_mean'] == pytest.approx(0.04)
        finally:
            node.destroy_node()
