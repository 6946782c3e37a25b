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
What produced a result: the machine it ran on, and the code that built the model it used.

Every report records the first; the model caches of the benchmark and the robot report are keyed
by the second, so a model built by older code is built again rather than timed or scored.
"""
from __future__ import annotations

import hashlib
from importlib import metadata
import json
import os
from pathlib import Path
import platform
import subprocess
import time

REPO = Path(__file__).resolve().parents[1]
# report-only modules: a change to them does not change a model, so does not rebuild one
NOT_BUILD_CODE = ('pcrp_core/evaluation/run.py', 'pcrp_core/evaluation/metrics.py')
VERSIONS_OF = ('numpy', 'scipy', 'scikit-learn', 'open3d', 'ros-jazzy-rclpy', 'rosbags', 'pcrp')


def machine() -> dict:
    """Return the cores, CPU, memory, versions and load the figures were measured with."""
    cpu = ''
    try:
        cpu = next(
            line.split(':', 1)[1].strip()
            for line in Path('/proc/cpuinfo').read_text().splitlines()
            if line.startswith('model name')
        )
    except (OSError, StopIteration):
        pass
    versions = {}
    for dist in VERSIONS_OF:
        try:
            versions[dist] = metadata.version(dist)
        except metadata.PackageNotFoundError:
            versions[dist] = '-'
    return {
        'cores': len(os.sched_getaffinity(0)),
        'cpu': cpu or platform.processor(),
        'python': platform.python_version(),
        'memory_gb': round(os.sysconf('SC_PAGE_SIZE') * os.sysconf('SC_PHYS_PAGES') / 2**30, 1),
        'versions': versions,
        'date': time.strftime('%Y-%m-%d %H:%M'),
        'load_start': round(os.getloadavg()[0], 1),
    }


def _git(*args) -> str:
    done = subprocess.run(['git', *args], capture_output=True, text=True, cwd=REPO)
    if done.returncode != 0:
        raise RuntimeError(done.stderr)
    return done.stdout


def code_key() -> str:
    """
    Return a name for the code that builds a model.

    The content of the package's source files (committed or not, less the report-only modules),
    so the same code has the same name before and after it is committed. A model cached under
    another key was built by other code, so is built again. The shipped model (pcrp_core/data) is
    what a build makes, not what makes one: rebuilding it renames no cached model.
    """
    try:
        names = _git('ls-files', '--cached', '--others', '--exclude-standard', '--', 'pcrp_core')
    except (OSError, RuntimeError):    # not a checkout: the installed version names the code
        return 'pcrp-' + metadata.version('pcrp')
    digest = hashlib.sha1()
    sources = {n for n in names.splitlines() if n.endswith('.py')}
    for name in sorted(sources - set(NOT_BUILD_CODE)):
        path = REPO / name
        if path.is_file():   # a file deleted but not yet committed is listed too
            digest.update(name.encode() + b'\0' + path.read_bytes() + b'\0')
    return digest.hexdigest()[:12]


def built_once(path: Path, build) -> dict:
    """
    Return the record of what building the model at path cost: {'seconds': ..., **build()}.

    build() makes the model at path (and may return more to record) when the model or its record
    (kept beside it, `<name>_build.json`) is missing, so a cached model still reports its cost.
    """
    record = path.parent / f'{path.name}_build.json'
    if not (path / 'model.json').exists() or not record.exists():
        t0 = time.perf_counter()
        more = build() or {}
        record.write_text(json.dumps({'seconds': time.perf_counter() - t0, **more}))
    return json.loads(record.read_text())
