"""`python -m tools`: the commands that write the committed reports in docs/results."""
from __future__ import annotations

import argparse
import sys

from pcrp_core.cli import run
from tools import bench, robot_report, robustness, soak
from tools.paper_eval import command as paper_eval


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="python -m tools", description="pcrp's experiments, benchmarks and "
                                     "fault batteries (run from a checkout; not installed)")
    sub = parser.add_subparsers(dest="command", required=True)
    for register in (paper_eval.register_eval, bench.register, robustness.register, soak.register,
                     robot_report.register):
        register(sub)
    return run(parser, argv)


if __name__ == "__main__":
    sys.exit(main())
