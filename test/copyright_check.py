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
A stand-in for ament_copyright's main(), which has no wheel on the package index.

It checks what ament_copyright checks of a Python package: every .py file (folders starting
with . or _ skipped, as ament does) begins, after an optional shebang and blank lines, with a
copyright notice (`# Copyright YEAR[-YEAR] HOLDER`) followed by the Apache License 2.0 header
ament knows, and the package has a LICENSE file with the license's full text. It prints one
line per problem and returns 0 when there is none, as ament_copyright.main.main does.
"""

import os
import re
import sys

NOTICE = re.compile(r'^# Copyright( \(c\))? \d{4}(-\d{4})? \S.*$')
APACHE2 = """\
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
LICENSE_TITLE = 'Apache License\n                           Version 2.0, January 2004'


def problems_of(path: str) -> list:
    """List what is wrong with one file's header (nothing for an empty file)."""
    with open(path, encoding='utf-8') as f:
        lines = f.read().splitlines()
    if lines and lines[0].startswith('#!'):
        lines = lines[1:]
    while lines and not lines[0].strip():
        lines = lines[1:]
    if not lines:
        return []
    if not NOTICE.match(lines[0]):
        return [f'{path}: could not find copyright notice']
    header = '\n'.join(lines[1:1 + APACHE2.count('\n')]) + '\n'
    if header != APACHE2:
        return [f'{path}: could not find the Apache 2.0 license header after the notice']
    return []


def _files(paths, excludes):
    excludes = [os.path.abspath(e) for e in excludes]

    def excluded(p):
        p = os.path.abspath(p)
        return any(os.path.commonpath([p, e]) == e for e in excludes)
    for path in paths:
        if os.path.isfile(path):
            if not excluded(path):
                yield path
            continue
        for root, dirs, files in os.walk(path):
            dirs[:] = sorted(d for d in dirs if not d.startswith(('.', '_'))
                             and not excluded(os.path.join(root, d)))
            for name in sorted(files):
                if name.endswith('.py') and not excluded(os.path.join(root, name)):
                    yield os.path.join(root, name)


def main(argv=sys.argv[1:]):
    """Check the files below the paths given (default .), less those after --exclude."""
    argv = list(argv)
    excludes = []
    if '--exclude' in argv:
        at = argv.index('--exclude')
        argv, excludes = argv[:at], argv[at + 1:]
    paths = argv or [os.curdir]
    problems = []
    seen = set()
    for path in _files(paths, excludes):
        if os.path.abspath(path) not in seen:
            seen.add(os.path.abspath(path))
            problems += problems_of(path)
    try:
        with open('LICENSE', encoding='utf-8') as f:
            if LICENSE_TITLE not in f.read():
                problems.append('LICENSE: not the Apache License 2.0 text')
    except OSError:
        problems.append('LICENSE: missing')
    for line in problems:
        print(line, file=sys.stderr)
    print(f'{len(seen)} files checked')
    if problems:
        print(f'{len(problems)} errors')
        return 1
    print('No problems found')
    return 0
