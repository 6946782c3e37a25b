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

"""The .py files the house-style tools (license_header.py, single_quotes.py) go through."""

from pathlib import Path


def python_files(paths):
    """
    Yield the files among paths, and every .py file below the folders among them.

    Folders starting with . or _ are skipped, as ament's linters skip them.
    """
    for p in map(Path, paths):
        if p.is_dir():
            yield from sorted(q for q in p.rglob('*.py')
                              if not any(part.startswith(('.', '_'))
                                         for part in q.relative_to(p).parts[:-1]))
        else:
            yield p
