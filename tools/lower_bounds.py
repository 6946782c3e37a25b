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
Check setup.py's lower bounds: run the tests that need no ROS against exactly those versions.

Makes a venv under the given folder, installs every install_requires entry at its lower bound
(`name>=X` becomes `name==X`), makes this environment's other packages (pytest, hypothesis,
what open3d needs) visible after its own, and runs the core, bag and CLI tests from this
checkout there. The ROS tests are left out: the ROS 2 wheels load only in the venv they were
installed in. Downloads about 500 MB the first time; takes a few minutes.

    python -m tools.lower_bounds [FOLDER]
"""

import os
from pathlib import Path
import re
import subprocess
import sys
import tempfile
import venv

REPO = Path(__file__).resolve().parents[1]
TESTS = ['test_model_io.py', 'test_features.py', 'test_aggregation.py', 'test_registration.py',
         'test_up.py', 'test_pipeline.py', 'test_bags.py', 'test_cli.py']


def lower_bounds() -> list:
    """Return install_requires' `name>=X` entries as `name==X`."""
    text = (REPO / 'setup.py').read_text()
    block = text[text.index('install_requires=['):]
    block = block[:block.index(']')]
    return [f'{name}=={version}'
            for name, version in re.findall(r"'([A-Za-z0-9_.-]+)>=([0-9.]+)'", block)]


def main(argv=None) -> int:
    argv = sys.argv[1:] if argv is None else argv
    folder = Path(argv[0]) if argv else Path(tempfile.mkdtemp(prefix='pcrp_lower_bounds_'))
    env_dir = folder / 'venv'
    if not (env_dir / 'bin' / 'python').exists():
        venv.create(env_dir, with_pip=True)
    python = str(env_dir / 'bin' / 'python')
    pins = lower_bounds()
    print('installing', ' '.join(pins), flush=True)
    subprocess.run([python, '-m', 'pip', 'install', '-q', *pins], check=True)
    site = subprocess.run([python, '-c', 'import sysconfig; print(sysconfig.get_path("purelib"))'],
                          capture_output=True, text=True, check=True).stdout.strip()
    here = [p for p in sys.path if p.endswith('site-packages')]
    Path(site, 'outer_environment.pth').write_text('\n'.join(here) + '\n')
    versions = subprocess.run(
        [python, '-c', 'import numpy, scipy, sklearn, joblib, tqdm, open3d, rosbags.rosbag2; '
         'print(numpy.__version__, scipy.__version__, sklearn.__version__, joblib.__version__, '
         'tqdm.__version__, open3d.__version__)'], capture_output=True, text=True)
    print('numpy, scipy, scikit-learn, joblib, tqdm, open3d:', versions.stdout.strip(),
          versions.stderr[-2000:], flush=True)
    tests = [str(REPO / 'test' / t) for t in TESTS]
    return subprocess.run([python, '-m', 'pytest', '-q', '-p', 'no:cacheprovider', *tests],
                          cwd=REPO, env=dict(os.environ, PYTHONPATH=str(REPO))
                          ).returncode


if __name__ == '__main__':
    sys.exit(main())
