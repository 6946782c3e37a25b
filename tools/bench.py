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
`python -m tools bench`: how fast, how big, how it scales.

Writes docs/results/BENCHMARKS.md and benchmarks.json; figures come from this machine, on the
commands' own runs.

Parts, each its own function so a reader can rerun one: the machine; building the four-category
ModelNet40 model (wall time, peak memory of the build's processes, size); one query end to end per
stage, single-threaded and with default threads, 1024- and 2048-point clouds, beside Open3D's FPFH
+ FGR + ICP and FPFH + RANSAC + ICP on the same queries; retrieval against galleries of 100, 1,000
and 9,843 objects; the node under load over DDS, and two node processes against one.
"""
from __future__ import annotations

import json
import os
from pathlib import Path
import subprocess
import sys
import tempfile
import time

import numpy as np
from tools.bench_plots import GROWTH_PLOT, growth_plot, slope
from tools.process_memory import tree_rss_mb
from tools.provenance import built_once, code_key, machine
from tools.soak import LARGE_CLOUDS_PROFILE

CATEGORIES = ('airplane', 'chair', 'sofa', 'car')
THREAD_VARS = ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS')
# the order a query goes through them, and what each is
STAGES = {
    'preprocess': 'finite points, duplicates merged, downsampled, checked',
    'fpfh': 'oriented normals and FPFH (Open3D)',
    'hop1': 'hop-1 Saab',
    'sampling': 'farthest-point sampling to half',
    'hop2': 'octants of each local frame, channel-wise Saab',
    'vlad': 'VLAD vector',
    'features': "= the query's features in all",
    'retrieval': 'nearest VLAD vectors in the gallery',
    'gallery_features': "the retrieved objects' features, where they seed RANSAC (cached)",
    'correspondences': 'feature matches within symmetry halves',
    'ransac': 'Procrustes in RANSAC',
    'hypotheses': 'principal-axis, half-turn and (for sensor clouds) view hypotheses, coarse ICP',
    'verification': 'the vote: every hypothesis briefly on every candidate, the best in full',
    'refinement': 'final ICP, pose averaging, the mirror-plane finish',
    'registration': '= everything after retrieval',
    'total': 'end to end',
}
CACHE = Path(os.environ.get('PCRP_CACHE', Path.home() / '.cache' / 'pcrp')) / 'bench'


def run_measured(cmd: list[str], env: dict | None = None) -> dict:
    """Wall time and peak resident memory (sampled, whole process tree) of a command."""
    t0 = time.perf_counter()
    proc = subprocess.Popen(
        cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True
    )
    peak = 0.0
    while proc.poll() is None:
        peak = max(peak, tree_rss_mb(proc.pid))
        time.sleep(0.25)
    out, err = proc.communicate()
    return {'seconds': time.perf_counter() - t0, 'peak_mb': peak, 'returncode': proc.returncode,
            'stdout': out, 'stderr': err}


# -- building -------------------------------------------------------------------------------------
def bench_build(data: Path, out: Path, limit: int | None = None) -> dict:
    """Build the four-category model as a user would (`pcrp build`), measured."""
    from pcrp_core import PCRP
    from pcrp_core.model_io import model_size

    cmd = [
        sys.executable,
        '-m',
        'pcrp_ros.cli',
        'build',
        *[str(data / f'{c}.npz') for c in CATEGORIES],
        '--out',
        str(out),
    ] + (['--limit', str(limit)] if limit else [])
    r = run_measured(cmd, dict(os.environ, TQDM_DISABLE='1'))
    if r['returncode']:
        raise RuntimeError(f"pcrp build failed: {r['stderr'][-2000:]}")
    model = PCRP.load(out)
    return {'objects': len(model.gallery_ids), 'seconds': r['seconds'], 'peak_mb': r['peak_mb'],
            'bytes': model_size(out), 'parts': model.size_report(), 'path': str(out)}


# -- queries --------------------------------------------------------------------------------------
def query_set(data: Path, n: int, n_points: int, seed: int):
    """
    Return n ModelNet40 test objects of the four categories in turn.

    Each is under a uniformly random rotation and a translation in [-0.5, 0.5]^3. The archives hold
    1024 points per object; a 2048-point cloud adds 1024 of them again, jittered by 0.5 % of the
    radius, as a denser scan of the same surface would be (the model downsamples it back to its own
    1024).
    """
    from pcrp_core.sources.views import random_rotation
    rng = np.random.default_rng(seed)
    per_cat = {}
    for c in CATEGORIES:
        with np.load(data / f'{c}.npz', allow_pickle=False) as f:
            per_cat[c] = (f['test_points'], f['test_names'])
    out = []
    for k in range(n):
        c = CATEGORIES[k % len(CATEGORIES)]
        pts, names = per_cat[c]
        i = int(rng.integers(len(pts)))
        p = pts[i].astype(np.float64)
        if n_points > len(p):
            extra = p[rng.integers(len(p), size=n_points - len(p))]
            p = np.concatenate([p, extra + rng.normal(scale=0.005, size=extra.shape)])
        R = random_rotation(rng)
        t = rng.uniform(-0.5, 0.5, 3)
        out.append((str(names[i]), c, p @ R.T + t, R))
    return out


def _eight_candidates(model):
    model.set_params(n_candidates=8)
    return model


def _paper(model):
    from tools.paper_eval.methods import paper_variant
    return paper_variant(model)


# cheaper configurations run on the same queries, so the report can say from this run what the
# defaults' time buys
VARIANTS = {'pcrp_8_candidates': _eight_candidates, 'pcrp_paper': _paper}


def bench_queries(
    model_path: str,
    data: Path,
    n: int,
    n_points: int,
    seed: int,
    baselines: bool = True,
    progress=None,
    variants: bool = False,
) -> dict:
    """
    Per-stage time of `estimate`.

    And the Open3D pipelines on the same queries (registering to the gallery object PCRP retrieved,
    its FPFH computed once beforehand as an Open3D user would); with variants, also the
    configurations in VARIANTS.
    """
    from pcrp_core import PCRP
    from tools.paper_eval.metrics import geodesic_deg
    model = PCRP.load(model_path)
    queries = query_set(data, n, n_points, seed)
    wrap = progress or (lambda it, **_: it)
    stages, errors, cats = [], [], []
    rows = {'pcrp': {'seconds': [], 'errors': []}}
    o3d_runs = {}
    if baselines:
        from tools.paper_eval.open3d_pipelines import OPEN3D_PIPELINES, prepare_target
        o3d_runs = {name: {'seconds': [], 'errors': []} for name in OPEN3D_PIPELINES}
        targets = {}
    model.estimate(queries[0][2])  # warm caches and imports outside the timings
    for gid, cat, pts, R in wrap(queries, desc=f'queries ({n_points} points)', unit='query'):
        t0 = time.perf_counter()
        r = model.estimate(pts)
        rows['pcrp']['seconds'].append(time.perf_counter() - t0)
        rows['pcrp']['errors'].append(geodesic_deg(r.rotation, R))
        stages.append(r.timings)
        cats.append(r.category == cat)
        if baselines:
            if r.gallery_id not in targets:
                targets[r.gallery_id] = prepare_target(
                    model.gallery_cloud(r.gallery_id).astype(np.float64)
                )
            for name, fn in OPEN3D_PIPELINES.items():
                t0 = time.perf_counter()
                T = fn(pts, targets[r.gallery_id])
                o3d_runs[name]['seconds'].append(time.perf_counter() - t0)
                # the baselines register query onto gallery:
                # p_gallery = R' p_query + t' => R = R'^T
                o3d_runs[name]['errors'].append(geodesic_deg(T[:3, :3].T, R))
        errors.append(rows['pcrp']['errors'][-1])
    rows.update(o3d_runs)
    if variants:
        for name, make in VARIANTS.items():
            # a model of its own, loaded afresh: a shared cache of prepared gallery objects
            # would let the variant skip work the default run already paid for
            alt = make(PCRP.load(model_path))
            alt.estimate(queries[0][2])
            rows[name] = {'seconds': [], 'errors': []}
            for gid, cat, pts, R in wrap(
                queries, desc=f'{name} ({n_points} points)', unit='query'
            ):
                t0 = time.perf_counter()
                r = alt.estimate(pts)
                rows[name]['seconds'].append(time.perf_counter() - t0)
                rows[name]['errors'].append(geodesic_deg(r.rotation, R))
    keys = [k for k in STAGES if any(k in s for s in stages)] + sorted(
        {k for s in stages for k in s} - set(STAGES)
    )
    per_stage = {k: _pct([s.get(k, 0.0) for s in stages]) for k in keys}
    summary = {name: {**_pct(v['seconds']), **_errors(v['errors'])} for name, v in rows.items()}
    return {'n': n, 'n_points': n_points, 'threads': os.environ.get('OMP_NUM_THREADS', 'default'),
            'stages': per_stage, 'methods': summary, 'category_accuracy': float(np.mean(cats))}


def _pct(seconds) -> dict:
    s = np.asarray(seconds, dtype=float) * 1e3
    return {'median_ms': float(np.median(s)), 'p95_ms': float(np.percentile(s, 95))}


def _errors(errs) -> dict:
    e = np.asarray(errs, dtype=float)
    return {'err_median': float(np.median(e)), 'err_mean': float(e.mean()),
            'under_5': float(np.mean(e < 5)), 'under_10': float(np.mean(e < 10))}


def queries_in_subprocess(
    model_path,
    data,
    n,
    n_points,
    seed,
    single_thread: bool,
    baselines: bool,
    variants: bool = False,
) -> dict:
    """Thread counts are fixed when numpy and Open3D load, so each setting gets its own process."""
    env = dict(os.environ, TQDM_DISABLE='1')
    if single_thread:
        env.update({v: '1' for v in THREAD_VARS})
    with tempfile.NamedTemporaryFile(suffix='.json', delete=False) as f:
        out = Path(f.name)
    cmd = [
        sys.executable,
        '-m',
        'tools.bench',
        '_queries',
        str(model_path),
        str(data),
        str(n),
        str(n_points),
        str(seed),
        '1' if baselines else '0',
        '1' if variants else '0',
        str(out),
    ]
    r = subprocess.run(
        cmd, env=env, capture_output=True, text=True, cwd=Path(__file__).resolve().parents[1]
    )
    if r.returncode:
        raise RuntimeError(f'query benchmark failed: {r.stderr[-2000:]}')
    result = json.loads(out.read_text())
    out.unlink()
    result['threads'] = '1' if single_thread else 'default'
    return result


# -- scale ----------------------------------------------------------------------------------------
def bench_scale(data: Path, sizes, seed: int, n_queries: int = 20, progress=print) -> list[dict]:
    """
    Return retrieval time and model size against galleries of all 40 categories.

    The galleries are drawn from the train split of all 40 categories (the largest is all of it,
    9,843 objects). Models are cached under the code that builds them, as the YCB model is:
    building the largest takes a while.
    """
    from pcrp_core import PCRP
    from pcrp_core.model_io import model_size
    from pcrp_core.sources import GalleryObject

    archives = sorted(data.glob('*.npz'))
    everything = []
    for a in archives:
        with np.load(a, allow_pickle=False) as f:
            everything += [
                (str(n), a.stem, p) for n, p in zip(f['train_names'], f['train_points'])
            ]
    rng = np.random.default_rng(seed)
    queries = query_set(data, n_queries, 1024, seed)
    rows = []
    key = code_key()
    for size in sizes:
        size = min(size, len(everything))
        path = CACHE / f'gallery_{size}_seed{seed}_{key}'
        # drawn whether or not the gallery is cached, so each size gets the same objects
        # however many of the others were built already
        pick = (
            np.sort(rng.choice(len(everything), size, replace=False))
            if size < len(everything)
            else range(size)
        )

        def build():
            objs = [
                GalleryObject(everything[i][0], everything[i][1], everything[i][2]) for i in pick
            ]
            progress(f'bench: building a {size}-object gallery (cached in {path})')
            PCRP.build(
                objs, seed=seed, sources=[f'{len(archives)} ModelNet40 archives, {size} objects']
            ).save(path)

        built = built_once(path, build)['seconds']
        model = PCRP.load(path)
        model.retrieve(queries[0][2])
        t_all, t_search = [], []
        for _, _, pts, _ in queries:
            t0 = time.perf_counter()
            model.retrieve(pts, k=10)
            t_all.append(time.perf_counter() - t0)
            vec = model.gallery.vectors[0]
            t0 = time.perf_counter()
            model.gallery.search(vec, 10)
            t_search.append(time.perf_counter() - t0)
        rows.append(
            {
                'objects': size,
                'retrieve': _pct(t_all),
                'search': _pct(t_search),
                'bytes': model_size(path),
                'parts': model.size_report(),
                'build_seconds': built,
            }
        )
    return rows


# -- the node -------------------------------------------------------------------------------------
def bench_node(
    model_path: str | None,
    topic_counts,
    duration: float,
    rate: float,
    processes=(1,),
    progress=print,
    driver_profile=None,
    workers: int = 1,
    scene: str | None = None,
) -> list:
    from tools import soak
    rows = []
    for n in topic_counts:
        for k in processes if n == max(topic_counts) else (1,):
            r = soak.run(
                duration,
                rate,
                n,
                bad_share=0.0,
                model_path=model_path,
                processes=k,
                progress=progress,
                driver_profile=driver_profile,
                workers=workers,
                scene=scene,
            )
            per = r['per_topic'].values()
            answered = sum(d['answered'] for d in per)
            rows.append(
                {
                    'topics': n,
                    'processes': k,
                    'workers': workers,
                    'rate_hz': rate,
                    'duration_s': duration,
                    'results_per_s': answered / duration,
                    'age_p50_ms': float(
                        np.median([d['age_p50_ms'] for d in r['per_topic'].values()])
                    ),
                    'age_p95_ms': max(d['age_p95_ms'] for d in r['per_topic'].values()),
                    'dropped': sum(d['dropped_stale'] for d in r['per_topic'].values()),
                    'received': sum(d['received'] for d in r['per_topic'].values()),
                    'sent': sum(d['sent_good'] + d['sent_bad'] for d in r['per_topic'].values()),
                    'refused': sum(d['rejected'] for d in r['per_topic'].values()),
                    'rss_start_mb': r['rss_warm_mb'],
                    'rss_end_mb': r['rss_end_mb'],
                    'rss_growth': r['rss_growth_after_warmup'],
                    'passed': r['passed'],
                    'driver_profile': r['driver_profile'],
                    'scene': scene,
                    **({k: sum(d[k] for d in per) for k in ('scene_used', 'scene_missing')}
                       if scene else {}),
                }
            )
    return rows


# -- the report -----------------------------------------------------------------------------------
def _count(row: dict, key: str) -> str:
    """row[key] as a count, or '-' for runs that did not record it."""
    return f'{row[key]:.0f}' if key in row else '-'


def _lost(row: dict) -> str:
    """Clouds sent that the node never received, or '-' for runs that did not count them."""
    return f"{row['sent'] - row['received']:.0f}" if 'sent' in row else '-'


TARGETS = [
    (
        'one query, end to end, single-threaded',
        'median at most 100 ms and p95 at most 200 ms, and a median no slower '
        'than Open3D FPFH + RANSAC + ICP registering to the same gallery object',
    ),
    ('building the four-category model', 'under 3 minutes; under 10 MB plus the gallery clouds'),
    (
        'node, one topic at 10 Hz',
        '95th percentile age at publication at most 250 ms; memory flat within 10 %',
    ),
    (
        'one camera view of a known object (YCB), single-threaded',
        'median at most 100 ms, p95 at most 200 ms, no slower than Open3D FPFH + RANSAC + ICP '
        'told the object',
    ),
    (
        'node on the shipped model, one topic at 10 Hz and four at 2 Hz',
        '95th percentile age at publication at most 250 ms and nothing dropped, with a worker '
        'per core',
    ),
    (
        "node on the shipped model, each cloud with the camera's depth image as its scene",
        'the same, with the whole frame in reach of every object',
    ),
]


def _driver_note(rows) -> str:
    """Say which Fast DDS profile the clouds of these node runs were published with."""
    profiles = {r.get('driver_profile', '-') for r in rows}
    if profiles == {None}:
        return 'The clouds were published on Fast DDS defaults.'
    if len(profiles) == 1 and '-' not in profiles:
        return (f'The driver, standing for the segmenter, published them with config/'
                f'{profiles.pop()}, as docs/node.md advises (on Fast DDS defaults a burst of '
                "four camera clouds overflows the publisher's 512 KB shared-memory segment and "
                'about one in six is lost before any subscriber sees it); the node ran on Fast '
                'DDS defaults.')
    return 'Which Fast DDS profile the clouds were published with was not recorded.'


SCENE_NAMES = {None: 'none', 'depth_image': 'depth image', 'points': 'depth cloud'}


def _scene_note(rows) -> list[str]:
    """Say what the node runs with a scene sent, and how many clouds were estimated with it."""
    with_scene = [r for r in rows if r.get('scene')]
    if not with_scene:
        return []
    used = sum(r['scene_used'] for r in with_scene)
    counted = used + sum(r['scene_missing'] for r in with_scene)
    return [
        "Scene: the camera's whole depth frame on `scene_topics`, so that surface something in "
        'front of an object hides is not counted missing (docs/node.md, Scenes): before each '
        "tick's objects (30 ms, which count in their age) the driver publishes a 640 x 480 frame "
        'with every pixel in reach of the objects (a table 5 cm behind them: the most a frame '
        'can cost), as a depth image with its CameraInfo (16UC1, 0.6 MB; `scene_type: '
        'depth_image`) or as an organized depth cloud (3.7 MB; `scene_type: points`). '
        f'{used:.0f} of the {counted:.0f} clouds estimated in those runs had their frame.',
        '',
    ]


def _fmt_ms(d) -> str:
    return f"{d['median_ms']:.0f} / {d['p95_ms']:.0f}"


def report(res: dict, command: str, out_dir=None) -> str:
    m = res['machine']
    L = [
        '# Benchmarks: speed, memory and scale',
        '',
        f"Regenerate with `{command}`. Measured {m['date']} on {m['cores']} cores ({m['cpu']}), "
        f"{m['memory_gb']} GB, Python {m['python']}; "
        + ', '.join(f'{k} {v}' for k, v in m['versions'].items())
        + '. All figures are from this run.',
        '',
    ]
    if 'load_start' in m:
        # other work on the machine lengthens every time here; say how busy it was
        end = f" and {m['load_end']} at the end" if 'load_end' in m else ''
        L += [f"Load average {m['load_start']} at the start{end}, on {m['cores']} cores.", '']
    L += ['## Targets', '', '| target | required | measured | met |', '|---|---|---|---|']
    L += [
        f"| {name} | {need} | {res['verdicts'][name][0]} | "
        f"{'yes' if res['verdicts'][name][1] else '**no**'} |"
        for name, need in TARGETS
        if name in res['verdicts']
    ]
    L += ['']
    L += why_unmet(res)
    if res.get('views'):
        from tools import bench_views
        L += bench_views.section(res['views'])
    if res.get('node_shipped'):
        L += [
            '## The node on the shipped model',
            '',
            'The node as `make demo` runs it (the household gallery, clouds from a camera), over '
            'DDS on loopback, with its default one worker and with a worker per core (`workers: '
            '2`, what docs/node.md advises; chosen on camera views of another seed):',
            '',
            '| topics x rate | workers | scene | answered per s | age p50 / p95 ms '
            '| dropped stale | lost on the way | memory MB |',
            '|---|---|---|---|---|---|---|---|',
        ]
        L += [
            f"| {r['topics']} x {r['rate_hz']:g} Hz | {r.get('workers', 1)} | "
            f"{SCENE_NAMES[r.get('scene')]} | {r['results_per_s']:.1f} | "
            f"{r['age_p50_ms']:.0f} / {r['age_p95_ms']:.0f} | {r['dropped']:.0f} | "
            f'{_lost(r)} | {r["rss_start_mb"]:.0f} -> {r["rss_end_mb"]:.0f} |'
            for r in res['node_shipped']
        ]
        L += ['', 'Lost on the way: clouds sent over best-effort DDS that never reached the node. '
              + _driver_note(res['node_shipped'])]
        L += ['']
        L += _scene_note(res['node_shipped'])
    if res.get('build'):
        b = res['build']
        L += [
            '## Building the four-category ModelNet40 model',
            '',
            f"`pcrp build` on the train splits of {', '.join(CATEGORIES)} ({b['objects']} "
            f"objects): **{b['seconds'] / 60:.1f} min** wall, peak resident memory "
            f"{b['peak_mb']:.0f} MB (build process and its workers together), "
            f"{b['bytes'] / 1e6:.1f} MB on disk ({b['parts']}). The paper: under 30 minutes, 230 "
            'kB of kernels plus 1.6 MB of VLAD vectors and codebook.',
            '',
        ]
    for q in res.get('queries', []):
        L += [
            f"## One query: {q['n_points']}-point clouds, "
            f"{'one thread' if q['threads'] == '1' else 'default threads'}",
            '',
            f"{q['n']} ModelNet40 test objects (the four categories in turn) under uniformly "
            'random rotations, '
            f"against the four-category model. Category right: {q['category_accuracy']:.0%}.",
            '',
            '| stage | what | median / p95 ms |',
            '|---|---|---|',
        ]
        L += [f"| {k} | {STAGES.get(k, '')} | {_fmt_ms(v)} |" for k, v in q['stages'].items()]
        L += [
            '',
            '| method | median / p95 ms | rotation error median / mean | < 5° | < 10° |',
            '|---|---|---|---|---|',
        ]
        for name, v in q['methods'].items():
            L.append(
                f"| {name} | {_fmt_ms(v)} | {v['err_median']:.1f}° / {v['err_mean']:.1f}° | "
                f"{v['under_5']:.0%} | {v['under_10']:.0%} |"
            )
        L += ['']
    if res.get('scale'):
        L += [
            '## Scale: galleries drawn from all 40 categories',
            '',
            '| gallery objects | retrieval (features + search) median / p95 ms | search alone '
            'median / p95 ms | model on disk | parts |',
            '|---|---|---|---|---|',
        ]
        L += [
            f"| {r['objects']} | {_fmt_ms(r['retrieve'])} | {r['search']['median_ms']:.2f} / "
            f"{r['search']['p95_ms']:.2f} | {r['bytes'] / 1e6:.1f} MB | {r['parts']} |"
            for r in res['scale']
        ]
        L += [''] + _scale_growth(res['scale'])
    if out_dir is not None and (Path(out_dir) / GROWTH_PLOT).exists():
        L += [
            '## How the cost grows, plotted',
            '',
            'Median times above against the gallery and the cloud, log-log, each series with '
            'its fitted slope (0: flat, 1: linear):',
            '',
            f'![How the cost grows]({GROWTH_PLOT})',
            '',
        ]
    if res.get('node'):
        L += [
            '## The node under load, over DDS on loopback',
            '',
            'Clouds (one-sided views of gallery objects) published at the rate shown on each '
            'topic; the topics take turns, and the oldest cloud waiting on a topic is dropped as '
            'stale when a newer one finds its queue full (`queue_size`).',
            '',
            '| topics | node processes | poses published/s | refused (fit) | '
            'age at publication p50 / p95 ms | dropped / received | lost on the way | '
            'memory start → end (MB) | checks |',
            '|---|---|---|---|---|---|---|---|---|',
        ]
        L += [
            f"| {r['topics']} at {r['rate_hz']:g} Hz | {r['processes']} | "
            f"{r['results_per_s']:.2f} | {_count(r, 'refused')} | "
            f"{r['age_p50_ms']:.0f} / {r['age_p95_ms']:.0f} | "
            f"{r['dropped']:.0f} / {r['received']:.0f} | {_lost(r)} | {r['rss_start_mb']:.0f} → "
            f"{r['rss_end_mb']:.0f} ({100 * r['rss_growth']:+.1f} %) | "
            f"{'pass' if r['passed'] else 'FAIL'} |"
            for r in res['node']
        ]
        L += ['', _driver_note(res['node']), '']
    L += res.get('notes', [])
    return '\n'.join(L) + '\n'


def _scale_growth(rows: list[dict]) -> list[str]:
    """How search time, build time and size grow with the ModelNet40 galleries."""
    if len(rows) < 2:
        return []
    n = [r['objects'] for r in rows]
    search = slope(n, [r['search']['median_ms'] for r in rows])
    retrieve = slope(n, [r['retrieve']['median_ms'] for r in rows])
    L = [
        f'Log-log slope of the search alone {search:.2f}, of the whole retrieval {retrieve:.2f} '
        '(0: flat, 1: linear). Building, on every core: the calibration of the confidence answers '
        'a fixed number of objects (category/calibration.py), so a small gallery pays more per '
        'object.',
        '',
        '| gallery objects | build s in all (per object) | model kB per object |',
        '|---|---|---|',
    ]
    for r in rows:
        built = r.get('build_seconds')
        per_object = f"{built:.0f} ({built / r['objects']:.2f})" if built else 'cached'
        L.append(f"| {r['objects']} | {per_object} | {r['bytes'] / r['objects'] / 1e3:.1f} |")
    return L + ['']


def why_unmet(res: dict) -> list[str]:
    """Plain reasons for each target missed, from this run's own figures."""
    out = []
    v = res.get('verdicts', {})

    def missed(k: int) -> bool:
        return not v.get(TARGETS[k][0], (None, True))[1]
    single = [q for q in res.get('queries', []) if q['threads'] == '1' and q['n_points'] == 1024]
    st = single[0]['stages'] if single else {}
    reg, tot = st.get('registration', {}).get('median_ms', 0), st.get('total', {}).get(
        'median_ms', 0
    )
    if single and missed(0):
        from pcrp_core.config import PoseOptions

        survivors = PoseOptions().vote_survivors
        out.append(
            f'**Why a query misses its target.** {reg:.0f} of its {tot:.0f} ms are registration: '
            'hypotheses from each of the retrieved candidates (principal axes and half turns, '
            'each with a short ICP; RANSAC too where retrieval finds a near twin) and the vote '
            'that refines them on every candidate, briefly and then the best '
            f'{survivors} in full.'
            + _what_time_buys(single[0]['methods'])
        )
    if res.get('node') and missed(2):
        out.append(
            "**Why the node's answers are older than 250 ms.** One worker answers the newest "
            'cloud of each topic: a cloud that arrives while another is being answered waits for '
            'it, so its age at publication is its own processing time plus up to one more. With a '
            f'query near {tot:.0f} ms that lands between {tot:.0f} and {2 * tot:.0f} ms. A second '
            'process on this 2-core machine does not help, because the publishing side and DDS '
            'share the same two cores; on a machine with cores to spare, '
            '`launch/pcrp_scaled.launch.py` spreads the topics over processes.'
        )
    shipped = [r for r in res.get('node_shipped', []) if r['topics'] > 1 and not r.get('scene')]
    views = res.get('views', {}).get('views', {}).get('free', {}).get('pcrp')
    if shipped and views and missed(4):
        ages = ', '.join(f"{r['age_p95_ms']:.0f} ms with {r.get('workers', 1)} worker"
                         f"{'s' if r.get('workers', 1) > 1 else ''}" for r in shipped)
        med, p95 = views['median_ms'], views['p95_ms']
        out.append(
            '**Why the node on the shipped model misses with four topics.** The four clouds of '
            'a tick arrive together, so with two workers two of them first wait for an answer: '
            'their age is about one query and another. Camera views take '
            f'{med:.0f} ms median and {p95:.0f} ms p95 here (the YCB views below), so the slowest '
            f'of them land near {med + p95:.0f} ms before DDS and the driver, which share the '
            f'same two cores, add theirs; measured p95 age {ages}. One topic at 10 Hz has no '
            'such wait. Only a faster query closes the gap.'
        )
    scened = [r for r in res.get('node_shipped', []) if r.get('scene') == 'depth_image']
    if scened and missed(5):
        ages = ', '.join(f"{r['age_p95_ms']:.0f} ms at {r['topics']} x {r['rate_hz']:g} Hz"
                         for r in scened)
        out.append(
            "**Why the node misses with the camera's depth image.** Each frame crosses DDS and is "
            'cut in the node process to what is in reach of its objects, and each worker reads '
            'its window of it, on the same two cores that answer and that the driver publishes '
            f'from; measured p95 age {ages}. A frame with less in reach of the objects (a farther '
            'background) costs less.'
        )
    return [line for o in out for line in (o, '')]


def _what_time_buys(methods: dict) -> str:
    """
    Return the cheaper configurations measured on the same queries (VARIANTS).

    Against the defaults.
    """
    ours, eight, paper = (
        methods['pcrp'],
        methods.get('pcrp_8_candidates'),
        methods.get('pcrp_paper'),
    )
    if not eight or not paper:
        return ''
    text = (
        " On these same queries the paper's bare method (one retrieved object, RANSAC only) takes "
        f"{paper['median_ms']:.0f} ms and puts {paper['under_5']:.0%} of poses within 5° (the "
        f"defaults: {ours['under_5']:.0%}); 8 retrieved candidates instead of the default 16 take "
        f"{eight['median_ms']:.0f} ms, with {eight['under_5']:.0%} within 5° and a mean error of "
        f"{eight['err_mean']:.1f}° (the defaults: {ours['err_mean']:.1f}°)."
    )
    if eight['under_5'] < ours['under_5'] or eight['err_mean'] > ours['err_mean']:
        return text + (
            ' So the defaults stay, and a user who needs latency more than accuracy lowers the '
            "node's `n_candidates`."
        )
    return text + ' Here 8 candidates lose nothing: the default of 16 is worth revisiting.'


def verdicts(res: dict) -> dict:
    v = {}
    single = [q for q in res.get('queries', []) if q['threads'] == '1' and q['n_points'] == 1024]
    if single:
        q = single[0]['methods']
        ours, rivals = q['pcrp'], q.get('fpfh_ransac_icp')
        ok = (
            ours['median_ms'] <= 100
            and ours['p95_ms'] <= 200
            and (rivals is None or ours['median_ms'] <= rivals['median_ms'])
        )
        v[TARGETS[0][0]] = (f'{_fmt_ms(ours)} ms median / p95'
                            + (f' (RANSAC + ICP {_fmt_ms(rivals)} ms)' if rivals else ''), ok)
    if res.get('build'):
        b = res['build']
        v[TARGETS[1][0]] = (
            f"{b['seconds'] / 60:.1f} min, {b['bytes'] / 1e6:.1f} MB",
            b['seconds'] < 180,
        )
    one = [r for r in res.get('node', []) if r['topics'] == 1 and r['processes'] == 1]
    if one:
        r = one[0]
        v[TARGETS[2][0]] = (f"{r['age_p95_ms']:.0f} ms, memory {100 * r['rss_growth']:+.1f} %",
                            r['age_p95_ms'] <= 250 and abs(r['rss_growth']) <= 0.10)
    if res.get('views'):
        free = res['views']['views']['free']
        ours, told = free['pcrp'], free['open3d_ransac_told']
        v[TARGETS[3][0]] = (
            f"{ours['median_ms']:.0f} / {ours['p95_ms']:.0f} ms (Open3D told the object "
            f"{told['median_ms']:.0f} ms)",
            ours['median_ms'] <= 100
            and ours['p95_ms'] <= 200
            and ours['median_ms'] <= told['median_ms'],
        )
    shipped = res.get('node_shipped', [])
    for k, scene in ((4, None), (5, 'depth_image')):
        judged = _node_verdict([r for r in shipped if r.get('scene') == scene])
        if judged:
            v[TARGETS[k][0]] = judged
    return v


def _node_verdict(shipped: list[dict]) -> tuple[str, bool] | None:
    """Judge node runs: worst age, drops, losses per worker count; met with a worker per core."""
    said, met = [], False
    for w in sorted({r.get('workers', 1) for r in shipped}):
        rows = [r for r in shipped if r.get('workers', 1) == w]
        worst = max(r['age_p95_ms'] for r in rows)
        dropped = sum(r['dropped'] for r in rows)
        lost = sum(r['sent'] - r['received'] for r in rows if 'sent' in r)
        said.append(f"{w} worker{'s' if w > 1 else ''}: p95 age {worst:.0f} ms, {dropped:.0f} "
                    f'dropped stale, {lost:.0f} lost on the way')
        # several topics are to use both cores: a worker per core is the configuration judged
        met = met or (w == 2 and worst <= 250 and dropped == 0 and lost == 0)
    return ('; '.join(said), met) if shipped else None


def register(sub) -> None:
    p = sub.add_parser(
        'bench', help='measure speed, memory and scale; write docs/results/BENCHMARKS.md'
    )
    p.add_argument(
        '--data',
        default=str(Path(__file__).resolve().parents[2] / 'shared' / 'data' / 'modelnet40'),
    )
    p.add_argument('--out', default='docs/results')
    p.add_argument(
        '--model', default=None, help='four-category model to use instead of building one'
    )
    p.add_argument('--queries', type=int, default=100)
    p.add_argument('--seed', type=int, default=0)
    p.add_argument('--node-seconds', type=float, default=60.0)
    p.add_argument(
        '--driver-profile',
        default=str(LARGE_CLOUDS_PROFILE),
        help="Fast DDS profile the node parts' clouds are published with, as docs/node.md "
        "advises a segmenter; 'none': Fast DDS defaults",
    )
    p.add_argument(
        '--ycb',
        default=str(Path(__file__).resolve().parents[2] / 'shared' / 'data' / 'ycb'),
        help="folder of meshes for the camera views' part (skipped when missing)",
    )
    p.add_argument(
        '--quick', action='store_true', help='a small run of every part, in a few minutes'
    )
    p.set_defaults(func=_bench)


def _bench(args) -> int:
    data = Path(args.data)
    quick = args.quick
    n = 8 if quick else args.queries
    res = {'machine': machine(), 'notes': []}
    say = lambda text: print(text, file=sys.stderr, flush=True)  # noqa: E731
    model = args.model
    if model is None:
        out = CACHE / ('model4_quick' if quick else 'model4')
        say(f'bench: building the four-category model into {out}')
        res['build'] = bench_build(data, out, limit=30 if quick else None)
        model = res['build']['path']
    res['queries'] = []
    for n_points in (1024,) if quick else (1024, 2048):
        for single in (True, False):
            say(
                f'bench: {n} queries of {n_points} points, '
                f"{'one thread' if single else 'default threads'}"
            )
            res['queries'].append(
                queries_in_subprocess(
                    model,
                    data,
                    n,
                    n_points,
                    args.seed,
                    single,
                    True,
                    variants=single and n_points == 1024,
                )
            )
    say('bench: scale')
    res['scale'] = bench_scale(
        data, (30, 100) if quick else (100, 1000, 9843), args.seed, 5 if quick else 20, say
    )
    if Path(args.ycb).is_dir():
        from tools import bench_views
        say('bench: camera views of known objects (YCB)')
        res['views'] = bench_views.run(Path(args.ycb), CACHE, 1, 4 if quick else 12, args.seed)
    say('bench: the node under load')
    profile = None if args.driver_profile == 'none' else args.driver_profile
    res['node'] = bench_node(
        model,
        (1, 2) if quick else (1, 2, 4),
        10.0 if quick else args.node_seconds,
        10.0,
        processes=(1, 2),
        progress=say,
        driver_profile=profile,
    )
    say('bench: the node on the shipped model (camera views of household objects)')
    seconds = 10.0 if quick else args.node_seconds
    # scenes only with a worker per core, the configuration docs/node.md advises with them
    res['node_shipped'] = [
        row
        for workers, scene in ((1, None), (2, None), (2, 'depth_image'), (2, 'points'))
        for topics, rate in ((1, 10.0), (4, 2.0))
        for row in bench_node(None, (topics,), seconds, rate, progress=say,
                              driver_profile=profile, workers=workers, scene=scene)
    ]
    res['verdicts'] = verdicts(res)
    res['machine']['load_end'] = round(os.getloadavg()[0], 1)
    out_dir = Path(args.out)
    out_dir.mkdir(parents=True, exist_ok=True)
    command = 'python -m tools bench' + (' --quick' if quick else '')
    growth_plot(res, out_dir / GROWTH_PLOT)
    (out_dir / 'BENCHMARKS.md').write_text(report(res, command, out_dir))
    (out_dir / 'benchmarks.json').write_text(json.dumps(res, indent=1, default=str))
    print(f"wrote {out_dir / 'BENCHMARKS.md'}")
    return 0


def main(argv=None) -> int:
    """`python -m tools.bench _queries ...`: bench_queries in a fresh process (see above)."""
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] != '_queries':
        print('usage: python -m tools bench [options]', file=sys.stderr)
        return 2
    model_path, data, n, n_points, seed, baselines, variants, out = argv[1:]
    r = bench_queries(
        model_path,
        Path(data),
        int(n),
        int(n_points),
        int(seed),
        baselines == '1',
        variants=variants == '1',
    )
    Path(out).write_text(json.dumps(r))
    return 0


if __name__ == '__main__':
    sys.exit(main())
