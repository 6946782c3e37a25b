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

"""`make demo` as a user runs it: every cloud of the shipped bag gets a row with its confidence."""

import re
import subprocess
import sys

from rosutil import own_domain_env  # and a ROS domain of this test process's own

ROW = re.compile(r'^segmented_object\s+\d+\.\d{9}\s+(\S+)\s+(\S+)\s+([\d.]+)\s+([\d.]+)%\s+'
                 r'(\S+)\s+(\d+)\s+(ok|rejected: \w+)$')


def test_the_demo_shows_every_cloud_with_its_confidence_and_accounts_for_the_bag():
    env = own_domain_env(70)
    proc = subprocess.run([sys.executable, '-m', 'pcrp_ros.cli', 'demo'], capture_output=True,
                          text=True, timeout=300, env=env)
    assert proc.returncode == 0, proc.stdout[-3000:] + proc.stderr[-3000:]
    out = proc.stdout
    rows = [ROW.match(line) for line in out.splitlines() if line.startswith('segmented_object')]
    assert rows and all(rows), out
    received, answered, rejected, stale = map(int, re.search(
        r'node: received (\d+), answered (\d+), rejected (\d+), dropped as stale (\d+)',
        out).groups())
    # the shipped bag holds 30 clouds; each one the node answered or refused has its row, the
    # refused ones (no pose is published for them) marked so, with the confidence that refused it
    assert received == 30 and len(rows) == answered + rejected == received - stale
    assert sum(r.group(7) != 'ok' for r in rows) == rejected
    for r in rows:
        confidence = float(r.group(5))
        assert 0.0 <= confidence <= 1.0
        assert (confidence >= 0.5) == (r.group(7) == 'ok'), r.group(0)
    assert f'clouds {len(rows)}, answered {answered}, rejected {rejected}' in out
