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

"""ament_python package `pcrp`: `colcon build` on a Jazzy install, or `pip install .`."""

from glob import glob
import os
from xml.etree import ElementTree

from setuptools import find_namespace_packages, setup

PACKAGE = 'pcrp'
# name, version, maintainer and license are package.xml's, so the two cannot disagree
MANIFEST = ElementTree.parse(
    os.path.join(os.path.dirname(os.path.abspath(__file__)), 'package.xml')).getroot()
MAINTAINER = MANIFEST.find('maintainer')

setup(
    name=MANIFEST.findtext('name'),
    version=MANIFEST.findtext('version'),
    # namespace packages too: the model and the demo bag live in folders without __init__.py
    packages=find_namespace_packages(include=['pcrp_core', 'pcrp_core.*', 'pcrp_ros',
                                              'pcrp_ros.*'], exclude=['*.__pycache__']),
    package_data={'pcrp_core': ['data/*/*'], 'pcrp_ros': ['data/*/*']},
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/config', glob('config/*.yaml') + glob('config/*.xml')),
        (f'share/{PACKAGE}/launch', glob('launch/*.launch.py')),
    ],
    # lower bounds: the oldest versions the core, bag and CLI tests pass with (checked by
    # `python -m tools.lower_bounds`): scipy 1.12 for Rotation.align_vectors' least turn between
    # two single vectors, open3d 0.20 for utility.set_max_threads (pcrp_core/threads.py holds
    # Open3D to one thread with it, which repeatable builds need), rosbags 0.11 for
    # StoragePlugin; the others are what Ubuntu Noble (ROS 2 Jazzy's platform) ships
    install_requires=[
        'setuptools',
        'numpy>=1.26',
        'scipy>=1.12',
        'scikit-learn>=1.4',
        'joblib>=1.3',
        'threadpoolctl>=3.1',
        'tqdm>=4.66',
        'open3d>=0.20',
        'rosbags>=0.11',
    ],
    extras_require={'test': ['pytest', 'hypothesis']},
    zip_safe=False,
    maintainer=MAINTAINER.text,
    maintainer_email=MAINTAINER.get('email'),
    description='Unsupervised point cloud object retrieval and pose estimation (PCRP) for ROS 2',
    license=MANIFEST.findtext('license'),
    python_requires='>=3.10',
    entry_points={
        'console_scripts': [
            'pcrp = pcrp_ros.entry_points:pcrp',
            'pcrp_node = pcrp_ros.entry_points:pcrp_node',
            'pcrp_lifecycle_node = pcrp_ros.entry_points:pcrp_lifecycle_node',
        ],
    },
)
