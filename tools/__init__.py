"""The harness beside the package: experiments, benchmarks and fault batteries. Not installed.

Run from a checkout: `python -m tools <command>` (see `python -m tools --help`).
"""
