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
What the package declares, held against what its code imports; and a real `pip install .`.

package.xml must name every ROS package and system dependency that the installed code and
the launch files import (rosdep installs from it), and setup.py's install_requires every
Python one (pip installs from it).
"""

import ast
import os
from pathlib import Path
import re
import shutil
import subprocess
import sys
import venv
from xml.etree import ElementTree

import pytest

REPO = Path(__file__).resolve().parents[2]
# Python modules -> (rosdep key, PyPI distribution)
PYTHON_DEPENDENCIES = {
    'numpy': ('python3-numpy', 'numpy'),
    'scipy': ('python3-scipy', 'scipy'),
    'sklearn': ('python3-sklearn', 'scikit-learn'),
    'joblib': ('python3-joblib', 'joblib'),
    'threadpoolctl': ('python3-threadpoolctl', 'threadpoolctl'),
    'tqdm': ('python3-tqdm', 'tqdm'),
    'open3d': ('python3-open3d-pip', 'open3d'),
    'rosbags': ('python3-rosbags-pip', 'rosbags'),
}
# imported by a ROS module the code imports rather than by name
IMPLIED = {'rclpy.lifecycle': 'lifecycle_msgs'}


def _imports(paths) -> set:
    found = set()
    for path in paths:
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found.update(a.name for a in node.names)
            elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
                found.add(node.module)
    return found


def _installed_code():
    return [*REPO.glob('pcrp_core/**/*.py'), *REPO.glob('pcrp_ros/**/*.py'),
            *REPO.glob('launch/*.py')]


def _depends(kind: str) -> set:
    root = ElementTree.parse(REPO / 'package.xml').getroot()
    return {e.text for e in root.findall(kind)}


def test_package_xml_declares_every_ros_and_system_dependency_imported():
    imports = _imports(_installed_code())
    tops = {name.split('.')[0] for name in imports}
    local = {'pcrp_core', 'pcrp_ros'}
    third_party = tops - local - set(sys.stdlib_module_names)
    needed = {PYTHON_DEPENDENCIES[t][0] if t in PYTHON_DEPENDENCIES else t for t in third_party}
    needed |= {key for module, key in IMPLIED.items() if module in imports}
    assert needed - _depends('exec_depend') == set()
    # and nothing declared for the code that it does not use
    assert _depends('exec_depend') - needed == set()


def test_setup_requires_every_python_dependency_with_a_lower_bound():
    text = (REPO / 'setup.py').read_text()
    block = text[text.index('install_requires=['):]
    block = block[:block.index(']')]
    required = dict(re.findall(r"'([A-Za-z0-9_.-]+)>=([0-9.]+)'", block))
    tops = {name.split('.')[0] for name in _imports(_installed_code())}
    wanted = {PYTHON_DEPENDENCIES[t][1] for t in tops if t in PYTHON_DEPENDENCIES}
    assert wanted == set(required), 'every Python dependency, each with a lower bound'


def test_the_license_file_is_the_license_package_xml_names():
    root = ElementTree.parse(REPO / 'package.xml').getroot()
    assert root.findtext('license') == 'Apache-2.0'
    text = (REPO / 'LICENSE').read_text()
    assert 'Apache License' in text and 'Version 2.0, January 2004' in text
    assert 'END OF TERMS AND CONDITIONS' in text
    maintainer = root.find('maintainer')
    assert maintainer.text.strip() and '@' in maintainer.get('email')
    assert 'pcrp@example.com' not in maintainer.get('email')


@pytest.mark.slow
def test_pip_install_gives_a_working_pcrp_without_setup_warnings(tmp_path):
    """Install into a fresh venv (dependencies from this one) and run the commands."""
    env_dir = tmp_path / 'venv'
    venv.create(env_dir, with_pip=True)
    python = env_dir / 'bin' / 'python'
    site = subprocess.run([python, '-c', 'import sysconfig; print(sysconfig.get_path("purelib"))'],
                          capture_output=True, text=True, check=True).stdout.strip()
    # this venv's packages (numpy, rclpy...) are seen after the new venv's own: --no-deps
    # installs pcrp alone, quickly, and nothing of the checkout is importable from there
    here = [p for p in sys.path if p.endswith('site-packages')]
    Path(site, 'parent_venv.pth').write_text('\n'.join(here) + '\n')
    env = {k: v for k, v in os.environ.items() if k != 'PYTHONPATH'}
    # from a copy: pip builds in the source tree, and build/ would land in the checkout
    source = shutil.copytree(REPO, tmp_path / 'source', ignore=shutil.ignore_patterns(
        '.*', 'build', '*.egg-info', '__pycache__', 'docs', 'test', 'tools'))
    out = subprocess.run([python, '-m', 'pip', 'install', '-v', '--no-deps', str(source)],
                         capture_output=True, text=True, env=env, timeout=600, cwd=tmp_path)
    assert out.returncode == 0, out.stdout[-3000:] + out.stderr[-3000:]
    warnings = [line for line in (out.stdout + out.stderr).splitlines()
                if re.search(r'Warning\b|!!', line) and 'Location' not in line]
    assert not warnings, '\n'.join(warnings)
    bin_dir = env_dir / 'bin'
    for script in ('pcrp', 'pcrp_node', 'pcrp_lifecycle_node'):
        assert (bin_dir / script).exists(), script
    help_ = subprocess.run([bin_dir / 'pcrp', '--help'], capture_output=True, text=True,
                           env=env, timeout=120, cwd=tmp_path)
    assert help_.returncode == 0 and 'usage: pcrp' in help_.stdout, help_.stderr
    where = subprocess.run([python, '-c', 'import pcrp_ros, pcrp_core.pipeline as p; '
                            'print(pcrp_ros.__file__); print(p.default_model_path())'],
                           capture_output=True, text=True, env=env, cwd=tmp_path, check=True)
    module, model = where.stdout.split()
    assert module.startswith(site) and Path(model, 'model.json').is_file()
    share = env_dir / 'share' / 'pcrp'
    assert (share / 'package.xml').is_file() and (share / 'config' / 'pcrp.yaml').is_file()
    assert {p.name for p in (share / 'launch').iterdir()} >= {
        'pcrp.launch.py', 'pcrp_lifecycle.launch.py', 'pcrp_scaled.launch.py'}
