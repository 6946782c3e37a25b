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

"""workers > 1: worker processes answer, over real DDS, and one that dies is replaced."""

import os
import signal

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
import numpy as np
from pcrp_core import ModelError
from pcrp_ros.conversions import xyz_to_pointcloud2
from pcrp_ros.node import PcrpNode
import pytest
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosutil import publish_until, ros_context, spinning, wait_for
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header

TOPICS = ('workers_a/object', 'workers_b/object')


def _alive(pid):
    """Tell whether the process runs (a killed child not yet reaped, a zombie, does not)."""
    try:
        with open(f'/proc/{pid}/stat') as f:
            return f.read().rsplit(')', 1)[1].split()[0] != 'Z'
    except OSError:
        return False


def test_worker_processes_answer_and_a_killed_one_is_replaced(monkeypatch):
    with ros_context() as ctx:
        node = PcrpNode(context=ctx, parameter_overrides=[
            Parameter('workers', value=2), Parameter('input_topics', value=list(TOPICS)),
            Parameter('sensor_at_origin', value=False)])
        model = node.model
        pids = node.answerer.worker_pids()
        assert len(pids) == 2 and os.getpid() not in pids and all(_alive(p) for p in pids)
        for pid in pids:   # one thread each: one worker per core
            with open(f'/proc/{pid}/environ', 'rb') as f:
                assert b'OMP_NUM_THREADS=1\0' in f.read() + b'\0'

        # the node's own copy of the model never estimates: the workers do
        def not_here(*args, **kwargs):
            raise AssertionError('estimated in the node process')
        monkeypatch.setattr(model, 'estimate', not_here)

        client = rclpy.create_node('workers_client', context=ctx)
        poses = {t: [] for t in TOPICS}
        for t in TOPICS:
            client.create_subscription(PoseStamped, f'/{t}/pose', poses[t].append, 10)
        pubs = {t: client.create_publisher(PointCloud2, f'/{t}', QoSProfile(depth=5))
                for t in TOPICS}
        gids = model.gallery_ids[3], model.gallery_ids[10]
        clouds = {t: model.gallery_cloud(g).astype(np.float64) + [0.0, 0.0, 2.0]
                  for t, g in zip(TOPICS, gids)}

        def send(t, sec):
            msg = xyz_to_pointcloud2(clouds[t], Header(stamp=Time(sec=sec), frame_id=t))
            return publish_until(pubs[t], msg, lambda: any(
                p.header.stamp.sec == sec for p in poses[t]), timeout=120)

        with spinning(ctx, node, client):
            assert wait_for(lambda: all(p.get_subscription_count() for p in pubs.values()), 10)
            assert send(TOPICS[0], 1) and send(TOPICS[1], 2)
            assert poses[TOPICS[0]][0].header.frame_id == TOPICS[0]
            stats = node.stats
            # the count follows the publication by a moment: the pose can be seen first
            assert wait_for(lambda: all(stats[t].counts['answered'] >= 1 for t in TOPICS), 10)

            # a worker killed (out of memory, a crash): the cloud it held is counted, it is
            # started again and the stream goes on
            for pid in pids:
                os.kill(pid, signal.SIGKILL)
            assert wait_for(lambda: not any(_alive(p) for p in pids), 10)
            for sec in range(10, 14):
                t = TOPICS[sec % 2]
                assert send(t, sec), (sec, dict(stats[t].counts), dict(stats[t].rejections))
            new = node.answerer.worker_pids()
            assert not set(new) & set(pids) and all(p and _alive(p) for p in new)
            died = sum(stats[t].rejections['worker_died'] for t in TOPICS)
            assert 1 <= died <= 2 and node.answerer.engine.restarts == 2
            status = {s.name: s for s in node.answerer.diagnostics().status}['/pcrp_node: model']
            values = {kv.key: kv.value for kv in status.values}
            assert values['worker_restarts'] == '2' and values['workers'] == '2'
        assert not any(_alive(p) for p in new), 'workers outlive the node'


def test_a_broken_model_stops_a_node_with_workers_before_any_starts(tmp_path):
    with ros_context() as ctx:
        with pytest.raises(ModelError, match='no such model'):
            PcrpNode(
                context=ctx,
                parameter_overrides=[
                    Parameter('workers', value=2),
                    Parameter('model_path', value=str(tmp_path / 'nowhere')),
                ],
            )
