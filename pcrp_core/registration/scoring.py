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

"""How well an aligned query sits on a gallery object: the numbers verification decides by."""
from __future__ import annotations

import numpy as np
from pcrp_core.registration.icp import transform_batch
from pcrp_core.registration.nearest import Tree


def fit_quality(aligned: np.ndarray, dst_tree: Tree, inlier_distance: float, trim: float = 0.9):
    """
    (fitness, inlier_rmse, trimmed_chamfer) of query points already moved into the gallery frame.

    One-way (query to gallery) because a query may be one side of the object: what the camera did
    not see must not count against it. The trimmed mean ignores the worst tenth, left by
    segmentation spill or by parts in which two instances differ.
    """
    dist, _ = dst_tree.query(aligned)
    inl = dist < inlier_distance
    fitness = float(inl.mean())
    rmse = float(np.sqrt(np.mean(dist[inl] ** 2))) if inl.any() else float('inf')
    k = max(1, int(trim * len(dist)))
    chamfer = float(np.mean(np.partition(dist, k - 1)[:k]))
    return fitness, rmse, chamfer


def fit_quality_batch(
    aligned: np.ndarray, dst_tree: Tree, inlier_distance: float, trim: float = 0.9
):
    """
    fit_quality() of many posed copies of the query at once.

    aligned (H, n, 3) -> three (H,) arrays.
    """
    dist = dst_tree.query(aligned.reshape(-1, 3))[0].reshape(aligned.shape[:2])
    inl = dist < inlier_distance
    fitness = inl.mean(axis=1)
    n_inl = inl.sum(axis=1)
    rmse = np.where(
        n_inl > 0, np.sqrt(np.where(inl, dist**2, 0).sum(axis=1) / np.maximum(n_inl, 1)), np.inf
    )
    k = max(1, int(trim * dist.shape[1]))
    chamfer = np.partition(dist, k - 1, axis=1)[:, :k].mean(axis=1)
    return fitness, rmse, chamfer


def mean_distance_batch(src: np.ndarray, Rs, ts, dst_tree: Tree) -> np.ndarray:
    """
    (H,) untrimmed mean distance from src under each pose (R, t) to the points in dst_tree.

    The cheap ranking of many rough hypotheses, before any is refined.
    """
    moved = transform_batch(src, np.asarray(Rs), np.asarray(ts))
    return dst_tree.query(moved.reshape(-1, 3))[0].reshape(len(moved), -1).mean(axis=1)


def distances_back(src_tree: Tree, points: np.ndarray, Rs, ts) -> np.ndarray:
    """
    Return (H, m) distances from the m gallery points to the query points posed by each (R, t).

    The query points are those in src_tree, posed query to gallery. The gallery points are taken
    back into the query's frame instead of the query moved into the gallery's: one tree of the
    query serves every pose (a rigid motion keeps distances).
    """
    local = np.einsum('hmj,hji->hmi', points[None] - np.asarray(ts)[:, None, :], np.asarray(Rs))
    return src_tree.query(local.reshape(-1, 3))[0].reshape(len(local), -1)
