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
Bad depth images as scenes cost no cloud its answer, and the next good frame is used.

Every case of tools/bad_scenes.py over DDS, in the catalogue's order (its first case needs a node
that has had no CameraInfo yet). The same catalogue writes a table of docs/results/ROBUSTNESS.md.
"""
from pcrp_core import PCRP
from pcrp_ros.node import PcrpNode
import rclpy
# sets ROS_DOMAIN_ID and the discovery range before any context is made
from rosutil import ros_context, spinning
from tools.bad_scenes import accepted, camera_frame, CASES, node_parameters, SceneCaseRunner


def test_every_bad_depth_image_is_counted_and_its_cloud_still_answered():
    model = PCRP.load(None)
    with ros_context() as ctx:
        node = PcrpNode(model=model, context=ctx, parameter_overrides=node_parameters())
        client = rclpy.create_node('scene_robustness_client', context=ctx)
        runner = SceneCaseRunner(node, client, camera_frame(model))
        with spinning(ctx, node, client):
            assert runner.ready()
            outcomes = [(case, runner.run(case)) for case in CASES]
    wrong = [(case.name, case.counted, out.counted, out.cloud, out.next_good)
             for case, out in outcomes if not accepted(case, out)]
    assert not wrong, wrong
    # each frame and the good one after it: two clouds, each decided once
    counts = node.stats['segmented_object'].counts
    assert counts['received'] == 2 * len(CASES) == counts['answered']
