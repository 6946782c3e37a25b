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
What the ament linters (test_flake8, test_pep257, test_copyright) leave out for now.

The linters check the whole package, as `colcon test` would: pcrp_core, pcrp_ros, launch,
setup.py, test and tools. The paths below are being rewritten and are not clean yet; remove
one from the list to lint it (relative to the package root, folders or files).
"""

import os

PACKAGE_ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

NOT_YET_LINTED = [
    'pcrp_core/build.py',
    'pcrp_core/category',
    'pcrp_core/config.py',
    'pcrp_core/evaluation',
    'pcrp_core/features',
    'pcrp_core/gallery.py',
    'pcrp_core/hypotheses.py',
    'pcrp_core/parallel.py',
    'pcrp_core/pipeline.py',
    'pcrp_core/registration',
    'pcrp_core/retrieval.py',
    'pcrp_core/symmetry.py',
    'tools/bench.py',
    'tools/paper_eval',
    'tools/robot_open3d.py',
    'tools/robot_report.py',
    'tools/robot_twins.py',
    'tools/robot_writer.py',
    'test/integration/test_pipeline.py',
    'test/tools/test_bench.py',
    'test/tools/test_evaluation.py',
    'test/tools/test_robot_eval.py',
    'test/unit/test_model_io.py',
    'test/unit/test_registration.py',
    'test/integration/test_category_confidence.py',
]
