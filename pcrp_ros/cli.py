"""The `pcrp` command: pcrp_core's commands plus the rosbag ones and the demo."""
import sys

from pcrp_core import cli as core_cli
from pcrp_ros import bag_commands, demo


def main(argv=None):
    parser = core_cli.build_parser(extensions=[bag_commands.register, demo.register])
    return core_cli.run(parser, argv)


if __name__ == "__main__":
    sys.exit(main())
