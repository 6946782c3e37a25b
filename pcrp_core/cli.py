"""`pcrp` command line: build | query | demo (and eval, bench later). ROS commands are added by pcrp_ros.cli.

Each subcommand lives in a `register(subparsers)` function that adds its parser and sets
`func` to a handler taking the parsed args and returning an exit code. Heavy imports stay
inside handlers so `pcrp --help` is instant.
"""
from __future__ import annotations

import argparse
import sys


def build_parser(extensions=()) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pcrp", description="PCRP point cloud object retrieval and pose estimation")
    sub = parser.add_subparsers(dest="command", required=True)
    for register in (*_CORE_COMMANDS, *extensions):
        register(sub)
    return parser


def run(parser: argparse.ArgumentParser, argv=None) -> int:
    args = parser.parse_args(argv)
    return int(args.func(args) or 0)


_CORE_COMMANDS: list = []  # filled below as commands are written


def main(argv=None) -> int:
    return run(build_parser(), argv)


if __name__ == "__main__":
    sys.exit(main())
