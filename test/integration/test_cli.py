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

"""The command line as a user types it."""
import json
import subprocess
import sys

import numpy as np
import pytest


def pcrp(*args):
    return subprocess.run(
        [sys.executable, '-m', 'pcrp_ros.cli', *args], capture_output=True, text=True, timeout=600
    )


@pytest.mark.slow
def test_build_a_gallery_then_query_a_cloud_file(tmp_path):
    model = tmp_path / 'model'
    built = pcrp('build', 'procedural:4', '--out', str(model))
    assert built.returncode == 0, built.stderr
    assert '16 objects' in built.stdout and 'MB on disk' in built.stdout
    # no terminal, so no progress bars: a line as each stage starts, for a log to show
    assert 'pcrp: features...' in built.stderr and 'pcrp: calibration...' in built.stderr
    from pcrp_core.sources.procedural import generate_object
    from scipy.spatial.transform import Rotation
    R = Rotation.from_euler('zyx', [40, -20, 70], degrees=True).as_matrix()
    cloud = tmp_path / 'chair.npy'
    np.save(cloud, generate_object('chair', 2).astype(np.float64) @ R.T + [1.0, 2.0, 3.0])
    out = pcrp('query', str(model), str(cloud), '--json')
    assert out.returncode == 0, out.stderr
    result = json.loads(out.stdout)
    assert result['gallery_id'] == 'proc_chair_0002' and result['category'] == 'chair'
    np.testing.assert_allclose(np.array(result['rotation']), R, atol=0.02)
    np.testing.assert_allclose(result['translation'], [1.0, 2.0, 3.0], atol=0.02)
    text = pcrp('query', str(model), str(cloud))
    assert 'gallery_id  proc_chair_0002' in text.stdout and 'quaternion' in text.stdout
    # the generator's objects are z-up, so the model knows its up axis and a query may state up
    assert 'up axis z' in built.stdout
    up = pcrp(
        'query', str(model), str(cloud), '--json', '--up=' + ','.join(f'{v:.6f}' for v in R[:, 2])
    )
    assert up.returncode == 0, up.stderr
    np.testing.assert_allclose(np.array(json.loads(up.stdout)['rotation']), R, atol=0.02)
    bad = pcrp('query', str(model), str(cloud), '--up', '0,1')
    assert bad.returncode == 2 and 'up' in bad.stderr and 'Traceback' not in bad.stderr


def test_a_missing_model_or_cloud_fails_with_one_clear_line(tmp_path):
    out = pcrp('query', str(tmp_path / 'nope'), str(tmp_path / 'x.npy'))
    assert out.returncode == 2 and 'no such model' in out.stderr and 'Traceback' not in out.stderr
    out = pcrp('query', 'default', str(tmp_path / 'x.npy'))
    assert out.returncode == 2 and 'x.npy' in out.stderr and 'Traceback' not in out.stderr
    np.save(tmp_path / 'transposed.npy', np.zeros((3, 500)))
    out = pcrp('query', 'default', str(tmp_path / 'transposed.npy'))
    assert out.returncode == 2 and 'one point a row' in out.stderr, out.stderr
    (tmp_path / 'taken').write_text('')
    out = pcrp('build', 'procedural:1', '--out', str(tmp_path / 'taken'))
    assert out.returncode == 2 and 'a file is there' in out.stderr, out.stderr


def test_a_leading_minus_is_a_value_not_an_option():
    """`--up -1,0,0` and `--up-axis -y`, as typed (argparse alone wants `--up=-1,0,0`)."""
    from pcrp_core.cli import build_parser, join_signed_values
    from pcrp_ros import bag_commands
    parser = build_parser(extensions=[bag_commands.register])
    args = parser.parse_args(
        join_signed_values(['query', 'm', 'c.ply', '--up', '-1,0,0', '--json'])
    )
    assert args.up == '-1,0,0' and args.json
    args = parser.parse_args(
        join_signed_values(['build', 'procedural', '--out', 'm', '--up-axis', '-y'])
    )
    assert args.up_axis == '-y'
    args = parser.parse_args(
        join_signed_values(['process', 'bag', '--out', 'o', '--up', '-0.5,0,-.5e0'])
    )
    assert args.up == '-0.5,0,-.5e0'
    # a forgotten value is still an error, not swallowed as one
    assert join_signed_values(['query', 'm', 'c', '--up', '--json']) == [
        'query',
        'm',
        'c',
        '--up',
        '--json',
    ]
    # and through the command itself (unjoined, argparse stops at
    # "--up-axis: expected one argument")
    proc = pcrp('build', '--up-axis', '-y', '--help')
    assert proc.returncode == 0 and '--up-axis' in proc.stdout, proc.stderr


def test_ctrl_c_ends_a_command_with_one_line_and_130(tmp_path):
    """As a terminal sends it: SIGINT to the whole process group, build's workers included."""
    import os
    import signal
    model = tmp_path / 'model'
    proc = subprocess.Popen(
        [sys.executable, '-c', 'import sys; from pcrp_ros.entry_points import pcrp; '
         'sys.exit(pcrp())', 'build', 'procedural:12', '--out', str(model)],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, start_new_session=True,
        env={**os.environ, 'PYTHONUNBUFFERED': '1'},
        # as a terminal starts it: a test run in the background would hand on SIGINT ignored
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        lines = []
        while not lines or (lines[-1] and 'fitting' not in lines[-1]):
            lines.append(proc.stdout.readline())
        assert 'fitting' in lines[-1], lines
        os.killpg(proc.pid, signal.SIGINT)
        out, _ = proc.communicate(timeout=60)
    finally:
        if proc.poll() is None:
            os.killpg(proc.pid, signal.SIGKILL)
    assert proc.returncode == 130 and 'pcrp: interrupted' in out and 'Traceback' not in out, out
    assert not model.exists()


def test_a_rejected_query_to_a_camera_model_says_how_the_node_would_ask(tmp_path):
    """The node takes clouds to be a camera's view from the origin; a cloud file says nothing."""
    cloud = tmp_path / 'blob.npy'
    np.save(cloud, np.random.default_rng(0).normal(scale=0.05, size=(500, 3)) + [0, 0, 0.6])
    out = pcrp('query', 'default', str(cloud))
    assert out.returncode == 0 and 'REJECTED' in out.stdout, out.stdout + out.stderr
    assert 'hint' in out.stderr and '--viewpoint 0,0,0' in out.stderr
    told = pcrp('query', 'default', str(cloud), '--viewpoint', '0,0,0')
    assert told.returncode == 0 and 'hint' not in told.stderr, told.stderr
