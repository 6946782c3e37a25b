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
The `pcrp` command line: build | query | eval (core).

make-bag | replay | process | demo are added by pcrp_ros.

Each subcommand lives in a `register(subparsers)` function that adds its parser and sets
`func` to a handler taking the parsed args and returning an exit code. Heavy imports stay
inside handlers so `pcrp --help` is instant.
"""
from __future__ import annotations

import argparse
import json
import math
from pathlib import Path
import re
import sys
import time

# Options whose values may start with a minus (an axis "-y", a vector "-1,0,0"). argparse takes
# such a value for an option of its own unless it is written "--up=-1,0,0"; joined before parsing,
# "--up -1,0,0" works as a user would type it.
SIGNED_OPTIONS = ('--up', '--up-axis', '--viewpoint')
_SIGNED_VALUE = re.compile(r'-(?:[xyz]|[\d.][\d.,eE+-]*)')


def _progress(it, **kw):
    from tqdm import tqdm
    if not sys.stderr.isatty():
        # tqdm draws nothing into a log or a pipe, where a build then said nothing for minutes:
        # a line as each stage starts says it is alive and where
        print(f"pcrp: {kw.get('desc', 'working')}...", file=sys.stderr, flush=True)
    return tqdm(it, leave=False, file=sys.stderr, disable=None, **kw)


def _fail(message: str) -> int:
    print(f'pcrp: error: {message}', file=sys.stderr)
    return 2


def register_build(sub) -> None:
    p = sub.add_parser(
        'build',
        help='build a gallery model from ModelNet40 archives, mesh/cloud folders or the generator',
        description='Build a model: fit FR-PointHop and the VLAD codebook on the gallery objects, '
        'describe every object, and save the model directory.',
    )
    p.add_argument(
        'sources',
        nargs='+',
        help='ModelNet40 archive (chair.npz), folder with one sub-folder per '
        'category of meshes/clouds, or procedural[:N]',
    )
    p.add_argument('--out', required=True, help='model directory to write')
    p.add_argument(
        '--split', default='train', choices=['train', 'test'], help='archive split (default train)'
    )
    p.add_argument(
        '--n-points', type=int, default=1024, help='points per gallery object (default 1024)'
    )
    p.add_argument(
        '--hop1',
        default='fpfh',
        choices=['fpfh', 'octant'],
        help='first-hop attribute: FPFH (FR-PointHop, default) or octant coordinates (R-PointHop)',
    )
    p.add_argument(
        '--aggregation',
        default='vlad',
        choices=['vlad', 'max'],
        help='global descriptor (default vlad)',
    )
    p.add_argument('--clusters', type=int, default=10, help='VLAD codebook size (default 10)')
    p.add_argument(
        '--views',
        type=int,
        default=0,
        help='also describe this many one-sided views per object, for depth-camera queries '
        '(default 0)',
    )
    p.add_argument(
        '--limit', type=int, default=None, help='at most this many objects per source category'
    )
    p.add_argument('--seed', type=int, default=0)
    p.add_argument(
        '--jobs',
        type=int,
        default=None,
        help='processes describing objects (default: one per core)',
    )
    p.add_argument(
        '--scale',
        type=float,
        default=None,
        metavar='FACTOR',
        help='multiply every object by this first: 0.001 for meshes in millimetres (meshes are '
        'read as metres, and a mesh gallery whose largest object is over 5 m across is refused '
        'until its scale is given); kept in the model, so `pcrp eval` scales the meshes alike',
    )
    p.add_argument(
        '--up-axis',
        default=None,
        choices=['x', 'y', 'z', '-x', '-y', '-z'],
        help="the objects' up axis in their own frame, so queries may state which way is up "
        '(default: what the sources say: z for ModelNet40 and the generator, none for folders)',
    )
    p.set_defaults(func=_build)


def _build(args) -> int:
    from pcrp_core import PCRP
    from pcrp_core.model_io import model_size
    from pcrp_core.geometry import axis_name
    from pcrp_core.sources import load_sources
    from pcrp_core.sources.units import scaled, unit_problem

    if args.scale is not None and not (math.isfinite(args.scale) and args.scale > 0):
        return _fail(f'--scale {args.scale:g}: expected a positive factor (0.001 for millimetres)')
    t0 = time.perf_counter()
    try:
        objects = load_sources(
            args.sources,
            split=args.split,
            n_points=args.n_points,
            seed=args.seed,
            limit_per_category=args.limit,
        )
    except (OSError, ValueError) as e:
        return _fail(str(e))
    if args.scale is not None:
        objects = scaled(objects, args.scale)
    if problem := unit_problem(objects, args.scale):
        return _fail(f"{' '.join(args.sources)}: {problem}")
    out = Path(args.out)
    if out.exists() and not out.is_dir():
        return _fail(f'--out {out}: a file is there; a model is a directory')
    print(
        f'{len(objects)} objects in {len({o.category for o in objects})} categories; fitting...',
        file=sys.stderr,
    )
    try:
        model = PCRP.build(
            objects,
            hop1=args.hop1,
            n_clusters=args.clusters,
            aggregation=args.aggregation,
            n_points=args.n_points,
            views=args.views,
            seed=args.seed,
            sources=args.sources,
            progress=_progress,
            n_jobs=args.jobs,
            up_axis=args.up_axis,
        )
    except RuntimeError as e:   # a mesh no view of which shows enough of it (evaluation/scenes.py)
        return _fail(f"{' '.join(args.sources)}: {e}")
    if args.scale is not None:
        model.meta['mesh_scale'] = args.scale   # what `pcrp eval` multiplies the meshes by
    model.save(args.out)
    size = model_size(args.out)
    print(
        f"built {args.out}: {len(objects)} objects, categories {', '.join(model.categories)}, "
        f'feature dimension {model.pointhop.n_features_}, '
        f'descriptor dimension {model.gallery.vectors.shape[1]}, '
        f'{time.perf_counter() - t0:.1f} s, {size / 1e6:.2f} MB on disk '
        f'({model.size_report()}); '
        + (
            f'up axis {axis_name(model.up_axis)}'
            if model.up_axis is not None
            else 'no up axis recorded (--up-axis to give one)'
        )
    )
    return 0


def register_query(sub) -> None:
    p = sub.add_parser('query', help='retrieve the gallery object and its pose for one cloud file')
    p.add_argument('model', help="model directory ('default' for the shipped one)")
    p.add_argument('cloud', help='cloud file: PLY, PCD, XYZ or NPY (N, 3); meshes are sampled')
    p.add_argument('--json', action='store_true', help='print the result as JSON')
    p.add_argument(
        '--candidates',
        type=int,
        default=None,
        help='gallery objects to verify (n_candidates, and n_candidates_view for views)',
    )
    p.add_argument(
        '--min-confidence',
        type=float,
        default=None,
        help='reject answers less confident than this',
    )
    p.add_argument(
        '--min-score', type=float, default=None, dest='min_confidence', help=argparse.SUPPRESS
    )
    p.add_argument(
        '--up',
        default=None,
        metavar='X,Y,Z',
        help="which way is up in the cloud's frame, if known: the search for a pose then keeps "
        'the object upright within --up-tolerance (refinement follows the cloud)',
    )
    p.add_argument('--up-tolerance', type=float, default=None, metavar='DEG',
                   help='how far an answer may tip the object from --up (default 60)')
    p.add_argument(
        '--viewpoint',
        default=None,
        metavar='X,Y,Z',
        help="where the sensor was in the cloud's frame, when the cloud is one sensor's view "
        "(0,0,0 for a cloud in the camera's own frame, as a depth driver publishes it)",
    )
    add_settings_option(p)
    p.set_defaults(func=_query)


def _query(args) -> int:
    from pcrp_core import InvalidCloud, ModelError, PCRP
    from pcrp_core.sources.folder import read_points

    try:
        model = PCRP.load(None if args.model == 'default' else args.model)
    except ModelError as e:
        return _fail(str(e))
    try:
        points = read_points(args.cloud)
    except (OSError, ValueError) as e:
        return _fail(f'{args.cloud}: {e}')
    opts = {
        k: v
        for k, v in (
            ('n_candidates', args.candidates),
            ('n_candidates_view', args.candidates),
            ('min_confidence', args.min_confidence),
            ('up_tolerance_deg', args.up_tolerance),
        )
        if v is not None
    }
    try:
        # the named options win over the same settings given by --set
        model.set_params(**{**parse_settings(args.settings), **opts})
    except ValueError as e:
        return _fail(str(e))
    try:
        up = parse_up(args.up)
        viewpoint = parse_up(args.viewpoint, '--viewpoint')
        result = model.estimate(points, viewpoint=viewpoint, up=up)
    except (InvalidCloud, ValueError) as e:
        return _fail(f'{args.cloud}: {e}')
    if result.rejected and viewpoint is None and model.templates is not None:
        # the node's default (sensor_at_origin); here the cloud may as well be a whole object
        print('pcrp query: hint: a cloud one depth camera saw, in its own frame, is answered '
              'as one with --viewpoint 0,0,0, as the node answers it', file=sys.stderr)
    if args.json:
        print(json.dumps(result.to_dict(), indent=1))
        return 0
    print(format_result(result))
    return 0


def register_eval(sub) -> None:
    p = sub.add_parser(
        'eval',
        help='how good a model is on your own meshes, seen by a simulated depth camera',
        description='Render seeded depth-camera views of every mesh in a folder (metres; 640x480, '
        'f=600, range noise growing with depth; perfectly segmented), answer them with the '
        'model as the node would, and print per-family and overall rates: right object, '
        'pose right (ADD-S < 10 % of the diameter), ADD-S AUC, error medians, wrong answers '
        'accepted, right ones rejected, time per view.',
    )
    p.add_argument(
        'meshes',
        help='folder of meshes in metres, as given to `pcrp build` (one object per file, or '
        'one sub-folder per category)',
    )
    p.add_argument('--model', required=True,
                   help="model directory built from those meshes ('default' for the shipped one)")
    p.add_argument(
        '--views-per-object', type=int, default=2, help='views drawn per mesh (default 2)'
    )
    p.add_argument(
        '--kind',
        default='free',
        choices=['free', 'table'],
        help='free: any orientation in front of the camera; table: standing on its z axis, the '
        'camera looking down at 25-65 degrees (default free)',
    )
    p.add_argument(
        '--occlusion',
        action='store_true',
        help="a box or cylinder hides 20-60 %% of each object's pixels",
    )
    p.add_argument(
        '--scene',
        action='store_true',
        help='with --occlusion: give the model what the camera measured of the occluder too, as '
        'the node does with scene_topics',
    )
    p.add_argument(
        '--up',
        action='store_true',
        help="tell the model which way is up (the table's normal); needs --kind table and a model "
        'built with --up-axis',
    )
    p.add_argument(
        '--seed',
        type=int,
        default=0,
        help='seed of the views (default 0); views of seed S are the same '
        'whatever else is drawn',
    )
    p.add_argument(
        '--json',
        default=None,
        metavar='FILE',
        help='also write the summary and per-view records here',
    )
    add_settings_option(p)
    p.set_defaults(func=_eval)


def _eval(args) -> int:
    from pcrp_core import ModelError, PCRP
    from pcrp_core.evaluation.run import (evaluate, format_summary, format_unknown, jsonable,
                                          summarise, unknown_statistics)
    from pcrp_core.evaluation.scenes import sample_scenes
    from pcrp_core.sources import load_source
    from pcrp_core.sources.units import scaled, unit_problem

    if args.views_per_object < 1:
        return _fail('--views-per-object must be at least 1')
    if args.up and args.kind != 'table':
        return _fail('--up needs --kind table: free views have no up')
    try:
        model = PCRP.load(None if args.model == 'default' else args.model)
        model.set_params(**parse_settings(args.settings))
    except (ModelError, ValueError) as e:
        return _fail(str(e))
    if args.up:
        try:
            model.check_up([0.0, 0.0, 1.0])
        except ValueError as e:
            return _fail(str(e))
    try:
        objects = load_source(args.meshes)
    except (OSError, ValueError) as e:
        return _fail(str(e))
    scale = model.meta.get('mesh_scale')
    if scale is not None:
        objects = scaled(objects, scale)
        print(f'pcrp eval: meshes multiplied by {scale:g}, as the model was built',
              file=sys.stderr)
    if problem := unit_problem(objects, scale, 'give the meshes in the units the model was '
                               'built from (the scale a model was built with applies here too)'):
        return _fail(f'{args.meshes}: {problem}')
    meshes = {o.gallery_id: o.mesh for o in objects if o.mesh is not None}
    skipped = [o.gallery_id for o in objects if o.mesh is None]
    if skipped:
        print(
            f'pcrp eval: {len(skipped)} clouds skipped (a view is rendered from a mesh): '
            f"{', '.join(skipped[:5])}",
            file=sys.stderr,
        )
    if not meshes:
        return _fail(f'{args.meshes}: no meshes to render')
    unknown = [g for g in meshes if g not in model.gallery.index]
    if unknown:
        print(
            f"pcrp eval: {len(unknown)} of the meshes are not in the model's gallery, "
            'so can never be named (their views measure how often it refuses what it lacks): '
            f"{', '.join(unknown[:5])}",
            file=sys.stderr,
        )
    try:
        # the gallery's objects are drawn the views they get without the others beside them
        order = [g for g in meshes if g not in unknown] + unknown
        scenes = sample_scenes(
            meshes, args.views_per_object, args.kind, args.occlusion, args.seed,
            indices={g: i for i, g in enumerate(order)}, progress=_progress
        )
    except RuntimeError as e:
        return _fail(str(e))
    rows = evaluate(model, scenes, meshes, use_up=args.up, progress=_progress,
                    use_scene=args.scene)
    # the gallery's objects are scored as they are; those it lacks only by what it refuses
    known = [r for r in rows if r['object_id'] in model.gallery.index]
    outside = [r for r in rows if r['object_id'] not in model.gallery.index]
    summary = summarise(known)
    summary['unknown'] = unknown_statistics(known, outside)
    views = (f"{args.kind}{' occluded' if args.occlusion else ''}"
             f"{', occluder seen' if args.occlusion and args.scene else ''} views")
    drawn = f"seed {args.seed}{', up given' if args.up else ''}; model {args.model}"
    if known:
        print(f'{len(known)} {views} of {len(meshes) - len(unknown)} meshes, {drawn}')
        print(format_summary(summary))
    else:
        print(f'{len(outside)} {views} of {len(unknown)} meshes the gallery lacks, {drawn}')
    if outside:
        print(format_unknown(summary['unknown'], len(unknown)))
    if args.json:
        with open(args.json, 'w') as f:
            json.dump(
                jsonable(
                    {
                        'settings': {k: v for k, v in vars(args).items() if k != 'func'},
                        'summary': summary,
                        'records': rows,
                    }
                ),
                f,
                indent=1,
            )
    return 0


def parse_up(text, option: str = '--up'):
    """
    Read an option's X,Y,Z as three floats (None when not given).

    A ValueError says what is expected.
    """
    if text is None:
        return None
    try:
        up = [float(v) for v in text.split(',')]
    except ValueError:
        up = []
    if len(up) != 3:
        raise ValueError(f'{option} {text!r}: expected three numbers, e.g. 0,0,1')
    return up


def add_settings_option(p) -> None:
    """Let a subcommand take any of the node's model parameters, as --set NAME=VALUE."""
    p.add_argument(
        '--set',
        action='append',
        default=[],
        metavar='NAME=VALUE',
        dest='settings',
        help="any of the node's model parameters (docs/node.md), e.g. --set "
        'local_shape_cost=inf; repeat for more',
    )


