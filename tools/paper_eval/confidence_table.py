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
How far the category-level path's confidence can be trusted.

The share of right answers it accepts at the default min_confidence, the share of objects from
categories the gallery lacks it rejects, and how well it ranks the two (ROC), whole clouds and
one-sided views apart.

The gallery is the four-category model; its confidence was learnt at build on its own train
objects (category/calibration.py). The queries are test objects: of its categories, and of
twelve categories it does not hold and no choice was made on (OUTSIDE).
"""

from __future__ import annotations

import numpy as np
from pcrp_core.category.evidence import RIGHT_DEG
from pcrp_core.confidence import expected_calibration_error, reliability
from tools.paper_eval.metrics import pose_error
from tools.paper_eval.models import loaded

OUTSIDE = (
    'bottle',
    'bowl',
    'cone',
    'cup',
    'guitar',
    'keyboard',
    'lamp',
    'person',
    'plant',
    'stairs',
    'tent',
    'vase',
)
TARGETS = {'right_accepted': 0.95, 'outside_rejected': 0.80, 'auc': 0.95}


def answer_one(state: dict, q) -> dict:
    model = loaded(state['model'])
    r = model.estimate(q.points, viewpoint=q.viewpoint)
    errors = pose_error(r.rotation, q.R, q.category)
    same = r.category == q.category
    return {
        'name': q.name,
        'category': q.category,
        'inside': q.category in state['inside'],
        'kind': 'whole' if q.viewpoint is None else 'view',
        'retrieved_category': r.category,
        **errors,
        'confidence': float(r.confidence),
        'rejected': bool(r.rejected),
        'right': same and errors['error'] < RIGHT_DEG,
        # airplane and car up to their labels (metrics.LABEL_TOLERANT)
        'right_tolerant': same and errors['tolerant'] < RIGHT_DEG,
    }


def summarise(rows: list[dict], threshold: float, right_key: str = 'right') -> dict:
    """
    Per kind of cloud (and both).

    The targets' figures, the ROC curve of right answers against objects from outside the gallery,
    and a reliability table over all answers; right_key names what counts as right.
    """
    from sklearn.metrics import roc_auc_score, roc_curve

    out = {}
    for kind in ('whole', 'view', 'all'):
        sel = [r for r in rows if kind in ('all', r['kind'])]
        if not sel:
            continue
        right = [r for r in sel if r['inside'] and r[right_key]]
        outside = [r for r in sel if not r['inside']]
        inside = [r for r in sel if r['inside']]
        d = {
            'n_inside': len(inside),
            'n_right': len(right),
            'n_outside': len(outside),
            'right_share': len(right) / max(1, len(inside)),
            'right_accepted': (
                float(np.mean([r['confidence'] >= threshold for r in right])) if right else np.nan
            ),
            'outside_rejected': (
                float(np.mean([r['confidence'] < threshold for r in outside]))
                if outside
                else np.nan
            ),
            'wrong_inside_rejected': (
                float(np.mean([r['confidence'] < threshold for r in inside if not r[right_key]]))
                if len(right) < len(inside)
                else np.nan
            ),
        }
        if right and outside:
            y = [1] * len(right) + [0] * len(outside)
            c = [r['confidence'] for r in right + outside]
            d['auc'] = float(roc_auc_score(y, c))
            fpr, tpr, _ = roc_curve(y, c)
            d['roc'] = [fpr.tolist(), tpr.tolist()]
        conf, ok = [r['confidence'] for r in sel], [r[right_key] for r in sel]
        d['reliability'] = reliability(conf, ok)
        d['ece'] = expected_calibration_error(conf, ok)
        out[kind] = d
    return out


def plot(summary: dict, path, either: dict | None = None) -> bool:
    """
    Reliability diagram (share right against confidence) and ROC curves, one line per kind.

    either: the same summary judged with airplanes' and cars' labels either way, whose reliability
    over all answers is drawn beside.
    """
    import matplotlib

    matplotlib.use('Agg')
    import matplotlib.pyplot as plt

    fig, (a, b) = plt.subplots(1, 2, figsize=(10, 4.2))
    for kind, style in (('whole', 'o-'), ('view', 's-'), ('all', 'k--')):
        d = summary.get(kind)
        if not d:
            continue
        rel = np.array(d['reliability'])
        if len(rel):
            a.plot(rel[:, 0], rel[:, 1], style, label=f"{kind} (ECE {d['ece']:.2f})")
        if 'roc' in d:
            b.plot(*d['roc'], style, label=f"{kind} (AUC {d['auc']:.2f})")
    rel = np.array((either or {}).get('all', {}).get('reliability', []))
    if len(rel):
        ece = either['all']['ece']
        a.plot(rel[:, 0], rel[:, 1], 'r--', label=f'all, labels either way (ECE {ece:.2f})')
    a.plot([0, 1], [0, 1], ':', color='grey')
    a.set(
        xlabel='confidence (mean in bin)', ylabel='share right', title='reliability, all answers'
    )
    b.plot([0, 1], [0, 1], ':', color='grey')
    b.set(
        xlabel='objects from outside the gallery accepted',
        ylabel='right answers accepted',
        title='ROC: right answers vs outside objects',
    )
    for ax in (a, b):
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8, loc='lower right')
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return True
