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
Launch several pcrp_node processes sharing the work.

Each answers its share of the input topics (round robin) under its own name, all reading the
same model file. Example:

  ros2 launch pcrp pcrp_scaled.launch.py topics:=cam_a/object,cam_b/object processes:=2

On one 2-core machine two processes answer about twice as many clouds per second as one
(docs/results/BENCHMARKS.md); across machines, run one such launch per machine with its topics.
"""

import os

from ament_index_python.packages import get_package_share_directory
from launch import LaunchDescription
from launch.actions import DeclareLaunchArgument, OpaqueFunction
from launch.substitutions import LaunchConfiguration
from launch_ros.actions import Node


def _nodes(context):
    topics = [
        t.strip() for t in LaunchConfiguration('topics').perform(context).split(',') if t.strip()
    ]
    k = max(1, min(int(LaunchConfiguration('processes').perform(context)), len(topics)))
    params = LaunchConfiguration('params_file').perform(context)
    return [Node(package='pcrp', executable='pcrp_node', name=f'pcrp_node_{i}', output='screen',
                 parameters=[params, {'input_topics': topics[i::k]}])
            for i in range(k)]


def generate_launch_description():
    params = os.path.join(get_package_share_directory('pcrp'), 'config', 'pcrp.yaml')
    return LaunchDescription([
        DeclareLaunchArgument('params_file', default_value=params),
        DeclareLaunchArgument('topics', default_value='segmented_object',
                              description='comma-separated input topics to share out'),
        DeclareLaunchArgument('processes', default_value='2', description='node processes'),
        OpaqueFunction(function=_nodes),
    ])
