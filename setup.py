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

from setuptools import find_packages, setup

PACKAGE = 'pcrp'

setup(
    name=PACKAGE,
    version='0.1.0',
    packages=find_packages(include=['pcrp_core', 'pcrp_core.*', 'pcrp_ros', 'pcrp_ros.*']),
    package_data={'pcrp_core': ['data/*/*'], 'pcrp_ros': ['data/*/*']},
    include_package_data=True,
    data_files=[
        ('share/ament_index/resource_index/packages', [f'resource/{PACKAGE}']),
        (f'share/{PACKAGE}', ['package.xml']),
        (f'share/{PACKAGE}/config', glob('config/*.yaml')),
        (f'share/{PACKAGE}/launch', glob('launch/*.launch.py')),
    ],
    install_requires=['setuptools'],
    zip_safe=False,
    maintainer='pcrp maintainers',
    maintainer_email='pcrp@example.com',
    description='Unsupervised point cloud object retrieval and pose estimation (PCRP) for ROS 2',
    license='Apache-2.0',
    tests_require=['pytest'],
    python_requires='>=3.10',
    entry_points={
        'console_scripts': [
            'pcrp = pcrp_ros.cli:main',
            'pcrp_node = pcrp_ros.node:main',
            'pcrp_lifecycle_node = pcrp_ros.lifecycle_node:main',
        ],
    },
)
