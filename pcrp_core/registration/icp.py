"""Trimmed point-to-point ICP: refine a pose by pulling the query onto the gallery surface.

Trimming keeps only the closest share of matches each iteration, so a partial view, clutter
left by the segmenter, or parts in which two instances of a category differ do not pull the
pose away.
"""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

from pcrp_core.registration.procrustes import procrustes


def icp(src: np.ndarray, dst: np.ndarray, dst_tree: cKDTree, R: np.ndarray, t: np.ndarray,
        iterations: int = 20, trim: float = 0.8, tolerance: float = 1e-6):
    """Refined R, t with dst ≈ R @ src + t."""
    keep = max(3, int(trim * len(src)))
    prev = np.inf
    for _ in range(iterations):
        dist, nn = dst_tree.query(src @ R.T + t)
        order = np.argpartition(dist, keep - 1)[:keep]
        R, t = procrustes(src[order], dst[nn[order]])
        err = float(np.mean(dist[order] ** 2))
        if prev - err < tolerance:
            break
        prev = err
    return R, t
