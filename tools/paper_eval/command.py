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

"""
`python -m tools paper-eval`.

The paper's experiments on ModelNet40 with the baselines beside them.
"""
from __future__ import annotations

import sys

from pcrp_core.cli import _fail, _progress


def register_eval(sub) -> None:
    from tools.paper_eval.run import EXPERIMENTS
    p = sub.add_parser(
        'paper-eval',
        help="reproduce the paper's experiments on ModelNet40, baselines alongside",
        description='Registration, retrieval and pose experiments of the PCRP paper, plus partial '
                    'views, '
        "a 40-category gallery and rejection, with Open3D's pipelines run alongside. Writes "
        'RESULTS.md, results.json and plots to --out. Models are built once into --cache.',
    )
    p.add_argument(
        '--data',
        default='../shared/data/modelnet40',
        help='folder of ModelNet40 category archives',
    )
    p.add_argument('--out', default='docs/results', help='report folder (default docs/results)')
    p.add_argument(
        '--seed',
        type=int,
        default=0,
        help='seed of every random motion, cut and viewpoint (default 0)',
    )
    p.add_argument('--per-category', type=int, default=None,
                   help='test objects per category, evenly spread (default: all 100)')
    p.add_argument(
        '--quick', action='store_true', help='a small subset and small models: a couple of minutes'
    )
    p.add_argument('--experiments', default=','.join(EXPERIMENTS),
                   help=f"comma-separated subset of {','.join(EXPERIMENTS)} (default all)")
    p.add_argument(
        '--jobs', type=int, default=None, help='worker processes (default: one per core)'
    )
    p.add_argument(
        '--cache', default=None, help='where built models are kept (default ~/.cache/pcrp/eval)'
    )
    p.add_argument(
        '--keep',
        default=None,
        help='an earlier results.json (same seed) whose experiments this run '
        'does not run are kept in the report, marked as carried over',
    )
    p.set_defaults(func=_eval)


def _eval(args) -> int:
    import os

    # one thread per worker: the queries run in parallel, one per core
    for var in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS'):
        os.environ.setdefault(var, '1')
    from tools.paper_eval.run import EXPERIMENTS, run, Settings, write

    chosen = [e.strip() for e in args.experiments.split(',') if e.strip()]
    unknown = sorted(set(chosen) - set(EXPERIMENTS))
    if unknown:
        return _fail(
            f"unknown experiments {', '.join(unknown)}; choose from {', '.join(EXPERIMENTS)}"
        )
    settings = Settings(
        args.data,
        args.out,
        args.seed,
        args.per_category,
        args.quick,
        args.jobs,
        args.cache,
        chosen,
        _progress,
        lambda m: print(m, file=sys.stderr, flush=True),
    )
    try:
        res = run(settings)
    except FileNotFoundError as e:
        return _fail(str(e))
    if args.keep:
        import json
        from pathlib import Path

        from tools.paper_eval.run import carry
        res = carry(res, json.loads(Path(args.keep).read_text()))
    path = write(settings, res)
    print(f"wrote {path} ({res['seconds']['total'] / 60:.1f} minutes)")
    return 0
