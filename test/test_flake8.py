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

import subprocess
import sys

from lint_scope import NOT_YET_LINTED, PACKAGE_ROOT
import pytest

# flake8 checks files in a pool of forked processes. Forked from this pytest process, which by
# now holds the native threads the ROS tests' DDS participants leave behind, a child crashed in
# CI and left the pool waiting for ever; a fresh interpreter forks with no such threads.
FLAKE8 = 'import sys; from ament_flake8.main import main; sys.exit(main())'


@pytest.mark.flake8
@pytest.mark.linter
def test_flake8():
    result = subprocess.run(
        [sys.executable, '-c', FLAKE8, '--exclude', *NOT_YET_LINTED],
        cwd=PACKAGE_ROOT, capture_output=True, text=True, timeout=600)
    assert result.returncode == 0, result.stdout + result.stderr
