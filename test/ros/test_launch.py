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
The launch files describe what they should, run against stand-ins of launch and launch_ros.

The launch packages have no wheels on the package index, so each launch file is run here with
modules of the same names whose classes only record how they were made: what is checked is
the description a launch file builds (the executables, names, parameters, the autostart
wiring), not launch itself.
"""

import importlib.util
from pathlib import Path
import re
import sys
import types

import pytest

REPO = Path(__file__).resolve().parents[2]
STUBBED = ['ament_index_python', 'ament_index_python.packages', 'launch', 'launch.actions',
           'launch.conditions', 'launch.events', 'launch.substitutions', 'launch_ros',
           'launch_ros.actions', 'launch_ros.event_handlers', 'launch_ros.events',
           'launch_ros.events.lifecycle']


class Made:
    """What a stand-in class was called with."""

    def __init__(self, *args, **kwargs):
        self.args, self.kwargs = args, kwargs

    def __repr__(self):
        return f'{type(self).__name__}({self.args}, {self.kwargs})'


class Stub(types.ModuleType):
    def __getattr__(self, name):
        if name.startswith('__'):
            raise AttributeError(name)
        if name == 'get_package_share_directory':
            return lambda package: f'/share/{package}'
        if name == 'matches_action':
            return lambda action: ('matches', action)
        made = type(name, (Made,), {})
        setattr(self, name, made)
        return made


@pytest.fixture
def launch_stubs(monkeypatch):
    for name in STUBBED:
        monkeypatch.setitem(sys.modules, name, Stub(name))


def _describe(name):
    spec = importlib.util.spec_from_file_location(name, REPO / 'launch' / name)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module.generate_launch_description().args[0]


def _console_scripts():
    return set(re.findall(r"'(\w+) = pcrp_ros\.", (REPO / 'setup.py').read_text()))


class Context:
    def __init__(self, **values):
        self.values = values


def _perform(self, context):
    return context.values[self.args[0]]


def test_the_plain_launch_starts_pcrp_node_with_the_shipped_config(launch_stubs):
    actions = _describe('pcrp.launch.py')
    node = next(a for a in actions if type(a).__name__ == 'Node')
    assert node.kwargs['package'] == 'pcrp' and node.kwargs['executable'] in _console_scripts()
    assert node.kwargs['executable'] == 'pcrp_node'
    default = next(a for a in actions if type(a).__name__ == 'DeclareLaunchArgument')
    assert default.kwargs['default_value'] == '/share/pcrp/config/pcrp.yaml'


def test_the_lifecycle_launch_configures_then_activates_only_after_configuring(launch_stubs):
    from lifecycle_msgs.msg import Transition
    actions = _describe('pcrp_lifecycle.launch.py')
    kinds = {type(a).__name__: a for a in actions}
    node = kinds['LifecycleNode']
    assert node.kwargs['executable'] == 'pcrp_lifecycle_node' in _console_scripts()
    assert node.kwargs['name'] == 'pcrp_node' and 'namespace' in node.kwargs
    configure = kinds['EmitEvent']
    assert configure.kwargs['event'].kwargs['transition_id'] == Transition.TRANSITION_CONFIGURE
    assert configure.kwargs['event'].kwargs['lifecycle_node_matcher'] == ('matches', node)
    handler = kinds['RegisterEventHandler'].args[0]
    assert handler.kwargs['target_lifecycle_node'] is node
    assert (handler.kwargs['start_state'], handler.kwargs['goal_state']) == (
        'configuring', 'inactive')
    (activate,) = handler.kwargs['entities']
    assert activate.kwargs['event'].kwargs['transition_id'] == Transition.TRANSITION_ACTIVATE
    # both depend on the autostart argument, which defaults to true
    autostart = configure.kwargs['condition']
    assert kinds['RegisterEventHandler'].kwargs['condition'] is autostart
    assert autostart.args[0].args[0] == 'autostart'
    declared = {a.args[0]: a.kwargs.get('default_value') for a in actions
                if type(a).__name__ == 'DeclareLaunchArgument'}
    assert declared['autostart'] == 'true' and declared['namespace'] == ''


def test_the_scaled_launch_shares_the_topics_round_robin(launch_stubs):
    actions = _describe('pcrp_scaled.launch.py')
    (opaque,) = [a for a in actions if type(a).__name__ == 'OpaqueFunction']
    sys.modules['launch.substitutions'].LaunchConfiguration.perform = _perform
    context = Context(topics='a, b,c,d,e', processes='2', params_file='/p.yaml')
    nodes = opaque.kwargs['function'](context)
    assert [n.kwargs['name'] for n in nodes] == ['pcrp_node_0', 'pcrp_node_1']
    assert [n.kwargs['parameters'][1]['input_topics'] for n in nodes] == [
        ['a', 'c', 'e'], ['b', 'd']]
    assert all(n.kwargs['executable'] in _console_scripts() for n in nodes)
    # never more processes than topics
    nodes = opaque.kwargs['function'](Context(topics='a', processes='4', params_file='/p.yaml'))
    assert len(nodes) == 1
