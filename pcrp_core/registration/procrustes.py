"""Least-squares rigid motion between matched point sets (Kabsch), one or many at once."""
from __future__ import annotations

import numpy as np


def procrustes_batch(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R (B, 3, 3), t (B, 3) minimising |R @ src + t - dst| for each batch of matches (B, n, 3)."""
    mu_s = src.mean(axis=1, keepdims=True)
    mu_d = dst.mean(axis=1, keepdims=True)
    H = (src - mu_s).transpose(0, 2, 1) @ (dst - mu_d)
    U, _, Vt = np.linalg.svd(H)
    # flip the weakest axis where needed so the result is a rotation, never a reflection
    d = np.sign(np.linalg.det(Vt.transpose(0, 2, 1) @ U.transpose(0, 2, 1)))
    D = np.tile(np.eye(3), (len(src), 1, 1))
    D[:, 2, 2] = np.where(d == 0, 1.0, d)
    R = Vt.transpose(0, 2, 1) @ D @ U.transpose(0, 2, 1)
    t = mu_d[:, 0] - (R @ mu_s.transpose(0, 2, 1))[..., 0]
    return R, t


def procrustes(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """R (3, 3), t (3,) minimising |R @ src + t - dst| over matched rows of (n, 3) arrays.

    Written out rather than calling the batch form: ICP calls it thousands of times per
    query and the batch bookkeeping would cost more than the SVD."""
    mu_s = src.mean(axis=0)
    mu_d = dst.mean(axis=0)
    U, _, Vt = np.linalg.svd((src - mu_s).T @ (dst - mu_d))
    R = Vt.T @ U.T
    if np.linalg.det(R) < 0:
        Vt[2] = -Vt[2]
        R = Vt.T @ U.T
    return R, mu_d - R @ mu_s
