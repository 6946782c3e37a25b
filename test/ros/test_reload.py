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
Switching models while the node runs, over real DDS.

A stream goes on through the switch; a bad model is refused and the old one kept.
"""

import shutil
import threading

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from helpers import PROCEDURAL_MODEL
import numpy as np
from pcrp_core import PCRP
from pcrp_core.model_io import ARRAYS_FILE
from pcrp_ros.conversions import xyz_to_pointcloud2
from pcrp_ros.node import PcrpNode
import pytest
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosutil import ros_context, spinning, wait_for
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header
from std_srvs.srv import Trigger

TOPIC = 'reload_object'


def _copy(tmp_path, name):
    return str(shutil.copytree(PROCEDURAL_MODEL, tmp_path / name))


def _damage(path):
    arrays = f'{path}/{ARRAYS_FILE}'
    data = bytearray(open(arrays, 'rb').read())
    data[len(data) // 2] ^= 0xFF
    open(arrays, 'wb').write(bytes(data))


class Stream:
    """
    Clouds sent one at a time from a thread of its own.

    Each is sent once the one before was answered or counted: nothing is dropped for being
    stale, so every cloud must be answered.
    """

    def __init__(self, client, node, cloud):
        self.node, self.cloud = node, cloud
        self.poses = []
        client.create_subscription(PoseStamped, f'/{TOPIC}/pose', self.poses.append, 50)
        self.pub = client.create_publisher(PointCloud2, f'/{TOPIC}', QoSProfile(depth=50))
        self.sent = 0
        self.stop = threading.Event()
        self.thread = threading.Thread(target=self._run, daemon=True)

    def decided(self):
        c = self.node.stats[TOPIC].counts
        return c['answered'] + c['rejected'] + c['dropped_stale']

    def _run(self):
        while not self.stop.is_set():
            self.sent += 1
            header = Header(stamp=Time(sec=self.sent), frame_id='cam')
            self.pub.publish(xyz_to_pointcloud2(self.cloud, header))
            if not wait_for(lambda: self.decided() >= self.sent, 60):
                return

    def answered(self):
        return self.node.stats[TOPIC].counts['answered']

    def finish(self):
        self.stop.set()
        self.thread.join(90)
        assert wait_for(lambda: len(self.poses) >= self.answered(), 10)


@pytest.fixture
def node_and_stream(tmp_path):
    model_a = _copy(tmp_path, 'model_a')
    with ros_context() as ctx:
        node = PcrpNode(context=ctx, parameter_overrides=[
            Parameter('input_topics', value=[TOPIC]), Parameter('sensor_at_origin', value=False),
            Parameter('model_path', value=model_a), Parameter('qos_reliability', value='reliable'),
            Parameter('qos_depth', value=10)])
        client = rclpy.create_node('reload_client', context=ctx)
        model = node.model
        cloud = model.gallery_cloud(model.gallery_ids[7]).astype(np.float64) + [0.0, 0.0, 2.0]
        stream = Stream(client, node, cloud)
        with spinning(ctx, node, client):
            assert wait_for(lambda: stream.pub.get_subscription_count(), 10)
            yield node, client, stream, model_a


def _answered_by(model, tag, log):
    """Record in log which model answered each cloud."""
    estimate = model.estimate

    def tagged(*args, **kwargs):
        result = estimate(*args, **kwargs)
        log.append(tag)
        return result
    model.estimate = tagged


def test_a_stream_goes_on_through_a_switch_without_loss(node_and_stream, tmp_path, monkeypatch):
    node, client, stream, model_a = node_and_stream
    model_b = _copy(tmp_path, 'model_b')
    who = []
    _answered_by(node.model, 'a', who)
    gate, loading = threading.Event(), threading.Event()
    real_load = PCRP.load

    def slow_load(path=None):
        # the new model takes as long as the test says: the old one must answer meanwhile
        loading.set()
        assert gate.wait(120)
        model = real_load(path)
        _answered_by(model, 'b', who)
        return model
    monkeypatch.setattr(PCRP, 'load', slow_load)

    stream.thread.start()
    assert wait_for(lambda: stream.answered() >= 2, 60)
    assert node.set_parameters([Parameter('model_path', value=model_b)])[0].successful
    assert loading.wait(30)
    during = stream.answered()
    assert wait_for(lambda: stream.answered() >= during + 2, 60), 'no answer while loading'
    assert set(who) == {'a'}
    gate.set()
    assert wait_for(lambda: node.answerer.engine.path == model_b, 60)
    assert wait_for(lambda: who.count('b') >= 2, 60)
    stream.finish()

    counts = node.stats[TOPIC].counts
    assert counts['received'] == stream.sent and counts['answered'] == stream.sent
    assert counts['rejected'] == 0 and counts['dropped_stale'] == 0
    assert len(stream.poses) == stream.sent
    switched = who.index('b')
    assert who[:switched] == ['a'] * switched and set(who[switched:]) == {'b'}
    assert node.get_parameter('model_path').value == model_b


def test_a_bad_model_is_refused_and_the_old_one_kept(node_and_stream, tmp_path, capfd):
    node, client, stream, model_a = node_and_stream
    broken = _copy(tmp_path, 'broken')
    _damage(broken)
    stream.thread.start()
    # a path with no model directory is refused at once, as `ros2 param set` shows it
    missing = node.set_parameters([Parameter('model_path', value=str(tmp_path / 'none'))])[0]
    assert not missing.successful and 'no such model' in missing.reason
    assert node.get_parameter('model_path').value == model_a
    assert node.set_parameters([Parameter('model_path', value=broken)])[0].successful
    # the parameter goes back to the model still answering, which /diagnostics says why
    assert wait_for(lambda: node.get_parameter('model_path').value == model_a, 60)
    status = {s.name: s for s in node.answerer.diagnostics().status}['/pcrp_node: model']
    assert status.level == status.WARN and 'checksum' in status.message
    assert broken in status.message
    answered = stream.answered()
    assert wait_for(lambda: stream.answered() >= answered + 2, 60)
    stream.finish()
    counts = node.stats[TOPIC].counts
    assert counts['answered'] == stream.sent and counts['rejected'] == 0
    assert node.answerer.engine.path == model_a
    assert 'could not switch to' in capfd.readouterr().err


def test_the_reload_service_reports_success_and_failure(node_and_stream):
    node, client, stream, model_a = node_and_stream
    service = client.create_client(Trigger, '/pcrp_node/reload_model')
    assert service.wait_for_service(timeout_sec=20)

    def call():
        future = service.call_async(Trigger.Request())
        assert wait_for(future.done, 120)
        return future.result()

    first = node.answerer.engine
    ok = call()
    assert ok.success and 'now answering with' in ok.message, ok.message
    assert node.answerer.engine is not first and node.answerer.engine.path == model_a
    # rebuilt in place, badly: refused with the reason, the model loaded before keeps answering
    second = node.answerer.engine
    _damage(model_a)
    bad = call()
    assert not bad.success and 'checksum' in bad.message, bad.message
    assert node.answerer.engine is second
    stream.thread.start()
    assert wait_for(lambda: stream.answered() >= 1, 60)
    stream.finish()
    ok = node.answerer.diagnostics().status[0]
    assert ok.level == ok.WARN and 'checksum' in ok.message


def test_worker_processes_are_replaced_by_a_switch(tmp_path):
    from test_workers import _alive
    model_b = _copy(tmp_path, 'model_b')
    with ros_context() as ctx:
        node = PcrpNode(context=ctx, parameter_overrides=[Parameter('workers', value=2)])
        try:
            old = node.answerer.worker_pids()
            assert node.answerer.reload(model_b).done.wait(120)
            assert node.answerer.engine.path == model_b
            new = node.answerer.worker_pids()
            assert len(new) == 2 and not set(new) & set(old) and all(map(_alive, new))
            # the answering threads let go of the old workers, at the latest when they stop
            node.answerer.deactivate()
            assert wait_for(lambda: not any(map(_alive, old)), 20)
        finally:
            node.destroy_node()
        assert not any(map(_alive, new))
