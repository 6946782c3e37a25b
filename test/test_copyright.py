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

try:
    from ament_copyright.main import main
except ImportError:   # no wheel on the package index: the same checks, see copyright_check.py
    from copyright_check import main
from lint_scope import NOT_YET_LINTED, PACKAGE_ROOT
import pytest


@pytest.mark.copyright
@pytest.mark.linter
def test_copyright(monkeypatch):
    monkeypatch.chdir(PACKAGE_ROOT)
    rc = main(argv=['.', 'test', '--exclude', *NOT_YET_LINTED])
    assert rc == 0, 'Found errors'


def test_the_check_finds_a_missing_or_altered_header(tmp_path, monkeypatch):
    from copyright_check import main as check
    monkeypatch.chdir(tmp_path)
    (tmp_path / 'LICENSE').write_text(open(f'{PACKAGE_ROOT}/LICENSE').read())
    good = open(__file__).read()
    (tmp_path / 'good.py').write_text(good)
    assert check(argv=['.']) == 0
    (tmp_path / 'no_notice.py').write_text('"""A module."""\n')
    assert check(argv=['.']) == 1
    assert check(argv=['.', '--exclude', 'no_notice.py']) == 0
    (tmp_path / 'altered.py').write_text(good.replace('WITHOUT WARRANTIES', 'WITH WARRANTIES'))
    assert check(argv=['.', '--exclude', 'no_notice.py']) == 1
    (tmp_path / 'LICENSE').write_text('MIT License\n')
    assert check(argv=['good.py']) == 1
