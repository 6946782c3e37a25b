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
The retrieval experiment (the paper's Table 2).

Which gallery objects a query's global descriptor finds, judged against the gallery ranked by
chamfer distance to the unrotated query.

Each query searches the train split of its own category (the paper's per-category galleries);
kernels and codebooks are the four-category model's.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.features.fpfh import fpfh, oriented_normals
from pcrp_core.vlad import VLAD
from scipy.spatial import cKDTree
from tools.paper_eval.metrics import chamfer, precision_at_10

METHODS = {
    'pcrp_vlad': 'PCRP: FR-PointHop point features, VLAD (k = 10)',
    'pcrp_max': 'FR-PointHop point features, global max pooling',
    'fpfh_vlad': 'FPFH point features, VLAD (k = 10)',
}
CHAMFER_POINTS = 512   # ground truth on half the points: the ranking barely moves, the time halves


def fpfh_features(state: dict, normed: np.ndarray) -> np.ndarray:
    return fpfh(normed, oriented_normals(normed), state['radius'])


def describe(state: dict, normed: np.ndarray) -> dict:
    """Return the three global descriptors of one normalised cloud."""
    feats = state['pointhop'].transform(normed)[1]
    return {'pcrp_vlad': state['vlad'].transform(feats), 'pcrp_max': state['max'].transform(feats),
            'fpfh_vlad': state['fpfh_vlad'].transform(fpfh_features(state, normed))}


def fpfh_codebook(pointhop, normed_clouds, seed: int = 0) -> VLAD:
    """
    Return the FPFH baseline's own k-means codebook.

    Fitted on the same kind of gallery sample the FR-PointHop kernels were.
    """
    state = {'radius': pointhop.fpfh_radius}
    feats = np.concatenate([fpfh_features(state, c) for c in normed_clouds])
    return VLAD(10, 'vlad', random_state=seed).fit(feats)


def _sub(points: np.ndarray) -> np.ndarray:
    return points[:: max(1, len(points) // CHAMFER_POINTS)]


def ground_truth(state: dict, query_canonical: np.ndarray) -> np.ndarray:
    """Chamfer distance from the unrotated query to each gallery object of its category."""
    q = _sub(query_canonical)
    tq = cKDTree(q)
    return np.array([chamfer(q, g, tq, t) for g, t in zip(state['clouds'], state['trees'])])


def scores(ranked_by_method: dict, chamfers: np.ndarray, rng: np.random.Generator) -> dict:
    out = {}
    for m, ranked in ranked_by_method.items():
        strict, corsair = precision_at_10(ranked, chamfers)
        out[m] = {
            'p10_strict': strict,
            'p10_corsair': corsair,
            'top1_chamfer': float(chamfers[ranked[0]]),
        }
    out['best'] = float(chamfers.min())
    out['random'] = float(chamfers[rng.integers(len(chamfers))])
    return out


def summarise(rows: list[dict]) -> dict:
    methods = [m for m in METHODS if rows and m in rows[0]]
    out = {
        m: {
            k: float(np.mean([r[m][k] for r in rows]))
            for k in ('p10_strict', 'p10_corsair', 'top1_chamfer')
        }
        for m in methods
    }
    out['best_top1_chamfer'] = float(np.mean([r['best'] for r in rows]))
    out['random_top1_chamfer'] = float(np.mean([r['random'] for r in rows]))
    out['n'] = len(rows)
    return out
