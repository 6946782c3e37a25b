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
The node's parameters, each defined once.

Its own settings are here, the model's in pcrp_core.config.

Every parameter is declared with a descriptor made from its setting (description, range, read
only), so `ros2 param describe` shows the same text and bounds as the table in docs/node.md and
config/pcrp.yaml, which a test holds against these declarations.
"""

from __future__ import annotations

from dataclasses import dataclass
import difflib
import math

from pcrp_core.config import Options, setting, user_settings


@dataclass(frozen=True)
class NodeSettings(Options):
    """What the node itself does, beside the model's settings."""

    model_path: str = setting(
        '', 'Model directory built by `pcrp build`; empty for the shipped default model. Set '
        'while running, the new model is loaded beside the old one, which answers until they '
        'are swapped; one that fails to load is refused (logged, in /diagnostics) and the old '
        'one kept.')
    input_topics: tuple = setting(
        ('segmented_object',), 'PointCloud2 topics of segmented objects, one object per '
        'message.', read_only=True)
    scene_topics: tuple = setting(
        (), "Topics of the camera's whole depth frame (e.g. /camera/depth/points; see "
        'scene_type): one shared by every input topic, or one per entry of input_topics, in '
        'order; empty: none. Each cloud is answered with the depth frame of its own stamp and '
        'frame, so surface of the object that something in front of it hid is not counted '
        'missing.', read_only=True)
    scene_type: str = setting(
        'auto', 'What scene_topics carry: points (PointCloud2 depth clouds), depth_image '
        '(sensor_msgs/Image, rectified, 16UC1 millimetres or 32FC1 metres, with its CameraInfo on '
        'the camera_info topic beside it, as image_transport pairs them: e.g. '
        '/camera/depth/image_rect_raw and /camera/depth/camera_info), or auto: whichever of the '
        "two each topic's publishers send (the topic is subscribed once a publisher is seen).",
        choices=('auto', 'points', 'depth_image'), read_only=True)
    publish_aligned_model: bool = setting(
        True, "Publish T/aligned_model, the gallery object moved into the cloud's frame.")
    sensor_at_origin: bool = setting(
        True, "The cloud's frame is the sensor's own (one-sided views seen from its origin); "
        'false for complete objects or clouds in a world frame.')
    up_vector: tuple = setting(
        (0.0, 0.0, 0.0), "Up (against gravity) in the input clouds' frame, if fixed and known: "
        "[0.0, -1.0, 0.0] for a level camera's optical frame; zeros: unknown. Needs a model "
        'that records its up axis; a tilting camera keeps it current.')
    qos_reliability: str = setting(
        'best_effort', 'Input QoS reliability: best_effort (sensor data) or reliable.',
        choices=('best_effort', 'reliable'), read_only=True)
    qos_depth: int = setting(
        5, 'Input QoS queue depth (5, as ROS sensor data).', low=1, high=100, read_only=True)
    log_throttle_sec: float = setting(
        5.0, 'Least seconds between two log lines of one kind.', low=0.0, high=3600.0)
    queue_size: int = setting(
        2, 'Clouds of one topic that may wait to be answered; when one more arrives the oldest is '
        'dropped (counted as dropped_stale). 1: only the newest waits.', low=1, high=100)
    workers: int = setting(
        1, 'Clouds answered at once. 1: in a thread of the node; more: that many worker '
        'processes, each with its own copy of the model (about one per core).',
        low=1, high=64, read_only=True)

    def __post_init__(self):
        super().__post_init__()
        inputs, scenes = len(self.input_topics), len(self.scene_topics)
        if scenes not in (0, 1, inputs):
            raise ValueError(
                f'scene_topics: expected one topic shared by every input topic or one per input '
                f'topic ({inputs}, in the order of input_topics), got {scenes}: '
                f'{list(self.scene_topics)}')

    def scene_topic_of(self) -> dict:
        """Map each input topic to the scene topic its clouds are answered with (if any)."""
        scenes = self.scene_topics
        if len(scenes) == 1:   # one camera's depth cloud, shared by every input topic
            scenes *= len(self.input_topics)
        return dict(zip(self.input_topics, scenes))


