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
The pose experiment (the paper's Table 3) and what a robot adds to it.

One-sided views, a 40-category gallery, and queries of objects that are not in the gallery at all.
"""

from __future__ import annotations

import numpy as np
from tools.paper_eval import open3d_pipelines as o3d_pipes
from tools.paper_eval.methods import open3d_pose, paper_variant, timed
from tools.paper_eval.metrics import pose_error, rotation_summary
from tools.paper_eval.models import category_model, loaded

METHODS = {
    'pcrp': "PCRP, this package's defaults (16 candidates verified, 24 for one-sided views, half "
            'turns, ICP)',
    'pcrp_paper': 'PCRP as the paper describes it (top-1 object, RANSAC on symmetry-split '
                  'matches)',
    'icp': "ICP alone, from the centroids' offset",
    'fgr_icp': 'Open3D FPFH + FGR + ICP',
    'ransac_icp': 'Open3D FPFH + RANSAC + ICP',
    'pcrp_up': 'PCRP told which way is up (a level camera, gravity known)',
}
# the paper's table: no method is told anything about the query's pose
PAPER_METHODS = ('pcrp', 'pcrp_paper', 'icp', 'fgr_icp', 'ransac_icp')
# what can answer a one-sided view (ICP alone from the centroids cannot: a view's centroid is off)
VIEW_METHODS = ('pcrp', 'pcrp_paper', 'fgr_icp', 'ransac_icp')
ROBOT_VIEW_METHODS = VIEW_METHODS + ('pcrp_up',)
BASELINES = {
    'icp': o3d_pipes.icp_only,
    'fgr_icp': o3d_pipes.fgr_icp,
    'ransac_icp': o3d_pipes.ransac_icp,
}
RIGHT_DEG = (
    30.0  # an answer is "right" for the rejection table when under this and of the right category
)


def pose_one(state: dict, q) -> dict:
    """
    Every method of state['methods'] on one query.

    The classical pipelines register to the object PCRP retrieved, its FPFH computed beforehand
    (untimed), so only registration differs.
    """
    o3d_pipes.quiet()
    model = (
        category_model(state['model'], q.category)
        if state['per_category']
        else loaded(state['model'])
    )
    r = model.estimate(q.points, viewpoint=q.viewpoint)
    row = {'name': q.name, 'category': q.category, 'retrieved': r.gallery_id,
           'retrieved_category': r.category, 'confidence': r.confidence,
           'rejected': bool(r.rejected), 'pcrp': _scored(r, q)}
    if 'pcrp_paper' in state['methods']:
        row['pcrp_paper'] = _scored(
            paper_variant(model).estimate(q.points, viewpoint=q.viewpoint), q
        )
    if 'pcrp_up' in state['methods']:
        # the up direction a robot reads from gravity: the gallery's up axis as the query
        # carries it
        row['pcrp_up'] = _scored(
            model.estimate(q.points, viewpoint=q.viewpoint, up=q.R @ model.up_axis), q
        )
    wanted = [m for m in BASELINES if m in state['methods']]
    if wanted:
        target = o3d_pipes.prepare_target(model.gallery_cloud(r.gallery_id).astype(np.float64))
        for m in wanted:
            (R, _), seconds = timed(open3d_pose, BASELINES[m], q.points, target)
            row[m] = {**pose_error(R, q.R, q.category), 'seconds': seconds}
    return row


def _scored(result, q) -> dict:
    """Return a pcrp answer's pose errors against the query's truth, and its seconds."""
    return {**pose_error(result.rotation, q.R, q.category), 'seconds': result.timings['total']}


def summarise(rows: list[dict], methods) -> dict:
    """Per category and over all: each method's rotation-error summary and median seconds."""
    out = {}
    cats = sorted({r['category'] for r in rows})
    for cat in cats + ['all']:
        sel = [r for r in rows if cat in ('all', r['category'])]
        out[cat] = {m: {**rotation_summary([r[m]['error'] for r in sel]),
                        'median_ms': float(np.median([r[m]['seconds'] for r in sel]) * 1e3),
                        # rows of an earlier run have no label-tolerant error
                        **({'tolerant': rotation_summary([r[m]['tolerant'] for r in sel])}
                           if 'tolerant' in sel[0][m] else {})}
                    for m in methods if sel and m in sel[0]}
        out[cat]['category_accuracy'] = float(
            np.mean([r['retrieved_category'] == r['category'] for r in sel])
        )
        out[cat]['object_accuracy'] = float(np.mean([r['retrieved'] == r['name'] for r in sel]))
        out[cat]['rejected'] = float(np.mean([r['rejected'] for r in sel]))
    return out


def rejection_summary(inside: list[dict], outside: list[dict]) -> dict:
    """
    Return what the default confidence threshold does with queries.

    Queries of gallery categories and of others. The gallery categories' shares are given with
    the raw rotation error and, under 'tolerant', with the error up to the labels.
    """
    acc = [r for r in inside if not r['rejected']]
    rej = [r for r in inside if r['rejected']]
    out_cats = sorted({r['category'] for r in outside})

    def shares(error: str) -> dict:
        def right(r):
            return r['retrieved_category'] == r['category'] and r['pcrp'][error] < RIGHT_DEG
        return {
            'inside_right_but_rejected': sum(map(right, rej)) / max(1, len(inside)),
            'inside_wrong_and_rejected': sum(not right(r) for r in rej) / max(1, len(inside)),
            'inside_wrong_but_accepted': sum(not right(r) for r in acc) / max(1, len(inside)),
            'inside_right_among_accepted': sum(map(right, acc)) / max(1, len(acc)),
        }
    tolerant = bool(inside) and all('tolerant' in r['pcrp'] for r in inside)
    return {
        'inside_n': len(inside),
        'inside_rejected': len(rej) / max(1, len(inside)),
        **shares('error'),
        **({'tolerant': shares('tolerant')} if tolerant else {}),
        'outside': {
            c: {
                'n': sum(r['category'] == c for r in outside),
                'rejected': float(np.mean([r['rejected'] for r in outside if r['category'] == c])),
            }
            for c in out_cats
        },
        'outside_rejected': (
            float(np.mean([r['rejected'] for r in outside])) if outside else float('nan')
        ),
        'confidence_inside': [r['confidence'] for r in inside],
        'confidence_outside': [r['confidence'] for r in outside],
    }
