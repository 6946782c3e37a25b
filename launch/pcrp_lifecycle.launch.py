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
Launch pcrp_lifecycle_node, the managed variant, with config/pcrp.yaml.

With autostart:=true (the default) the launch configures the node and, once it is inactive
after configuring, activates it; with autostart:=false it stays unconfigured until a lifecycle
manager or `ros2 lifecycle set /pcrp_node configure` (then `activate`) moves it on. A
configure that fails (a broken model) is logged by the node, which stays unconfigured.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, EmitEvent, RegisterEventHandler
from launch.conditions import IfCondition
from launch.events import matches_action
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import LifecycleNode
from launch_ros.event_handlers import OnStateTransition
from launch_ros.events.lifecycle import ChangeState
from lifecycle_msgs.msg import Transition


def generate_launch_description():
    params = os.path.join(get_package_share_directory('pcrp'), 'config', 'pcrp.yaml')
    node = LifecycleNode(package='pcrp', executable='pcrp_lifecycle_node', name='pcrp_node',
                         namespace=LaunchConfiguration('namespace'), output='screen',
                         parameters=[LaunchConfiguration('params_file')])
    autostart = IfCondition(LaunchConfiguration('autostart'))
    configure = EmitEvent(event=ChangeState(lifecycle_node_matcher=matches_action(node),
                                            transition_id=Transition.TRANSITION_CONFIGURE),
                          condition=autostart)
    # only after configuring: a node deactivated later by hand stays inactive
    activate = RegisterEventHandler(OnStateTransition(
        target_lifecycle_node=node, start_state='configuring', goal_state='inactive',
        entities=[EmitEvent(event=ChangeState(lifecycle_node_matcher=matches_action(node),
                                              transition_id=Transition.TRANSITION_ACTIVATE))]),
        condition=autostart)
    return LaunchDescription([
        DeclareLaunchArgument('params_file', default_value=params),
        DeclareLaunchArgument('namespace', default_value=''),
        DeclareLaunchArgument('autostart', default_value='true',
                              description='configure and activate the node at launch'),
        node,
        activate,
        configure,
    ])
