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
Every setting is defined once (pcrp_core.config, pcrp_ros.parameters).

What repeats it is held against the definition here: the committed params file, the README's
table, the node's descriptors.
"""
from pathlib import Path

import numpy as np
from pcrp_core import PCRP
from pcrp_core.config import PAPER_POSE, PoseOptions, QueryOptions
from pcrp_ros.parameters import descriptor, markdown_table, NodeSettings, parameters, params_file
import pytest

REPO = Path(__file__).resolve().parents[2]


def test_the_committed_params_file_is_the_one_the_settings_make():
    assert (REPO / 'config' / 'pcrp.yaml').read_text() == params_file(), \
        'regenerate it: python -m pcrp_ros.parameters yaml > config/pcrp.yaml'


def test_the_readme_or_the_node_docs_carry_the_parameter_table_as_the_settings_make_it():
    docs = [REPO / 'README.md', *sorted((REPO / 'docs').glob('*.md'))]
    assert any(
        markdown_table() in p.read_text() for p in docs
    ), 'paste `python -m pcrp_ros.parameters` into the docs'


def test_every_parameter_has_a_descriptor_with_its_bounds():
    by_name = {spec['name']: descriptor(spec) for spec in parameters()}
    assert len(by_name) == len(parameters())          # no name declared twice
    assert by_name['n_candidates'].integer_range[0].from_value == 1
    assert by_name['up_tolerance_deg'].floating_point_range[0].to_value == 180.0
    # unbounded above: infinity (never look again) must pass ROS's range check
    assert by_name['local_shape_cost'].floating_point_range[0].to_value == float('inf')
    assert by_name['workers'].read_only and not by_name['min_confidence'].read_only
    assert not by_name['model_path'].read_only   # set while running: the model is switched


@pytest.mark.parametrize('options, change, message', [
    (QueryOptions, {'n_candidates': 0}, r'n_candidates: 0 is outside \[1, 50\]'),
    (QueryOptions, {'scale_mode': 'huge'}, 'expected one of metric, normalize'),
    (QueryOptions, {'n_candidates': 2.5}, 'expected an integer'),
    (PoseOptions, {'icp_trim': 0.0}, r'outside \(0.0, 1.0\]'),
    (NodeSettings, {'up_vector': [0.0, 'up', 1.0]}, 'expected a list of float'),
    (NodeSettings, {'qos_reliability': 'sometimes'}, 'best_effort, reliable'),
])
def test_a_bad_value_is_refused_with_what_is_expected(options, change, message):
    with pytest.raises(ValueError, match=message):
        options(**change)


def test_numpy_scalars_are_the_numbers_they_are_and_a_wrong_name_hears_every_name():
    """np.int64 was 'expected an integer'; a mistyped name heard only the query settings."""
    model = PCRP.load(None)
    model.set_params(yaw_steps=np.int64(24), min_confidence=np.float32(0.25), refine=np.bool_(0))
    assert model.instance_options.yaw_steps == 24 and type(model.instance_options.yaw_steps) is int
    assert model.options.min_confidence == pytest.approx(0.25) and not model.pose_options.refine
    with pytest.raises(ValueError, match='expected an integer'):
        model.set_params(yaw_steps=np.float64(2.5))
    with pytest.raises(ValueError, match='unknown setting yaw_stepz') as said:
        model.set_params(yaw_stepz=3)
    for name in ('n_candidates', 'local_shape_cost', 'refine', 'up_tolerance_deg', 'yaw_steps'):
        assert name in str(said.value)


def test_replace_checks_again_and_leaves_the_original_alone():
    base = PoseOptions()
    assert base.replace(refine=False).refine is False and base.refine is True
    with pytest.raises(ValueError, match='unknown setting'):
        base.replace(refinement=False)
    assert not PAPER_POSE.refine and not PAPER_POSE.consensus and PAPER_POSE.seeders == 1
