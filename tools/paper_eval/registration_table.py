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
The registration experiment (the paper's Table 1).

An object registered to a moved copy of itself, so the features' quality is all that differs
between methods.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.config import PoseOptions
from tools.paper_eval import open3d_pipelines as o3d_pipes
from tools.paper_eval.methods import open3d_pose, PAPER_OPTIONS, register_pair, timed
from tools.paper_eval.metrics import euler_errors, mse_rmse_mae

METHODS = {
    'r_pointhop': 'R-PointHop (octant-coordinate hop 1), RANSAC on feature matches',
    'fr_pointhop': 'FR-PointHop (FPFH hop 1), RANSAC on feature matches',
    'fr_pointhop_ext': "FR-PointHop with this package's registration (half turns, ICP)",
    'fgr_icp': 'Open3D FPFH + FGR + ICP',
    'ransac_icp': 'Open3D FPFH + RANSAC + ICP',
}


def register_one(state: dict, q) -> dict:
    """q.canonical is the object, q.points its moved (and maybe cut) copy."""
    o3d_pipes.quiet()
    row = {'name': q.name, 'category': q.category}
    runs = {
        'r_pointhop': lambda: register_pair(
            state['octant'], state['unit'], q.canonical, q.points, PAPER_OPTIONS
        ),
        'fr_pointhop': lambda: register_pair(
            state['fpfh'], state['unit'], q.canonical, q.points, PAPER_OPTIONS
        ),
        'fr_pointhop_ext': lambda: register_pair(
            state['fpfh'], state['unit'], q.canonical, q.points, PoseOptions()
        ),
    }
    target = o3d_pipes.prepare_target(q.canonical)
    runs['fgr_icp'] = lambda: open3d_pose(o3d_pipes.fgr_icp, q.points, target)
    runs['ransac_icp'] = lambda: open3d_pose(o3d_pipes.ransac_icp, q.points, target)
    for name, run in runs.items():
        (R, t), seconds = timed(run)
        row[name] = {
            'euler': euler_errors(R, q.R).tolist(),
            't': (np.asarray(t) - q.t).tolist(),
            'seconds': seconds,
        }
    return row


def summarise(rows: list[dict]) -> dict:
    return {m: {'rotation': mse_rmse_mae([r[m]['euler'] for r in rows]),
                'translation': mse_rmse_mae([r[m]['t'] for r in rows]),
                'median_ms': float(np.median([r[m]['seconds'] for r in rows]) * 1e3)}
            for m in METHODS if rows and m in rows[0]}
