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
`python -m tools segmentation-report`: the robot report's views as a segmenter may cut them.

The free and table views of ROBOT.md (same seeds, same model: the README's recipe), each with
each fault of tools/segmentation_faults.py added, answered with pcrp's defaults, again with
drop_strays off (what setting strays aside buys), and on a table with drop_support on. Validation
views (seed 1000) are where the stray and table rules (pcrp_core/strays.py, support.py) were
chosen; the test views (seed 0) are reported.
"""
from __future__ import annotations

from dataclasses import replace
import json
import os
from pathlib import Path
import time

import numpy as np
from tools.provenance import code_key, machine
from tools.robot_protocol import RECIPE, SEEDS, VIEWS_PER_OBJECT

KINDS = {'free': 'free in space', 'table': 'on a table, up known'}
FILES = {'test': 'SEGMENTATION', 'validation': 'SEGMENTATION_validation'}
NOTHING_ASIDE = 'nothing set aside'     # drop_strays and drop_support off
TABLE_ASIDE = 'drop_support on'         # the table's layer set aside too (up known only)
# what segmentation.json keeps of each view's record (pcrp_core/evaluation/run.py)
VIEW_FIELDS = ('object_id', 'view', 'n_points', 'gallery_id', 'pose_right', 'rejected',
               'confidence', 'surface_error', 'stray_share', 'table_share', 'seconds')


def register(sub) -> None:
    p = sub.add_parser(
        'segmentation-report',
        help="the robot report's views with a segmenter's faults; write SEGMENTATION.md",
        description="Answer the robot report's free and table views with what an imperfect "
                    'segmenter adds (specks, a mask a pixel too wide, flying pixels), with '
                    'strays set aside (the default) and without; write SEGMENTATION.md and '
                    'segmentation.json to --out.')
    p.add_argument('--data', default=None, help='folder of meshes in metres (default: '
                   "the robot report's, ../shared/data/ycb)")
    p.add_argument('--out', default='docs/results', help='report folder (default docs/results)')
    p.add_argument('--split', default='test', choices=sorted(SEEDS),
                   help='test (seed 0, reported) or validation (seed 1000, chosen on)')
    p.add_argument('--views-per-object', type=int, default=VIEWS_PER_OBJECT,
                   help='per scenario (default 2)')
    p.add_argument('--objects', type=int, default=None,
                   help='only every n-th object of the folder, to this many (a smoke run)')
    p.add_argument('--cache', default=None, help='where models are built (default: the robot '
                   "report's)")
    p.set_defaults(func=_report)


def _report(args) -> int:
    from pcrp_core.cli import _fail
    from tools import robot_report

    for var in robot_report.THREAD_VARS:
        os.environ[var] = '1'
    data = Path(args.data) if args.data else robot_report.REPO.parent / 'shared' / 'data' / 'ycb'
    if not data.is_dir():
        return _fail(f'{data}: no such folder of meshes')
    cache = Path(args.cache) if args.cache else robot_report.CACHE
    res = run(data, args.split, args.views_per_object, cache, args.objects)
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    name = FILES[args.split]
    (out / f'{name.lower()}.json').write_text(json.dumps(res, indent=1) + '\n')
    (out / f'{name}.md').write_text(markdown(res))
    print(f"wrote {out / (name + '.md')} ({res['seconds'] / 60:.1f} minutes)")
    return 0


def run(data: Path, split: str, views: int, cache: Path, objects: int | None = None) -> dict:
    from pcrp_core import PCRP
    from pcrp_core.cli import _progress
    from pcrp_core.evaluation.run import evaluate, jsonable, statistics, Truths
    from pcrp_core.evaluation.scenes import sample_scenes
    from pcrp_core.sources import load_source
    from tools.robot_report import build_model
    from tools.segmentation_faults import FAULTS, with_fault

    t_start = time.perf_counter()
    seed = SEEDS[split]
    meshes = {o.gallery_id: o.mesh for o in load_source(str(data)) if o.mesh is not None}
    ids = list(meshes)
    indices = {oid: i for i, oid in enumerate(ids)}
    chosen = ids[:: max(1, len(ids) // objects)][:objects] if objects else ids
    model = PCRP.load(build_model(data, cache))
    settings = {'defaults': model, TABLE_ASIDE: model.with_options(drop_support=True),
                NOTHING_ASIDE: model.with_options(drop_strays=False, drop_support=False)}
    truths = Truths(meshes)
    table, views_of = {}, {}
    for kind in KINDS:
        scenes = sample_scenes({k: meshes[k] for k in chosen}, views, kind, False, seed,
                               indices=indices)
        for fault in FAULTS:
            dirty = [replace(s, points=with_fault(s, meshes[s.object_id], fault)) for s in scenes]
            added = [len(d.points) - len(s.points) for d, s in zip(dirty, scenes)]
            for name, m in settings.items():
                if name == TABLE_ASIDE and kind != 'table':
                    continue    # without up the setting changes nothing
                rows = evaluate(m, dirty, meshes, use_up=kind == 'table', truths=truths,
                                progress=_progress)
                stats = statistics(rows)
                stats['added_median'] = float(np.median(added))
                stats['stray_share_median'] = float(
                    np.median([r['stray_share'] + r['table_share'] for r in rows]))
                key = f'{kind}/{fault}/{name}'
                table[key] = stats
                views_of[key] = [{k: r[k] for k in VIEW_FIELDS} for r in rows]
    return {'split': split, 'seed': seed, 'views_per_object': views, 'objects': chosen,
            'gallery_size': len(meshes), 'data': str(data), 'machine': machine(),
            'model': {'recipe': f'pcrp build {data.name} ' + ' '.join(RECIPE), 'code': code_key()},
            'faults': FAULTS, 'settings': list(settings), 'results': table,
            'views': jsonable(views_of, 4), 'seconds': time.perf_counter() - t_start}


def markdown(res: dict) -> str:
    from tools.robot_writer import _pct

    m = res['machine']
    n_views = len(res['objects']) * res['views_per_object']
    split = '' if res['split'] == 'test' else f" --split {res['split']}"
    lines = [
        "# pcrp on the robot report's views, cut by an imperfect segmenter",
        '',
        (f"**Validation views (seed {res['seed']}): where the stray and table rules were "
         "chosen; the reported figures are the test views' (SEGMENTATION.md).**\n"
         if res['split'] == 'validation' else '')
        + f'Generated by `python -m tools segmentation-report{split}` in '
        f"{max(1, round(res['seconds'] / 60))} minute(s) on {m['cores']} cores ({m['cpu']}, "
        f"one thread), {m['date']}, code {res['model']['code']}. The free and table views of "
        'ROBOT.md '
        f"(seed {res['seed']}, {len(res['objects'])} of the {res['gallery_size']} YCB objects, "
        f"{res['views_per_object']} view(s) each: {n_views} per scenario), the model its "
        f"recipe builds (`{res['model']['recipe']}`). Each view is answered as a segmenter "
        'might send it: with nothing added (the perfect mask of the other reports), or with '
        'one of the faults below added, at the defaults (strays set aside: '
        'pcrp_core/strays.py), on a table also with `drop_support` on (its layer set aside: '
        'pcrp_core/support.py), and with nothing set aside. Pose right, wrong acc and right rej '
        'as in ROBOT.md: ADD-S under 10 % of the diameter; shares of the views, right rej of '
        'the right answers. Per-view figures: '
        f"[{FILES[res['split']].lower()}.json]({FILES[res['split']].lower()}.json).",
        '',
        '| fault | what the segmenter added |',
        '| --- | --- |',
    ]
    lines += [f'| {k} | {v} |' for k, v in res['faults'].items()]
    header = ('| scenario | fault | points added (median) | set aside (median) | pose right '
              '| wrong acc | right rej | pose right, drop_support on | wrong acc, drop_support '
              'on | pose right, nothing set aside | wrong acc, nothing set aside | time med |')
    lines += ['', header, '| ' + ' | '.join(['---'] * 12) + ' |']
    for kind, title in KINDS.items():
        for fault in res['faults']:
            on = res['results'][f'{kind}/{fault}/defaults']
            off = res['results'][f'{kind}/{fault}/{NOTHING_ASIDE}']
            cut = res['results'].get(f'{kind}/{fault}/{TABLE_ASIDE}')
            with_table = (f"{_pct(cut['pose_right'])} | {_pct(cut['wrong_accepted'])}"
                          if cut else '- | -')
            lines.append(
                f"| {title} | {fault} | {on['added_median']:.0f} | "
                f"{100 * on['stray_share_median']:.1f} % | {_pct(on['pose_right'])} | "
                f"{_pct(on['wrong_accepted'])} | {_pct(on['right_rejected'])} | {with_table} | "
                f"{_pct(off['pose_right'])} | {_pct(off['wrong_accepted'])} | "
                f"{on['seconds_median']:.2f} s |")
    lines += ['', "Set aside: the median share of a view's points (of those screened: at most "
              'three times max_points, drawn at random) set aside at the defaults as strays '
              "(the answer's stray_share).", '']
    lines += ['Not handled at the defaults: background that touches the object (the table under '
              'its foot, a wall it leans on) is linked to it and kept. `drop_support` sets the '
              "table's layer aside where up is known, at a price for partly hidden objects and "
              "for the rejection of objects the gallery lacks (docs/method.md): ROBOT.md's views "
              'are answered at the defaults.', '']
    return '\n'.join(lines)
