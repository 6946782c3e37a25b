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

"""The `pcrp` command: pcrp_core's commands plus the rosbag ones and the demo."""
import sys

from pcrp_core import cli as core_cli
from pcrp_ros import bag_commands, demo


def main(argv=None):
    parser = core_cli.build_parser(extensions=[bag_commands.register, demo.register])
    try:
        return core_cli.run(parser, argv)
    except KeyboardInterrupt:
        # Ctrl-C: what was under way is abandoned, which the user knows; a traceback says nothing
        print('pcrp: interrupted', file=sys.stderr)
        return 130


if __name__ == '__main__':
    sys.exit(main())
