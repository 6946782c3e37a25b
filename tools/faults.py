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
Broken model files, and what the node and the CLI do at start-up with each.

Each fault damages a copy of a good model directory the way a disk, a download or a person
might. Both programs must stop with one error line naming the file and the problem and a
non-zero exit, never a traceback. Shared by the test suite and `python -m tools robustness`.
"""
from __future__ import annotations

from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
import json
from pathlib import Path
import shutil
import subprocess
import sys
from typing import Callable

import numpy as np
from pcrp_core.model_io import _sha256, ARRAYS_FILE, META_FILE


def _edit_meta(path: Path, **changes) -> None:
    meta = json.loads((path / META_FILE).read_text())
    meta.update(changes)
    (path / META_FILE).write_text(json.dumps(meta))


def _flip_byte(path: Path) -> None:
    data = bytearray((path / ARRAYS_FILE).read_bytes())
    data[len(data) // 2] ^= 0xFF
    (path / ARRAYS_FILE).write_bytes(bytes(data))


def _pickled(path: Path) -> None:
    # a pickled object with a matching checksum: only the loader's refusal of pickle stops it
    with np.load(path / ARRAYS_FILE, allow_pickle=False) as f:
        arrays = dict(f)
    arrays['gallery_lengths'] = np.array([{'evil': 1}], dtype=object)
    np.savez(path / ARRAYS_FILE, **arrays)
    _edit_meta(path, arrays_sha256=_sha256(path / ARRAYS_FILE))


def _truncated_resummed(path: Path) -> None:
    # cut short and checksum updated (a half-finished copy by a tool that rewrote the metadata)
    p = path / ARRAYS_FILE
    p.write_bytes(p.read_bytes()[: p.stat().st_size // 2])
    _edit_meta(path, arrays_sha256=_sha256(p))


@dataclass(frozen=True)
class Fault:
    name: str
    what: str
    damage: Callable[[Path], Path]      # damages the copy in place, returns the path to hand over
    words: str                          # what the error line must say


def _in_place(f):
    def damage(p: Path) -> Path:
        f(p)
        return p
    return damage


FAULTS = [
    Fault('missing', 'model path does not exist', lambda p: p / 'nowhere', 'no such model'),
    Fault(
        'a_file',
        'model path is a file, not a model directory',
        lambda p: p / META_FILE,
        'not a file',
    ),
    Fault(
        'no_arrays',
        f'{ARRAYS_FILE} missing',
        _in_place(lambda p: (p / ARRAYS_FILE).unlink()),
        'missing',
    ),
    Fault(
        'truncated',
        f'{ARRAYS_FILE} cut to half',
        _in_place(lambda p: (p / ARRAYS_FILE).write_bytes((p / ARRAYS_FILE).read_bytes()[:1000])),
        'checksum',
    ),
    Fault(
        'truncated_resummed',
        f'{ARRAYS_FILE} cut to half, checksum rewritten',
        _in_place(_truncated_resummed),
        'unreadable arrays',
    ),
    Fault(
        'tampered_arrays', f'one byte of {ARRAYS_FILE} changed', _in_place(_flip_byte), 'checksum'
    ),
    Fault(
        'bad_json',
        f'{META_FILE} is not JSON',
        _in_place(lambda p: (p / META_FILE).write_text('{not json')),
        'unreadable model metadata',
    ),
    Fault(
        'newer_version',
        'format version 99 (from a newer pcrp)',
        _in_place(lambda p: _edit_meta(p, format_version=99)),
        'format version 99',
    ),
    Fault(
        'not_pcrp',
        'metadata of some other program',
        _in_place(lambda p: _edit_meta(p, format='something-else')),
        'not a pcrp model',
    ),
    Fault(
        'tampered_meta',
        'gallery IDs edited to disagree with the arrays',
        _in_place(lambda p: _edit_meta(p, gallery_ids=['only_one'])),
        'incomplete or inconsistent',
    ),
    Fault(
        'pickle',
        'a pickled object in the arrays, checksum valid',
        _in_place(_pickled),
        'unreadable arrays',
    ),
]


@dataclass
class StartUp:
    fault: str
    program: str          # node / cli
    returncode: int
    stderr: str

    def error_lines(self) -> list[str]:
        """
        Return our lines on stderr.

        rcl's own warnings about the environment (e.g. a deprecated variable) are not the program's
        to answer for.
        """
        return [
            line for line in self.stderr.splitlines() if line.strip() and '] [rcl]:' not in line
        ]


def damaged_copy(fault: Fault, model_dir: Path, work: Path) -> Path:
    dst = work / fault.name
    shutil.rmtree(dst, ignore_errors=True)
    shutil.copytree(model_dir, dst)
    return fault.damage(dst)


def start(
    program: str, model_path: Path, cloud_file: Path, timeout: float = 60.0
) -> subprocess.CompletedProcess:
    """Start the node or run a CLI query on the given model, as a user would."""
    if program == 'node':
        cmd = [
            sys.executable,
            '-m',
            'pcrp_ros.node',
            '--ros-args',
            '-p',
            f'model_path:={model_path}',
        ]
    else:
        cmd = [sys.executable, '-m', 'pcrp_ros.cli', 'query', str(model_path), str(cloud_file)]
    return subprocess.run(cmd, capture_output=True, text=True, timeout=timeout)


PROGRAMS = ('node', 'cli')


def try_fault(fault: Fault, model_dir: Path, work: Path, cloud_file: Path) -> list[StartUp]:
    """
    Start the node and run the CLI on one damaged copy of the model, as PROGRAMS.

    Both at once: each spends seconds importing before it reads the model, and neither writes it.
    """
    path = damaged_copy(fault, model_dir, work)
    with ThreadPoolExecutor(len(PROGRAMS)) as pool:
        outs = list(pool.map(lambda program: start(program, path, cloud_file), PROGRAMS))
    return [StartUp(fault.name, p, o.returncode, o.stderr) for p, o in zip(PROGRAMS, outs)]


def handled(fault: Fault, result: StartUp, path_shown: str) -> bool:
    """One error line that names the file and the problem, a non-zero exit, no traceback."""
    lines = result.error_lines()
    return (result.returncode != 0 and len(lines) == 1 and fault.words in lines[0]
            and path_shown in lines[0] and 'Traceback' not in result.stderr)