MODEL_SETTINGS = tuple(d['name'] for d in user_settings())


def parameters() -> list[dict]:
    """
    List every parameter the node declares, as Options.describe() gives them.

    The node's own, then the model's (which a parameter update passes to the model).
    """
    return NodeSettings.describe() + user_settings()


def unknown_overrides(node) -> list[str]:
    """
    Name the parameters the node was given and does not have, each with the nearest it has.

    rclpy keeps what the command line and params files give a node (its _parameter_overrides)
    and ignores, without a word, every name the node never declares: a misspelt min_confidence
    left the default in force.
    """
    given = getattr(node, '_parameter_overrides', {})
    known = [spec['name'] for spec in parameters()]
    said = []
    for name in sorted(n for n in given if not node.has_parameter(n)):
        near = difflib.get_close_matches(name, known, n=1)
        said.append(f'{name} (did you mean {near[0]}?)' if near else name)
    return said


def ros_value(value):
    """Turn a setting's default into a ROS parameter value (tuples become lists)."""
    return list(value) if isinstance(value, tuple) else value


def descriptor(spec: dict):
    """Make the ParameterDescriptor of one parameter: its doc, bounds, whether read only."""
    from rcl_interfaces.msg import FloatingPointRange, IntegerRange, ParameterDescriptor

    text = spec['doc'] + (f" One of: {', '.join(spec['choices'])}." if spec.get('choices') else '')
    d = ParameterDescriptor(
        name=spec['name'], description=text, read_only=bool(spec.get('read_only'))
    )
    if spec['default'] == ():
        # rclpy types an empty list default as a byte array, and a `[]` in a params file or on
        # the command line sets nothing, so a statically typed empty list of strings would refuse
        # every list of topics given: NodeSettings checks the type instead
        d.dynamic_typing = True
    default, low, high = spec['default'], spec.get('low'), spec.get('high')
    if low is None and high is None or isinstance(default, (bool, str, tuple)):
        return d
    if isinstance(default, int):
        d.integer_range = [
            IntegerRange(
                from_value=int(low if low is not None else -(2**63)),
                to_value=int(high if high is not None else 2**63 - 1),
                step=1,
            )
        ]
    else:
        # unbounded sides are infinite, so that a setting whose infinity means "never" takes it
        d.floating_point_range = [
            FloatingPointRange(
                from_value=float(low if low is not None else -math.inf),
                to_value=float(high if high is not None else math.inf),
                step=0.0,
            )
        ]
    return d


def _yaml(value) -> str:
    value = ros_value(value)
    if isinstance(value, bool):
        return 'true' if value else 'false'
    if isinstance(value, str):
        return f'"{value}"'
    if isinstance(value, list):
        return '[' + ', '.join(_yaml(v) for v in value) + ']'
    return repr(value)


def params_file() -> str:
    """Make config/pcrp.yaml as committed: every parameter at its default, its doc beside it."""
    lines = [
        '# pcrp_node parameters, at their defaults '
        '(regenerate: python -m pcrp_ros.parameters yaml)',
        '# ros2 run pcrp pcrp_node --ros-args --params-file config/pcrp.yaml',
        '/**:   # any node name, so renamed and scaled-out instances (-r __node:=...) read it too',
        '  ros__parameters:',
    ]
    for spec in parameters():
        lines.append(f"    # {spec['doc']}" + (' (read only)' if spec.get('read_only') else ''))
        lines.append(f"    {spec['name']}: {_yaml(spec['default'])}")
    return '\n'.join(lines) + '\n'


def markdown_table() -> str:
    """Make the parameter table of docs/node.md."""
    from pcrp_core.config import bounds_text

    rows = ['| parameter | default | range | what it does |', '|---|---|---|---|']
    for spec in parameters():
        ro = ' Read only.' if spec.get('read_only') else ''
        rows.append(f"| `{spec['name']}` | `{_yaml(spec['default'])}` | {bounds_text(spec)} "
                    f"| {spec['doc']}{ro} |")
    return '\n'.join(rows) + '\n'


if __name__ == '__main__':
    import sys

    print(params_file() if sys.argv[1:] == ['yaml'] else markdown_table(), end='')
