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
Turn "double-quoted" strings into 'single-quoted' ones, as ament's flake8 wants (Q000).

Only strings whose text holds no quote character of either kind are changed, so no escaping
changes; triple-quoted strings (docstrings) and strings standing alone as a statement are left
as they are, and nothing is rewrapped or moved (from Python 3.12 on, f-strings are tokenized in
parts and left alone). Each file's syntax tree is compared before and after, and a file whose
tree would change is left untouched. Usage:

    python -m tools.single_quotes [--check] PATH...

PATHs are files or folders (every .py file below them). --check changes nothing and exits 1
when some string would change.
"""

import argparse
import ast
import io
import sys
import tokenize

from tools.source_files import python_files

PREFIX_CHARS = set('rRbBuUfF')
STATEMENT_START = {tokenize.NEWLINE, tokenize.NL, tokenize.INDENT, tokenize.DEDENT,
                   tokenize.ENCODING}


def _convertible(text: str) -> int:
    """Offset of the opening quote when the string token can change, else -1."""
    i = 0
    while i < len(text) and text[i] in PREFIX_CHARS:
        i += 1
    body = text[i:]
    if not body.startswith('"') or body.startswith('"""') or len(body) < 2:
        return -1
    inner = body[1:-1]
    if "'" in inner or '"' in inner:
        return -1
    return i


def convert(source: str) -> tuple[str, int]:
    """Return (converted source, strings changed)."""
    lines = source.splitlines(keepends=True)
    tokens = list(tokenize.generate_tokens(io.StringIO(source).readline))
    edits = []
    for n, tok in enumerate(tokens):
        if tok.type != tokenize.STRING:
            continue
        before = next((t for t in reversed(tokens[:n]) if t.type != tokenize.COMMENT), None)
        after = next((t for t in tokens[n + 1:] if t.type != tokenize.COMMENT), None)
        alone = ((before is None or before.type in STATEMENT_START)
                 and (after is None or after.type in (tokenize.NEWLINE, tokenize.ENDMARKER)))
        if alone:   # a docstring, or a string statement: left as written
            continue
        offset = _convertible(tok.string)
        if offset < 0:
            continue
        edits.append((tok.start, tok.end, offset))
    chars = [list(line) for line in lines]
    for (srow, scol), (erow, ecol), offset in edits:
        chars[srow - 1][scol + offset] = "'"
        chars[erow - 1][ecol - 1] = "'"
    return ''.join(''.join(c) for c in chars), len(edits)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    parser.add_argument('paths', nargs='+')
    parser.add_argument('--check', action='store_true', help='report only; exit 1 if any')
    args = parser.parse_args(argv)
    pending = 0
    for path in python_files(args.paths):
        source = path.read_text()
        converted, count = convert(source)
        if not count:
            continue
        if ast.dump(ast.parse(source)) != ast.dump(ast.parse(converted)):
            print(f'{path}: left alone, its syntax tree would change', file=sys.stderr)
            continue
        pending += count
        if args.check:
            print(f'{path}: {count} strings to change')
        else:
            path.write_text(converted)
            print(f'{path}: {count} strings changed')
    return 1 if args.check and pending else 0


if __name__ == '__main__':
    sys.exit(main())
