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
Put the Apache-2.0 notice that test_copyright.py wants at the top of .py files lacking one.

A file that already starts with a copyright notice, or is empty, is left alone; a shebang
stays first. Usage:

    python -m tools.license_header [--check] PATH...

PATHs are files or folders (every .py file below them, folders starting with . or _ skipped).
--check changes nothing and exits 1 when some file lacks the notice.
"""

import argparse
import sys
import time

from tools.source_files import python_files

HEADER = """\
# Copyright {year} The pcrp authors
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


def with_header(source: str, year: int) -> str:
    """Return the source with the notice on top (the source itself if it has one)."""
    lines = source.splitlines(keepends=True)
    shebang = lines[:1] if lines and lines[0].startswith('#!') else []
    rest = ''.join(lines[len(shebang):])
    if not rest.strip() or rest.lstrip().startswith('# Copyright'):
        return source
    return ''.join(shebang) + HEADER.format(year=year) + rest.lstrip('\n')


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.strip().split('\n')[0])
    parser.add_argument('paths', nargs='+')
    parser.add_argument('--check', action='store_true', help='report only; exit 1 if any')
    args = parser.parse_args(argv)
    year = time.gmtime().tm_year
    missing = 0
    for path in python_files(args.paths):
        source = path.read_text()
        new = with_header(source, year)
        if new == source:
            continue
        missing += 1
        if args.check:
            print(f'{path}: no copyright notice')
        else:
            path.write_text(new)
            print(f'{path}: notice added')
    return 1 if args.check and missing else 0


if __name__ == '__main__':
    sys.exit(main())
