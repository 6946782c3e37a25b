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
The camera's case in `python -m tools bench`: how fast known objects are answered view by view.

Where the time goes, and how the cost grows with the gallery and with the cloud.

Per view, single-threaded (one process with OMP_NUM_THREADS=1, as on a robot's shared computer):
pcrp on the YCB test views (seed 0) of `python -m tools robot-report`, and Open3D's FPFH + RANSAC
+ ICP registering the same view to the right object (told it: the least a registration-only
pipeline must do) in the same run. Growth: the gallery replicated to 10 ... 10,000 objects
(templates copied: the answer's cost does not depend on which object a template is of, only on
how many there are) and clouds of 1,000 to 100,000 points (one view resampled).
"""
from __future__ import annotations

import json
import os
from pathlib import Path
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np
from tools.provenance import built_once, code_key

REPO = Path(__file__).resolve().parents[1]
THREADS = {v: '1' for v in ('OMP_NUM_THREADS', 'OPENBLAS_NUM_THREADS', 'MKL_NUM_THREADS')}
GALLERY_SIZES = (10, 100, 1000, 10000)
CLOUD_SIZES = (1000, 3000, 10000, 30000, 100000)


def _pct(seconds) -> dict:
    s = np.asarray(seconds, dtype=np.float64) * 1e3
    return {
        'median_ms': float(np.median(s)),
        'p95_ms': float(np.percentile(s, 95)),
        'n': int(len(s)),
    }


def _rss_mb() -> float:
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def ycb_model(ycb: Path, cache: Path) -> tuple[str, dict]:
    """
    Return the YCB model built as the README says, and what building it cost.

    Cached under the code that builds it (as the robot report's models): a model kept from
    older code would time today's queries on yesterday's gallery.
    """
    path = cache / f'ycb_{code_key()}'

    def build() -> dict:
        subprocess.run(
            [
                sys.executable,
                '-m',
                'pcrp_ros.cli',
                'build',
                str(ycb),
                '--up-axis',
                'z',
                '--out',
                str(path),
            ],
            check=True,
            cwd=REPO,
            capture_output=True,
        )
        from pcrp_core.model_io import model_size
        return {'bytes': model_size(path), 'objects': len(list(ycb.glob('*.ply')))}

    return str(path), built_once(path, build)


def views(model_path: str, ycb: Path, per_kind: int, seed: int = 0) -> dict:
    """
    Time pcrp per view and per stage, and Open3D RANSAC told the object, on the same YCB views.

    Free, and on a table with up known.
    """
    from pcrp_core import PCRP
    from pcrp_core.evaluation.scenes import sample_scene
    from pcrp_core.sources.camera import Mesh
    from tools import robot_open3d as o3d_pipe

    model = PCRP.load(model_path)
    files = sorted(ycb.glob('*.ply'))
    meshes = {f.stem: Mesh.read(f) for f in files}
    out = {}
    for kind in ('free', 'table'):
        ours, stages, theirs, right = [], {}, [], 0
        for i, (gid, mesh) in enumerate(meshes.items()):
            for v in range(per_kind):
                s = sample_scene(mesh, gid, i, v, kind, seed=seed)
                t0 = time.perf_counter()
                r = model.estimate(s.points, viewpoint=np.zeros(3), up=s.up)
                ours.append(time.perf_counter() - t0)
                right += r.gallery_id == gid
                for k, val in r.timings.items():
                    stages.setdefault(k, []).append(val)
                tgt = o3d_pipe.target(mesh)
                t0 = time.perf_counter()
                o3d_pipe.register('ransac', o3d_pipe.query(s.points), tgt)
                theirs.append(time.perf_counter() - t0)
        out[kind] = {'pcrp': _pct(ours), 'stages': {k: _pct(v) for k, v in stages.items()},
                     'open3d_ransac_told': _pct(theirs), 'right_object': right / len(ours)}
    return out


def _replicated(model, n: int):
    """
    Return the model's templates tiled to n objects.

    An answer's cost depends on how many there are, not on which object each is.
    """
    from dataclasses import fields

    from pcrp_core.instance.matcher import InstanceMatcher
    from pcrp_core.instance.templates import Templates

    tpl = model.templates
    reps = np.resize(np.arange(len(tpl)), n)
    return InstanceMatcher(
        Templates(**{f.name: getattr(tpl, f.name)[reps] for f in fields(Templates)})
    )


def growth(model_path: str, ycb: Path, queries: int, seed: int = 0) -> dict:
    """Seconds per view against gallery size and cloud size, and the memory the templates take."""
    from pcrp_core import PCRP
    from pcrp_core.evaluation.scenes import sample_scene
    from pcrp_core.instance.templates import shape_code
    from pcrp_core.sources.camera import Mesh
    from tools.bench_plots import slope

    model = PCRP.load(model_path)
    files = sorted(ycb.glob('*.ply'))[:queries]
    scenes = [
        sample_scene(Mesh.read(f), f.stem, i, 0, 'free', seed=seed) for i, f in enumerate(files)
    ]
    clouds = [model.prepare(s.points) for s in scenes]
    per_object = sum(v.nbytes for v in model.templates.to_arrays().values()) / len(model.templates)
    sizes = []
    for n in GALLERY_SIZES:
        matcher = _replicated(model, n)
        t_all, t_short = [], []
        for c in clouds:
            timings = {}
            t0 = time.perf_counter()
            matcher.match(c, model.instance_options, rng=np.random.default_rng(0), timings=timings)
            t_all.append(time.perf_counter() - t0)
            t0 = time.perf_counter()
            opts = model.instance_options
            matcher.shortlist(shape_code(c), opts)
            t_short.append(time.perf_counter() - t0)
        sizes.append({'objects': n, 'match': _pct(t_all), 'shortlist': _pct(t_short),
                      'template_mb': per_object * n / 1e6})
        del matcher
    points = []
    rng = np.random.default_rng(seed)
    for m in CLOUD_SIZES:
        t_all = []
        for s in scenes:
            p = s.points[rng.choice(len(s.points), m, replace=len(s.points) < m)]
            p = p + rng.normal(scale=2e-4, size=p.shape)   # resampled points, not copies
            t0 = time.perf_counter()
            model.estimate(p, viewpoint=np.zeros(3))
            t_all.append(time.perf_counter() - t0)
        points.append({'points': m, 'estimate': _pct(t_all)})
    return {
        'gallery': sizes,
        'points': points,
        'template_kb_per_object': per_object / 1e3,
        'gallery_slope': slope(
            [r['objects'] for r in sizes], [r['match']['median_ms'] for r in sizes]
        ),
        'shortlist_slope': slope(
            [r['objects'] for r in sizes], [r['shortlist']['median_ms'] for r in sizes]
        ),
        'points_slope': slope(
            [r['points'] for r in points], [r['estimate']['median_ms'] for r in points]
        ),
    }


def run(ycb: Path, cache: Path, per_kind: int, queries: int, seed: int = 0) -> dict:
    """Everything above in a single-threaded subprocess (thread counts are fixed at import)."""
    cache.mkdir(parents=True, exist_ok=True)
    model_path, build = ycb_model(ycb, cache)
    with tempfile.NamedTemporaryFile(suffix='.json', delete=False) as f:
        out = Path(f.name)
    cmd = [
        sys.executable,
        '-m',
        'tools.bench_views',
        model_path,
        str(ycb),
        str(per_kind),
        str(queries),
        str(seed),
        str(out),
    ]
    r = subprocess.run(
        cmd,
        env={**os.environ, **THREADS, 'TQDM_DISABLE': '1'},
        cwd=REPO,
        capture_output=True,
        text=True,
    )
    if r.returncode:
        raise RuntimeError(f'camera-view benchmark failed: {r.stderr[-2000:]}')
    res = json.loads(out.read_text())
    out.unlink()
    res['build'] = build
    return res


def section(res: dict) -> list[str]:
    """BENCHMARKS.md's part on camera views."""
    b = res['build']
    L = [
        '## Known objects from a depth camera: YCB views, one thread',
        '',
        f'The 78 YCB meshes built as the README says (`pcrp build <ycb> --up-axis z`): '
        f"{b['seconds']:.0f} s on every core, {b['bytes'] / 1e6:.1f} MB on disk "
        f"({b['seconds'] / b['objects']:.1f} s and "
        f"{b['bytes'] / b['objects'] / 1e3:.0f} kB per object). "
        "Views of the robot report's test seed; Open3D FPFH + RANSAC + ICP registers each view "
        'to the right object (told it) in the same run.',
        '',
        '| views | pcrp median / p95 ms | Open3D RANSAC + ICP, told the object | right object |',
        '|---|---|---|---|',
    ]
    for kind, r in res['views'].items():
        L.append(
            f"| {kind} ({r['pcrp']['n']}) | "
            f"{r['pcrp']['median_ms']:.0f} / {r['pcrp']['p95_ms']:.0f} | "
            f"{r['open3d_ransac_told']['median_ms']:.0f} / "
            f"{r['open3d_ransac_told']['p95_ms']:.0f} | "
            f"{r['right_object']:.0%} |"
        )
    L += ['', 'Where the time goes (median / p95 ms per stage, as `/diagnostics` reports it):', '',
          '| stage | ' + ' | '.join(res['views']) + ' |', '|---|' + '---|' * len(res['views'])]
    stages = list(next(iter(res['views'].values()))['stages'])
    for s in stages:
        L.append(
            f'| {s} | '
            + ' | '.join(
                (
                    f"{r['stages'][s]['median_ms']:.1f} / {r['stages'][s]['p95_ms']:.1f}"
                    if s in r['stages']
                    else '-'
                )
                for r in res['views'].values()
            )
            + ' |'
        )
    g = res['growth']
    L += [
        '',
        '### How the cost grows',
        '',
        f"Against the gallery's size (templates replicated; "
        f"{g['template_kb_per_object']:.0f} kB of templates per object in memory); "
        f"log-log slope {g['gallery_slope']:.2f} for a whole answer (0: flat, 1: linear), "
        f"{g['shortlist_slope']:.2f} for the shortlist, the only step that looks "
        'at every object (a scan of every view up to 20,000 views, a KD-tree of them beyond: '
        'pcrp_core/instance/shape_index.py):',
        '',
        '| objects | answer median / p95 ms | shortlist median ms | templates MB |',
        '|---|---|---|---|',
    ]
    L += [f"| {r['objects']:,} | {r['match']['median_ms']:.0f} / {r['match']['p95_ms']:.0f} | "
          f"{r['shortlist']['median_ms']:.2f} | {r['template_mb']:.0f} |" for r in g['gallery']]
    L += [
        '',
        f"Against the points in the cloud (log-log slope {g['points_slope']:.2f}: the cloud is "
        'thinned to 1,024 points first, so only that step grows):',
        '',
        '| points | median / p95 ms |',
        '|---|---|',
    ]
    L += [f"| {r['points']:,} | {r['estimate']['median_ms']:.0f} / {r['estimate']['p95_ms']:.0f} |"
          for r in g['points']]
    return L + ['']


def main(argv) -> int:
    model_path, ycb, per_kind, queries, seed, out = argv
    res = {'views': views(model_path, Path(ycb), int(per_kind), int(seed)),
           'growth': growth(model_path, Path(ycb), int(queries), int(seed)), 'rss_mb': _rss_mb()}
    Path(out).write_text(json.dumps(res))
    return 0


if __name__ == '__main__':
    sys.exit(main(sys.argv[1:]))
