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

"""Least-squares rigid motion between matched point sets (Kabsch), one or many at once."""
from __future__ import annotations

import numpy as np


def procrustes_batch(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """
    R (B, 3, 3), t (B, 3) minimising |R @ src + t - dst| for each batch of matches (B, n, 3).

    Means and cross-covariances are matrix products, not reductions over the middle axis: numpy
    reduces (B, n, 3) along n several times slower than it multiplies.
    """
    n = src.shape[1]
    w = np.full(n, 1.0 / n)
    mu_s, mu_d = w @ src, w @ dst
    H = src.transpose(0, 2, 1) @ dst - n * mu_s[:, :, None] * mu_d[:, None, :]
    U, _, Vt = np.linalg.svd(H)
    # flip the weakest axis where needed so the result is a rotation, never a reflection
    Vt[np.linalg.det(U @ Vt) < 0, 2] *= -1
    R = (U @ Vt).transpose(0, 2, 1)
    t = mu_d - (R @ mu_s[:, :, None])[..., 0]
    return R, t


def procrustes(src: np.ndarray, dst: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """
    R (3, 3), t (3,) minimising |R @ src + t - dst| over matched rows of (n, 3) arrays.

    Written out rather than calling the batch form: for one set of matches (the single-pose icp(),
    RANSAC's refit) the batch bookkeeping would cost more than the SVD.
    """
    mu_s = src.mean(axis=0)
    mu_d = dst.mean(axis=0)
    U, _, Vt = np.linalg.svd((src - mu_s).T @ (dst - mu_d))
    R = Vt.T @ U.T
    if np.linalg.det(R) < 0:
        Vt[2] = -Vt[2]
        R = Vt.T @ U.T
    return R, mu_d - R @ mu_s
