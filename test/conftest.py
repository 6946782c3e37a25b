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

"""Session-wide fixtures: one small real gallery model, built once for the whole suite."""
import faulthandler
import os
from pathlib import Path
import sys
from types import SimpleNamespace

import pytest

sys.path.insert(0, str(Path(__file__).parent))
from helpers import MODELNET, modelnet  # noqa: E402,I100

GROUPS = ('unit', 'integration', 'ros', 'tools')

# A test that hangs (a crashed child a pool waits on for ever, say) ends the run with every
# thread's traceback rather than holding CI to its time limit. The slowest test, the quick paper
# evaluation, takes about 2 minutes.
HANG_SECONDS = 1200
HANG_REPORT = pytest.StashKey[object]()


def pytest_collection_modifyitems(items):
    """
    Mark each test with its group, the folder it lives in.

    So `-m unit` or `-m "not ros"` selects by what a test needs rather than by file names.
    """
    for item in items:
        group = Path(str(item.fspath)).parent.name
        if group in GROUPS:
            item.add_marker(getattr(pytest.mark, group))


def pytest_configure(config):
    # The tracebacks must reach the terminal: during a test pytest captures file descriptor 2,
    # and what it captured is lost when the process exits. Capture is off here.
    config.stash[HANG_REPORT] = os.fdopen(os.dup(2), 'w')


@pytest.fixture(autouse=True)
def end_run_on_hang(pytestconfig):
    report = pytestconfig.stash[HANG_REPORT]
    faulthandler.dump_traceback_later(HANG_SECONDS, exit=True, file=report)
    yield
    faulthandler.cancel_dump_traceback_later()


@pytest.fixture(scope='session')
def small_model(tmp_path_factory):
    """
    Build a model of 40 ModelNet40 training objects each of chair, sofa and airplane.

    The model is saved; the tests load it back from the path returned.
    """
    if not MODELNET.exists():
        pytest.skip('needs ../shared/data/modelnet40')
    from pcrp_core import PCRP

    objects = []
    for category in ('chair', 'sofa', 'airplane'):
        points, names = modelnet(category, 'train', 40)
        objects += [
            SimpleNamespace(gallery_id=n, category=category, points=p)
            for n, p in zip(names, points)
        ]
    path = tmp_path_factory.mktemp('model') / 'small'
    PCRP.build(objects, seed=0, sources=['modelnet40 test subset']).save(path)
    return path
