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

"""RANSAC over matched points: triples -> Procrustes -> inlier count, all hypotheses at once."""
from __future__ import annotations

import numpy as np
from pcrp_core.registration.procrustes import procrustes, procrustes_batch


def squared_residuals(
    src: np.ndarray, dst: np.ndarray, R: np.ndarray, t: np.ndarray
) -> np.ndarray:
    """
    (H, n): |R_h @ src_n + t_h - dst_n|^2 for every pose h and matched pair n.

    Expanded into one (H, 17) x (17, n) product: with s = src_n, d = dst_n,
    |R s + t - d|^2 = |s|^2 + |d|^2 + |t|^2 - 2 d.t + 2 s.(R^T t) - 2 sum_ij R_ij d_i s_j.
    Moving every pair under every pose first would cost an (H, n, 3) array and a reduction
    over its short last axis, several times slower for hundreds of poses.
    """
    n, h = len(src), len(R)
    pairs = np.column_stack([(src ** 2).sum(1) + (dst ** 2).sum(1), np.ones(n), dst, src,
                             (dst[:, :, None] * src[:, None, :]).reshape(n, 9)])
    poses = np.column_stack(
        [
            np.ones(h),
            (t**2).sum(1),
            -2.0 * t,
            2.0 * np.einsum('hji,hj->hi', R, t),
            -2.0 * R.reshape(h, 9),
        ]
    )
    return poses @ pairs.T


def ransac(src: np.ndarray, dst: np.ndarray, threshold: float, iterations: int,
           rng: np.random.Generator, batch: int = 500):
    """
    Best R, t with dst ≈ R @ src + t over matched rows, and its inlier mask.

    Hypotheses are drawn in batches and scored by inlier count with numpy, which costs about as
    much as a few Python-level iterations would.
    """
    n = len(src)
    if n < 3:
        return np.eye(3), dst.mean(0) - src.mean(0) if n else np.zeros(3), np.zeros(n, bool)
    best = (-1, np.eye(3), np.zeros(3))
    thr2 = threshold ** 2
    for start in range(0, iterations, batch):
        b = min(batch, iterations - start)
        triples = (
            np.stack([rng.choice(n, 3, replace=False) for _ in range(b)])
            if n < 6
            else rng.integers(0, n, (b, 3))
        )
        R, t = procrustes_batch(src[triples], dst[triples])
        counts = (squared_residuals(src, dst, R, t) < thr2).sum(1)
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
