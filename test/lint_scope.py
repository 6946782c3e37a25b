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

NOT_YET_LINTED = []
