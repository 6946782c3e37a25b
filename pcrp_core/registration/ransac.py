"""RANSAC over matched points: triples -> Procrustes -> inlier count, all hypotheses at once."""
from __future__ import annotations

import numpy as np

from pcrp_core.registration.procrustes import procrustes, procrustes_batch


def ransac(src: np.ndarray, dst: np.ndarray, threshold: float, iterations: int,
           rng: np.random.Generator, batch: int = 500):
    """Best R, t with dst ≈ R @ src + t over matched rows, and its inlier mask.

    Hypotheses are drawn in batches and scored by inlier count with numpy, which costs about
    as much as a few Python-level iterations would.
    """
    n = len(src)
    if n < 3:
        return np.eye(3), dst.mean(0) - src.mean(0) if n else np.zeros(3), np.zeros(n, bool)
    best = (-1, np.eye(3), np.zeros(3))
    thr2 = threshold ** 2
    for start in range(0, iterations, batch):
        b = min(batch, iterations - start)
        triples = np.stack([rng.choice(n, 3, replace=False) for _ in range(b)]) if n < 6 else rng.integers(0, n, (b, 3))
        R, t = procrustes_batch(src[triples], dst[triples])
        moved = src[None] @ R.transpose(0, 2, 1) + t[:, None, :]
        counts = (((moved - dst[None]) ** 2).sum(-1) < thr2).sum(1)
        k = int(np.argmax(counts))
        if counts[k] > best[0]:
            best = (int(counts[k]), R[k], t[k])
    _, R, t = best
    inliers = ((src @ R.T + t - dst) ** 2).sum(1) < thr2
    # refit on the inliers: the triple only located the basin
    for _ in range(2):
        if inliers.sum() < 3:
            break
        R, t = procrustes(src[inliers], dst[inliers])
        inliers = ((src @ R.T + t - dst) ** 2).sum(1) < thr2
    return R, t, inliers
