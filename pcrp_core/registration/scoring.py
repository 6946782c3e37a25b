"""How well an aligned query sits on a gallery object: the numbers verification decides by."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def fit_quality(aligned: np.ndarray, dst_tree: cKDTree, inlier_distance: float, trim: float = 0.9):
    """(fitness, inlier_rmse, trimmed_chamfer) of query points already moved into the gallery frame.

    One-way (query to gallery) because a query may be one side of the object: what the camera
    did not see must not count against it. The trimmed mean ignores the worst tenth, left by
    segmentation spill or by parts in which two instances differ.
    """
    dist, _ = dst_tree.query(aligned)
    inl = dist < inlier_distance
    fitness = float(inl.mean())
    rmse = float(np.sqrt(np.mean(dist[inl] ** 2))) if inl.any() else float("inf")
    k = max(1, int(trim * len(dist)))
    chamfer = float(np.mean(np.partition(dist, k - 1)[:k]))
    return fitness, rmse, chamfer
