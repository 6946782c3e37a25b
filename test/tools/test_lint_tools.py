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

"""The mechanical converters in tools/ change only what they should."""

import ast

from tools.license_header import with_header
from tools.single_quotes import convert, main

SOURCE = '''"""Module docstring stays."""
x = "plain"
y = f"{x!r} and {x}"
z = "it's"
w = "say \\"hi\\""
v = rb"raw\\\\d"
"string statement stays"


def f():
    """Docstring stays."""
    return ("a"
            "b")
'''


def test_single_quotes_change_plain_strings_only():
    out, count = convert(SOURCE)
    assert count == 5
    assert "x = 'plain'" in out and "y = f'{x!r} and {x}'" in out and "v = rb'raw" in out
    assert "return ('a'\n            'b')" in out
    assert 'z = "it' in out and 'w = "say' in out     # would need escaping: left
    assert '"""Module docstring stays."""' in out and '"""Docstring stays."""' in out
    assert '"string statement stays"' in out
    assert ast.dump(ast.parse(out)) == ast.dump(ast.parse(SOURCE))
    assert convert(out) == (out, 0)


def test_single_quotes_check_reports_and_changes_nothing(tmp_path):
    path = tmp_path / 'a.py'
    path.write_text(SOURCE)
    assert main(['--check', str(tmp_path)]) == 1 and path.read_text() == SOURCE
    assert main([str(tmp_path)]) == 0 and path.read_text() != SOURCE
    assert main(['--check', str(path)]) == 0


def test_license_header_goes_after_a_shebang_and_only_once():
    out = with_header('#!/usr/bin/env python3\n\n"""Doc."""\n', 2026)
    lines = out.splitlines()
    assert lines[0] == '#!/usr/bin/env python3' and lines[1] == '# Copyright 2026 The pcrp authors'
    assert '# limitations under the License.' in out and out.endswith('"""Doc."""\n')
    assert with_header(out, 2030) == out
    assert with_header('', 2026) == ''
