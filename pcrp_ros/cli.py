"""The `pcrp` command: pcrp_core's commands plus the ROS and rosbag ones."""
import sys

from pcrp_core import cli as core_cli
from pcrp_ros import bag_commands, bench, robustness, soak


def main(argv=None):
    parser = core_cli.build_parser(extensions=[bag_commands.register, soak.register, robustness.register, bench.register])
    return core_cli.run(parser, argv)


if __name__ == "__main__":
    sys.exit(main())