def parse_settings(pairs) -> dict:
    """
    Read --set NAME=VALUE pairs as settings: true or false, a number (inf too), else the text.

    A ValueError names a pair that is not NAME=VALUE of a known setting; the value itself is the
    setting's to check when it is set (set_params: type, bounds, choices, in config's words).
    """
    from pcrp_core.config import user_settings

    names = sorted(d['name'] for d in user_settings())
    out = {}
    for pair in pairs:
        name, sep, text = pair.partition('=')
        if not sep or name not in names:
            raise ValueError(
                f'--set {pair!r}: expected NAME=VALUE with NAME one of {", ".join(names)}'
            )
        out[name] = _literal(text)
    return out


def _literal(text: str):
    if text.lower() in ('true', 'false'):
        return text.lower() == 'true'
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def format_result(r) -> str:
    import numpy as np

    rows = [
        f'gallery_id  {r.gallery_id}',
        f'category    {r.category}',
        f"status      {'REJECTED: ' + r.reason if r.rejected else 'accepted'}",
        f'confidence  {r.confidence:.3f}',
        f'score       {r.score:.3f} (fitness {r.fitness:.3f}, inlier rmse {r.inlier_rmse:.4g}, '
        f'chamfer {r.chamfer:.4f})',
        f'scale       {r.scale:.4f}',
        'rotation    '
        + np.array2string(
            np.asarray(r.rotation), precision=4, suppress_small=True, prefix='            '
        ),
        'translation '
        + np.array2string(np.asarray(r.translation), precision=4, suppress_small=True),
        'quaternion  (x, y, z, w) '
        + np.array2string(r.quaternion, precision=4, suppress_small=True),
        'candidates  ' + ', '.join(f'{g} ({d:.3f})' for g, d in r.candidates[:5]),
        'timings ms  ' + ', '.join(f'{k} {v * 1000:.1f}' for k, v in r.timings.items()),
    ]
    return '\n'.join(rows)


def build_parser(extensions=()) -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog='pcrp', description='PCRP point cloud object retrieval and pose estimation'
    )
    sub = parser.add_subparsers(dest='command', required=True)
    for register in (register_build, register_query, register_eval, *extensions):
        register(sub)
    return parser


def join_signed_values(argv: list[str]) -> list[str]:
    """Join "--up -1,0,0" and "--up-axis -y" in argv into "--up=-1,0,0" and "--up-axis=-y"."""
    out: list[str] = []
    for arg in argv:
        if out and out[-1] in SIGNED_OPTIONS and _SIGNED_VALUE.fullmatch(arg):
            out[-1] += '=' + arg
        else:
            out.append(arg)
    return out


def run(parser: argparse.ArgumentParser, argv=None) -> int:
    args = parser.parse_args(join_signed_values(sys.argv[1:] if argv is None else list(argv)))
    return int(args.func(args) or 0)


def main(argv=None) -> int:
    return run(build_parser(), argv)


if __name__ == '__main__':
    sys.exit(main())
