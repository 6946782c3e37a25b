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

"""scene_type auto: each scene topic is read as what its publishers send (pcrp_ros.answering)."""
from types import SimpleNamespace

from pcrp_ros.answering import CloudAnswerer

PUBLISHED = {
    '/images': ['sensor_msgs/msg/Image'],
    '/clouds': ['sensor_msgs/msg/PointCloud2'],
    '/compressed': ['sensor_msgs/msg/CompressedImage'],   # not a scene the node reads
    '/silent': [],                                          # no publisher yet
}


def _answerer(scene_type: str, warnings: list):
    """Stand in for the node's answerer: its settings, publishers' types and logger."""
    node = SimpleNamespace(
        resolve_topic_name=lambda topic: '/' + topic,
        get_publishers_info_by_topic=lambda name: [
            SimpleNamespace(topic_type=t) for t in PUBLISHED[name]],
    )
    return SimpleNamespace(settings=SimpleNamespace(scene_type=scene_type), node=node,
                           _due=lambda key: True,
                           _log=lambda: SimpleNamespace(warning=warnings.append))


def test_auto_reads_the_publishers_type_and_names_one_it_cannot_read():
    warnings = []
    answerer = _answerer('auto', warnings)
    kinds = {t: CloudAnswerer._scene_kind(answerer, t.strip('/')) for t in PUBLISHED}
    assert kinds == {'/images': 'depth_image', '/clouds': 'points', '/compressed': None,
                     '/silent': None}
    # only the topic whose publisher sends something else is worth a warning, naming both
    assert len(warnings) == 1
    assert '/compressed' in warnings[0] and 'sensor_msgs/msg/CompressedImage' in warnings[0]


def test_a_fixed_scene_type_is_taken_without_looking_at_publishers():
    warnings = []
    answerer = _answerer('points', warnings)
    assert CloudAnswerer._scene_kind(answerer, 'silent') == 'points'
    assert CloudAnswerer._scene_kind(answerer, 'compressed') == 'points'
    assert warnings == []
