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

"""The shipped Fast DDS profile carries bursts of camera-sized clouds that its defaults drop."""
from collections import Counter
import os
from pathlib import Path
import subprocess
import sys
from xml.etree import ElementTree

from rclpy.qos import qos_profile_sensor_data
from rosutil import ros_context, spinning, wait_for
from sensor_msgs.msg import PointCloud2
from tools.soak import LARGE_CLOUDS_PROFILE, PROFILE_VARIABLE, use_driver_profile

TOPICS = 4
BURSTS = 10

# A segmenter's frame: four objects' clouds of 20,000 points (240 KB each) published at once,
# twice a second, from one process, once the test's subscriber is matched on every topic.
PUBLISHER = f"""
import time
import numpy as np
import rclpy
from rclpy.qos import QoSProfile
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import Header
from pcrp_ros.conversions import xyz_to_pointcloud2
rclpy.init()
node = rclpy.create_node('burst_publisher')
pubs = [node.create_publisher(PointCloud2, f'/burst/object_{{k}}', QoSProfile(depth=10))
        for k in range({TOPICS})]
while not all(p.get_subscription_count() for p in pubs):
    time.sleep(0.05)
time.sleep(2.0)  # matching is not symmetric: let the subscriber see this publisher too
cloud = xyz_to_pointcloud2(np.random.default_rng(0).normal(size=(20000, 3)), Header())
for _ in range({BURSTS}):
    for p in pubs:
        p.publish(cloud)
    time.sleep(0.5)
time.sleep(1.0)
"""


def test_the_profile_is_installed_with_the_package():
    setup = (Path(__file__).resolve().parents[2] / 'setup.py').read_text()
    assert "glob('config/*.xml')" in setup
    root = ElementTree.parse(LARGE_CLOUDS_PROFILE).getroot()
    sizes = [int(e.text) for e in root.iter() if e.tag.endswith('segment_size')]
    assert sizes and min(sizes) >= 4 * 1024 * 1024


def test_a_burst_of_four_camera_clouds_arrives_whole_with_the_profile():
    env = dict(os.environ, **{PROFILE_VARIABLE: str(LARGE_CLOUDS_PROFILE)})
    got = Counter()
    with ros_context() as ctx:
        import rclpy
        node = rclpy.create_node('burst_counter', context=ctx)
        for k in range(TOPICS):
            node.create_subscription(PointCloud2, f'/burst/object_{k}',
                                     lambda m, k=k: got.update([k]), qos_profile_sensor_data)
        with spinning(ctx, node):
            pub = subprocess.Popen([sys.executable, '-c', PUBLISHER], env=env)
            try:
                pub.wait(timeout=60)
            finally:
                pub.kill()
            wait_for(lambda: sum(got.values()) == TOPICS * BURSTS, 5.0)
    assert pub.returncode == 0
    # on Fast DDS defaults about one cloud in six of such bursts never arrives
    assert got == Counter({k: BURSTS for k in range(TOPICS)})


def test_one_profile_per_soak_process():
    import tools.soak as soak
    saved = list(soak._driver_profile_in_use), os.environ.get(PROFILE_VARIABLE)
    try:
        soak._driver_profile_in_use[:] = []
        use_driver_profile(None)
        use_driver_profile(None)
        try:
            use_driver_profile(LARGE_CLOUDS_PROFILE)
        except ValueError as e:
            assert 'one profile per process' in str(e)
        else:
            raise AssertionError('a second profile in one process was taken')
    finally:
        soak._driver_profile_in_use[:] = saved[0]
        if saved[1] is None:
            os.environ.pop(PROFILE_VARIABLE, None)
        else:
            os.environ[PROFILE_VARIABLE] = saved[1]
