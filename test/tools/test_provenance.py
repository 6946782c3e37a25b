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

"""The code key names what the package's files hold, not whether they are committed."""

import subprocess

import pytest
from tools import provenance


def _git(repo, *args):
    subprocess.run(['git', '-c', 'user.name=t', '-c', 'user.email=t@t', *args], cwd=repo,
                   check=True, capture_output=True)


@pytest.fixture
def checkout(tmp_path, monkeypatch):
    (tmp_path / 'pcrp_core' / 'evaluation').mkdir(parents=True)
    (tmp_path / 'pcrp_core' / 'matcher.py').write_text('A = 1\n')
    (tmp_path / 'pcrp_core' / 'evaluation' / 'run.py').write_text('REPORT = 1\n')
    _git(tmp_path, 'init', '-q')
    monkeypatch.setattr(provenance, 'REPO', tmp_path)
    return tmp_path


def test_the_same_files_have_one_key_committed_or_not(checkout):
    untracked = provenance.code_key()
    _git(checkout, 'add', '-A')
    staged = provenance.code_key()
    _git(checkout, 'commit', '-q', '-m', 'x')
    assert untracked == staged == provenance.code_key()


def test_a_change_to_model_code_changes_the_key_and_to_a_report_does_not(checkout):
    _git(checkout, 'add', '-A')
    _git(checkout, 'commit', '-q', '-m', 'x')
    before = provenance.code_key()
    (checkout / 'pcrp_core' / 'evaluation' / 'run.py').write_text('REPORT = 2\n')
    assert provenance.code_key() == before
    # nor does a rebuilt shipped model: what a build makes, not what makes one
    (checkout / 'pcrp_core' / 'data').mkdir()
    (checkout / 'pcrp_core' / 'data' / 'model.json').write_text('{}\n')
    assert provenance.code_key() == before
    (checkout / 'pcrp_core' / 'matcher.py').write_text('A = 2\n')
    changed = provenance.code_key()
    assert changed != before
    (checkout / 'pcrp_core' / 'matcher.py').unlink()
    assert provenance.code_key() not in (before, changed)


def test_a_model_is_built_once_and_its_cost_read_back_until_its_record_is_gone(tmp_path):
    path, builds = tmp_path / 'model', []

    def build():
        path.mkdir(exist_ok=True)
        (path / 'model.json').write_text('{}')
        builds.append(1)
        return {'objects': 3}

    first = provenance.built_once(path, build)
    assert first['objects'] == 3 and first['seconds'] >= 0.0
    assert provenance.built_once(path, build) == first and len(builds) == 1
    (tmp_path / 'model_build.json').unlink()     # a model without its record is built again
    provenance.built_once(path, build)
    assert len(builds) == 2
