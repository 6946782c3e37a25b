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
`python -m tools robot-report`: pcrp on the YCB objects as a robot's depth camera sees them.

pcrp's model is built as the README tells a user (`pcrp build <meshes> --up-axis z`) and answered
with its defaults; Open3D's FPFH + RANSAC / FGR + ICP answer the same views, told the object
and with their own retrieval. A second model, built the same way from the gallery less a
held-out set of objects, answers every view again: its held-out objects are what a robot meets
that its gallery does not hold, and should be rejected. Writes ROBOT.md and its files
(tools/robot_writer.py).

Every view is drawn from seed (split seed, object index, view index). The validation views
(seed 1000) are the only ones anything is chosen on; the test views (seed 0) are reported.
"""
from __future__ import annotations

from collections import defaultdict
import hashlib
import json
import os
from pathlib import Path
import subprocess
import sys
import time

from tools.provenance import code_key, machine, REPO
from tools.robot_protocol import (BASELINES, HELD_OUT, HOLDOUT_SEED, LOOKALIKE, METHODS,
                                  NO_LOCAL_SHAPE, QUICK_OBJECTS, RECIPE, SCENARIOS, SEEDS,
                                  VIEWS_PER_OBJECT)

CACHE = Path(os.environ.get('PCRP_CACHE', Path.home() / '.cache' / 'pcrp')) / 'robot'
THREAD_VARS = ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS')


def register(sub) -> None:
    p = sub.add_parser(
        'robot-report', help='pcrp and Open3D on YCB depth-camera views; write ROBOT.md',
        description='Render seeded depth-camera views of every mesh (free, on a table with up '
                    'known, and both occluded), answer them with pcrp (and with a model built '
                    "without some objects, which it should reject) and with Open3D's FPFH + "
                    'RANSAC / FGR + ICP (told the object, and with their own retrieval), and '
                    'write ROBOT.md and its figures to --out.')
    p.add_argument('--data', default=str(REPO.parent / 'shared' / 'data' / 'ycb'),
                   help='folder of meshes in metres')
    p.add_argument('--out', default='docs/results', help='report folder (default docs/results)')
    p.add_argument('--split', default='test', choices=sorted(SEEDS),
                   help='test (seed 0, reported) or validation (seed 1000, the views to tune on, '
                        'with a sweep of min_confidence); validation writes ROBOT_validation.md')
    p.add_argument('--views-per-object', type=int, default=VIEWS_PER_OBJECT,
                   help='per scenario (default 2)')
    p.add_argument('--baseline-views', type=int, default=None,
                   help='answer only the first this many views of each object and scenario with '
                        'Open3D (about 4 s a view; default: all)')
    p.add_argument('--no-baselines', action='store_true', help='pcrp only')
    p.add_argument('--quick', action='store_true',
                   help=f'{QUICK_OBJECTS} objects, 1 view each, the held-out model a subset of '
                        'the full one: a smoke run')
    p.add_argument('--cache', default=None, help=f'where models are built (default {CACHE})')
    p.add_argument('--rebuild', action='store_true',
                   help='build the models even if the cache holds them for this code')
    p.add_argument('--jobs', type=int, default=None,
                   help='processes building a model (default: one per core, as pcrp build); '
                        'the model is the same whatever the number, and views are answered on '
                        'one thread after it is built')
    p.add_argument('--from-json', default=None, metavar='FILE',
                   help='only re-render the report from a robot.json')
    p.set_defaults(func=_report)


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _report(args) -> int:
    # one thread: the times per view are one core's, as on a robot's shared computer
    for var in THREAD_VARS:
        os.environ[var] = '1'
    from pcrp_core.cli import _fail
    from tools import robot_writer

    if args.from_json:
        res = json.loads(Path(args.from_json).read_text())
    else:
        data = Path(args.data)
        if not data.is_dir():
            return _fail(f'{data}: no such folder of meshes')
        views = 1 if args.quick else args.views_per_object
        baseline_views = 0 if args.no_baselines else min(views, args.baseline_views or views)
        res = run(data, args.split, views, args.quick, Path(args.cache) if args.cache else CACHE,
                  args.rebuild, baseline_views, args.jobs)
    path = robot_writer.write(res, Path(args.out))
    print(f"wrote {path} ({res['seconds']['total'] / 60:.1f} minutes)")
    return 0


# -- models -------------------------------------------------------------------------------------
def mesh_files(data: Path) -> dict[str, Path]:
    """
    Map gallery ID -> file, as `pcrp build` names a folder's objects.

    The stem; `category/stem` in a sub-folder.
    """
    from pcrp_core.sources.folder import MESH_SUFFIXES

    files = {}
    for f in sorted(data.rglob('*')):
        rel = f.relative_to(data)
        if f.is_file() and f.suffix.lower() in MESH_SUFFIXES and len(rel.parts) <= 2:
            files['/'.join(rel.parts[:-1] + (f.stem,))] = f
    return files


def build_model(data: Path, cache: Path, rebuild: bool = False, without=(),
                jobs: int | None = None) -> Path:
    """
    Return the model the README's recipe builds from the meshes in data.

    Less those `without` (from a folder of links to the others), cached under the code that builds
    it.
    """
    without = sorted(without)
    name = f'{data.resolve().name}_{code_key()}'
    source = data
    if without:
        digest = hashlib.sha1('\n'.join(without).encode()).hexdigest()[:8]
        name += f'_without{len(without)}_{digest}'
        source = cache / f'{name}_meshes'
        if source.exists():
            for link in sorted(source.rglob('*'), reverse=True):
                link.rmdir() if link.is_dir() and not link.is_symlink() else link.unlink()
        for gid, f in mesh_files(data).items():
            if gid not in without:
                link = source / f.relative_to(data)
                link.parent.mkdir(parents=True, exist_ok=True)
                link.symlink_to(f.resolve())
    out = cache / name
    stamp = out / 'robot_recipe.json'
    recipe = {'data': str(data.resolve()), 'without': without, 'recipe': list(RECIPE)}
    if stamp.exists() and not rebuild and json.loads(stamp.read_text()) == recipe:
        _say(f'robot-report: reusing the model in {out}')
        return out
    _say(f'robot-report: building the model into {out}')
    cmd = [sys.executable, '-m', 'pcrp_core.cli', 'build', str(source), *RECIPE, '--out', str(out),
           *(['--jobs', str(jobs)] if jobs else [])]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
    if done.returncode != 0:
        raise RuntimeError(f'building the model failed: {done.stderr[-2000:]}')
    stamp.write_text(json.dumps(recipe))
    return out


def held_out(ids: list[str], twins, n: int, seed: int = HOLDOUT_SEED) -> list[str]:
    """Return n objects (or a few fewer) in a seeded order, each taken with its twins."""
    import numpy as np

    partners = defaultdict(set)
    for a, b in twins:
        partners[a].add(b)
        partners[b].add(a)
    chosen: list[str] = []
    for i in np.random.default_rng(seed).permutation(len(ids)):
        group = [ids[i]] + sorted(partners[ids[i]] - {ids[i]})
        if ids[i] in chosen or len(chosen) + len(group) > n:
            continue
        chosen += [g for g in group if g not in chosen]
        if len(chosen) == n:
            break
    return [g for g in ids if g in chosen]


def lookalikes(held: list[str], kept: list[str], chamfers, within: float = LOOKALIKE) -> dict:
    """
    Return held-out object -> the objects left in the gallery within `within` of its shape.

    Within by the chamfer table: with those there, the object is nearly a known one.
    """
    kept = set(kept)
    near = defaultdict(list)
    for a, b, c in chamfers:
        if c < within:
            if a in held and b in kept:
                near[a].append(b)
            if b in held and a in kept:
                near[b].append(a)
    return {g: sorted(near[g]) for g in held if near[g]}


# -- the run ------------------------------------------------------------------------------------
def _view_seed(scene) -> int:
    import numpy as np
    return int(np.random.SeedSequence([scene.seed, scene.object_index, scene.view])
               .generate_state(1)[0] % 2**31)


def _options(model) -> dict:
    params = model.get_params()
    return {k: params[k] for k in ('min_confidence', 'max_points', 'scale_mode', 'method')
            if k in params}


def _baselines(scenes, targets, truths, twins, progress):
    """Return the Open3D rows of the scenes, and how the size gate of their retrieval went."""
    import numpy as np
    from pcrp_core.evaluation.run import record
    from tools import robot_open3d as ro

    rows = {m: [] for m in BASELINES}
    kept, dropped = [], 0
    for s in progress(scenes, desc='open3d'):
        t_q = time.perf_counter()
        q = ro.query(s.points)
        t_features = time.perf_counter() - t_q
        for method in ro.METHODS:
            (told, t_told), (got, t_got), n, true_kept = ro.answer_view(
                method, q, t_features, targets, s.object_id, _view_seed(s))
            rows[f'{method}_told'].append(record(s, told, t_told, truths, '', twins))
            rows[method].append(record(s, got, t_got, truths,
                                       '' if got else 'no object passed the size gate', twins))
        kept.append(n)
        dropped += not true_kept
    gate = {'candidates_mean': float(np.mean(kept)) if kept else float('nan'),
            'true_dropped': int(dropped), 'views': len(scenes)}
    return rows, gate


def run(data: Path, split: str, views: int, quick: bool, cache: Path, rebuild: bool = False,
        baseline_views: int | None = None, jobs: int | None = None) -> dict:
    from pcrp_core import PCRP
    from pcrp_core.cli import _progress
    from pcrp_core.evaluation.run import evaluate, Truths, twin_pairs
    from pcrp_core.evaluation.scenes import sample_scenes
    from pcrp_core.sources import load_source
    from tools import robot_open3d as ro
    from tools.robot_twins import find_twins

    baseline_views = views if baseline_views is None else baseline_views
    t_start = time.perf_counter()
    load = [os.getloadavg()[0]]
    seconds = {}
    seed = SEEDS[split]
    objects = load_source(str(data))
    meshes = {o.gallery_id: o.mesh for o in objects if o.mesh is not None}
    ids = list(meshes)
    indices = {oid: i for i, oid in enumerate(ids)}
    chosen = ids[:: max(1, len(ids) // QUICK_OBJECTS)][:QUICK_OBJECTS] if quick else ids
    t0 = time.perf_counter()
    model_path = build_model(data, cache, rebuild, jobs=jobs)
    model = PCRP.load(model_path)
    seconds['model'] = time.perf_counter() - t0
    twins = twin_pairs(model)
    model_twins = [sorted(p) for p in model.meta.get('twins') or ()]

    t0 = time.perf_counter()
    chamfer_twins, nearest, aligned, chamfers = find_twins({k: meshes[k] for k in chosen})
    seconds['twins'] = time.perf_counter() - t0
    # the held-out model: rebuilt by the recipe without them; a quick run leaves them out of
    # the full model's gallery instead (same calibration), to stay quick
    pool = chosen if quick else ids
    n_held = HELD_OUT if len(pool) >= 4 * HELD_OUT else max(1, len(pool) // 4)
    held = held_out(pool, model_twins, n_held)
    kept = [g for g in ids if g not in held]
    t0 = time.perf_counter()
    if quick:
        reduced = model.subset(kept)
        reduced_twins = twins
    else:
        reduced = PCRP.load(build_model(data, cache, rebuild, held, jobs))
        reduced_twins = twin_pairs(reduced)
    seconds['held_out_model'] = time.perf_counter() - t0

    targets = {}
    if baseline_views:
        ro.quiet()
        t0 = time.perf_counter()
        targets = {oid: ro.target(m) for oid, m in meshes.items()}
        seconds['baseline_gallery'] = time.perf_counter() - t0
    truths = Truths(meshes)
    results, unknown, gate, drawn = {}, {}, {}, {}
    for name, (kind, occluded, up, seen) in SCENARIOS.items():
        _say(f'robot-report: {name}: drawing {views} view(s) of {len(chosen)} objects')
        part = {}
        t0 = time.perf_counter()
        if (kind, occluded) not in drawn:
            drawn[kind, occluded] = sample_scenes({k: meshes[k] for k in chosen}, views, kind,
                                                  occluded, seed, indices=indices)
        scenes = drawn[kind, occluded]
        part['scenes'] = time.perf_counter() - t0
        t0 = time.perf_counter()
        rows = {'pcrp': evaluate(model, scenes, meshes, use_up=up, progress=_progress,
                                 truths=truths, twins=twins, use_scene=seen)}
        part['pcrp'] = time.perf_counter() - t0
        if occluded:
            t0 = time.perf_counter()
            rows['pcrp_no_local_shape'] = evaluate(
                model.with_options(**NO_LOCAL_SHAPE), scenes, meshes, use_up=up,
                progress=_progress, truths=truths, twins=twins, use_scene=seen)
            part['pcrp_no_local_shape'] = time.perf_counter() - t0
        t0 = time.perf_counter()
        unknown[name] = evaluate(reduced, scenes, meshes, use_up=up, progress=_progress,
                                 truths=truths, twins=reduced_twins, use_scene=seen)
        for r in unknown[name]:
            r['known'] = r['object_id'] not in held
        part['held_out_model'] = time.perf_counter() - t0
        if baseline_views and not seen:    # Open3D's answers take no scene
            t0 = time.perf_counter()
            sub = [s for s in scenes if s.view < baseline_views]
            more, gate[name] = _baselines(sub, targets, truths, twins, _progress)
            rows.update(more)
            part['open3d'] = time.perf_counter() - t0
        results[name] = rows
        seconds[name] = part
        _say(f'robot-report: {name} took {sum(part.values()) / 60:.1f} min')
    seconds['total'] = time.perf_counter() - t_start
    load.append(os.getloadavg()[0])
    methods = {k: v for k, v in METHODS.items() if k not in BASELINES or baseline_views}
    return {
        'split': split, 'seed': seed, 'quick': quick, 'views_per_object': views,
        'baseline_views': baseline_views, 'data': str(data), 'objects': chosen,
        'gallery_size': len(meshes), 'machine': machine(), 'load': load, 'seconds': seconds,
        'model': {'recipe': f'pcrp build {data.name} ' + ' '.join(RECIPE), 'code': code_key(),
                  'n_objects': model.meta.get('n_objects'), 'up_axis': model.meta.get('up_axis'),
                  'templates': model.meta.get('templates'), 'twins': model_twins,
                  'options': _options(model),
                  'calibrated': getattr(model, 'view_calibration', None) is not None},
        'held_out': {'objects': held, 'seed': HOLDOUT_SEED, 'n': n_held,
                     'how': 'subset' if quick else 'rebuilt',
                     'twins': [sorted(p) for p in reduced_twins],
                     'lookalikes': lookalikes(held, kept, chamfers)},
        'baselines': {'voxel': ro.VOXEL, 'normal_radius': ro.NORMAL_RADIUS,
                      'feature_radius': ro.FEATURE_RADIUS, 'ransac_distance': ro.RANSAC_DISTANCE,
                      'ransac_criteria': list(ro.RANSAC_CRITERIA), 'fgr_distance': ro.FGR_DISTANCE,
                      'icp_distance': ro.ICP_DISTANCE, 'gate': list(ro.GATE)},
        'gate': gate,
        'twins': {'within': LOOKALIKE, 'pairs': chamfer_twins, 'nearest_others': nearest,
                  'pairs_aligned': aligned},
        'methods': methods, 'scenarios': {k: list(v) for k, v in SCENARIOS.items()},
        'results': results, 'unknown': unknown,
    }
