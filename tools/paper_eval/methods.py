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
The methods each table compares.

Each answering "where is the gallery object in the query?" as (R, t) with p_query = R @ p_gallery +
t.
"""

from __future__ import annotations

import time

import numpy as np
from pcrp_core.category import prepare, Registrar
from pcrp_core.config import PAPER_POSE, PAPER_QUERY, PoseOptions
from pcrp_core.geometry import normalised

PAPER_OPTIONS = PAPER_POSE


def paper_variant(model):
    """
    Return the model configured as the paper describes PCRP (top-1 retrieval, no rejection).

    It shares the model's gallery and its cache of prepared gallery objects.
    """
    return model.with_options(pose=PAPER_POSE, **PAPER_QUERY)


def _prepared(pointhop, unit: float, points: np.ndarray):
    centre = points.mean(0)
    normed = normalised(points, unit, centre)
    return centre, prepare(normed, *pointhop.transform(normed))


def register_pair(pointhop, unit: float, gallery_points: np.ndarray, query_points: np.ndarray,
                  options: PoseOptions, seed: int = 0):
    """
    Register one known object to a moved copy of it (the registration table).

    Both described by the given point features, then the pose stage with the given options.
    """
    c_g, g = _prepared(pointhop, unit, np.asarray(gallery_points, dtype=np.float64))
    c_q, q = _prepared(pointhop, unit, np.asarray(query_points, dtype=np.float64))
    _, h = Registrar(q, options, np.random.default_rng(seed)).best_pose([g], [g])
    # g_n = R' q_n + t'  =>  q = R'^T g + c_q - R'^T (c_g + unit t')
    R = h.R.T
    return R, c_q - R @ (c_g + unit * h.t)


def open3d_pose(fn, query_points: np.ndarray, target) -> tuple[np.ndarray, np.ndarray]:
    """
    Return an Open3D pipeline's answer in the same convention.

    It moves the query onto the target.
    """
    T = fn(np.asarray(query_points, dtype=np.float64), target)
    R = T[:3, :3].T
    return R, -R @ T[:3, 3]


def timed(fn, *args, **kw):
    t0 = time.perf_counter()
    out = fn(*args, **kw)
    return out, time.perf_counter() - t0
