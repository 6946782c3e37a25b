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

"""The managed node over real DDS, driven through its lifecycle services as ros2 lifecycle does."""

from builtin_interfaces.msg import Time
from geometry_msgs.msg import PoseStamped
from lifecycle_msgs.msg import State, Transition
from lifecycle_msgs.srv import ChangeState, GetState
import numpy as np
from pcrp_core import PCRP
from pcrp_ros.conversions import xyz_to_pointcloud2
from pcrp_ros.lifecycle_node import PcrpLifecycleNode
import rclpy
from rclpy.parameter import Parameter
from rclpy.qos import QoSProfile
from rosutil import publish_until, ros_context, spinning, wait_for
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header

TOPIC = 'lifecycle_object'


def _call(client, request, timeout=120.0):
    assert client.wait_for_service(timeout_sec=20.0), client.srv_name
    future = client.call_async(request)
    assert wait_for(future.done, timeout), f'{client.srv_name}: no response'
    return future.result()


class Driver:
    """What `ros2 lifecycle set/get` does: the node's change_state and get_state services."""

    def __init__(self, client, name):
        self.change = client.create_client(ChangeState, f'/{name}/change_state')
        self.get = client.create_client(GetState, f'/{name}/get_state')

    def transition(self, transition: int) -> bool:
        return _call(self.change, ChangeState.Request(
            transition=Transition(id=transition))).success

    def state(self) -> int:
        return _call(self.get, GetState.Request()).current_state.id


def test_transitions_load_answer_stop_and_free_the_model(tmp_path):
    model = PCRP.load(None)
    gid = model.gallery_ids[5]
    cloud = model.gallery_cloud(gid).astype(np.float64) + [0.0, 0.0, 2.0]
    with ros_context() as ctx:
        node = PcrpLifecycleNode(context=ctx, parameter_overrides=[
            Parameter('input_topics', value=[TOPIC]),
            Parameter('sensor_at_origin', value=False),
            Parameter('model_path', value=str(tmp_path / 'no_model_here'))])
        client = rclpy.create_node('lifecycle_driver', context=ctx)
        poses = []
        client.create_subscription(PoseStamped, f'/{TOPIC}/pose', poses.append, 10)
        pub = client.create_publisher(PointCloud2, f'/{TOPIC}', QoSProfile(depth=5))
        drive = Driver(client, 'pcrp_node')

        def cloud_msg(sec):
            return xyz_to_pointcloud2(cloud, Header(stamp=Time(sec=sec), frame_id='cam'))

        with spinning(ctx, node, client):
            assert drive.state() == State.PRIMARY_STATE_UNCONFIGURED
            assert node.model is None and not pub.get_subscription_count()
            # a configure that cannot load the model fails and leaves the node unconfigured
            assert not drive.transition(Transition.TRANSITION_CONFIGURE)
            assert drive.state() == State.PRIMARY_STATE_UNCONFIGURED and node.model is None
            # a transition the state has none of, asked for by id as a lifecycle manager may:
            # refused, and the node stays up (rclpy alone raised in the service and stopped it)
            assert not drive.transition(Transition.TRANSITION_ACTIVATE)
            assert drive.state() == State.PRIMARY_STATE_UNCONFIGURED
            node.set_parameters([Parameter('model_path', value='')])
            assert drive.transition(Transition.TRANSITION_CONFIGURE)
            assert drive.state() == State.PRIMARY_STATE_INACTIVE
            assert node.model is not None and gid in node.model.gallery_ids
            # inactive: the model is loaded, but nothing listens yet
            assert not wait_for(lambda: pub.get_subscription_count(), 1.0)

            assert drive.transition(Transition.TRANSITION_ACTIVATE)
            assert drive.state() == State.PRIMARY_STATE_ACTIVE
            assert wait_for(lambda: pub.get_subscription_count(), 10)
            assert publish_until(pub, cloud_msg(1), lambda: poses)
            assert poses[0].header.stamp.sec == 1

            assert drive.transition(Transition.TRANSITION_DEACTIVATE)
            assert drive.state() == State.PRIMARY_STATE_INACTIVE
            assert wait_for(lambda: not pub.get_subscription_count(), 10)
            answered = len(poses)
            received = node.stats[TOPIC].counts['received']
            pub.publish(cloud_msg(2))
            assert not wait_for(lambda: len(poses) > answered, 3.0)
            assert node.stats[TOPIC].counts['received'] == received

            # answering again after a second activate
            assert drive.transition(Transition.TRANSITION_ACTIVATE)
            assert wait_for(lambda: pub.get_subscription_count(), 10)
            assert publish_until(pub, cloud_msg(3), lambda: any(
                p.header.stamp.sec == 3 for p in poses))

            assert drive.transition(Transition.TRANSITION_DEACTIVATE)
            assert drive.transition(Transition.TRANSITION_CLEANUP)
            assert drive.state() == State.PRIMARY_STATE_UNCONFIGURED
            assert node.model is None and node.answerer.engine is None
            assert drive.transition(Transition.TRANSITION_UNCONFIGURED_SHUTDOWN)
            assert drive.state() == State.PRIMARY_STATE_FINALIZED


def test_an_unconfigured_node_checks_parameters_without_a_model():
    with ros_context() as ctx:
        node = PcrpLifecycleNode(context=ctx)
        try:
            assert node.model is None
            bad = node.set_parameters([Parameter('n_candidates', value=0)])[0]
            assert not bad.successful and 'n_candidates' in bad.reason
            bad = node.set_parameters([Parameter('min_points', value=5000)])[0]
            assert not bad.successful and 'min_points' in bad.reason
            assert node.set_parameters([Parameter('min_confidence', value=0.3)])[0].successful
            assert node.answerer._params['min_confidence'] == 0.3
        finally:
            node.destroy_node()
