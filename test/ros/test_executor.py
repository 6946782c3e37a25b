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

"""The executor pcrp nodes spin on: a burst on several topics starts every callback at once."""

import threading
import time

import pytest
import rclpy
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.qos import DurabilityPolicy, QoSProfile
from rosutil import ros_context, spinning, wait_for
from std_msgs.msg import String

# as long as a callback may be busy (screening a cloud under load took 40-50 ms); long enough
# that one callback left waiting for a thread shows far beyond scheduling noise
HOLD_S = 0.5


@pytest.mark.parametrize('n_topics', [4, 24])
def test_a_burst_on_several_topics_starts_every_callback_at_once(n_topics):
    topics = [f'burst_{k}' for k in range(n_topics)]
    # transient local: a message published before the subscriber saw the publisher still arrives
    qos = QoSProfile(depth=1, durability=DurabilityPolicy.TRANSIENT_LOCAL)
    started, lock = {}, threading.Lock()

    def callback(topic):
        def on_message(msg):
            with lock:
                started.setdefault(topic, time.monotonic())
            time.sleep(HOLD_S)
        return on_message

    with ros_context() as ctx:
        listener = rclpy.create_node('burst_listener', context=ctx)
        talker = rclpy.create_node('burst_talker', context=ctx)
        for t in topics:
            # a group per topic, as the node's input topics have
            listener.create_subscription(String, t, callback(t), qos,
                                         callback_group=MutuallyExclusiveCallbackGroup())
        pubs = [talker.create_publisher(String, t, qos) for t in topics]
        with spinning(ctx, listener, talker):
            assert wait_for(lambda: all(p.get_subscription_count() for p in pubs), 30.0)
            for p in pubs:
                p.publish(String(data='cloud'))
            wait_for(lambda: len(started) == len(topics), 30.0)
    assert len(started) == len(topics)
    # with a thread short, the last callbacks start a whole HOLD_S after the first
    assert max(started.values()) - min(started.values()) < HOLD_S / 2
