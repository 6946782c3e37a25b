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

"""`python -m tools`: the commands that write the committed reports in docs/results."""
from __future__ import annotations

import argparse
import sys

from pcrp_core.cli import run
from tools import bench, robot_report, robustness, segmentation_report, soak
from tools.paper_eval import command as paper_eval


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(
        prog='python -m tools',
        description="pcrp's experiments, benchmarks and "
        'fault batteries (run from a checkout; not installed)',
    )
    sub = parser.add_subparsers(dest='command', required=True)
    for register in (paper_eval.register_eval, bench.register, robustness.register, soak.register,
                     robot_report.register, segmentation_report.register):
        register(sub)
    return run(parser, argv)


if __name__ == '__main__':
    sys.exit(main())
