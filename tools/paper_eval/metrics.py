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
Error measures of the paper's tables.

And the chamfer distance that defines retrieval's ground truth.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.geometry import rotation_angle_deg
from pcrp_core.hypotheses import upright_turns
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

# Categories whose labels in this copy of ModelNet40 lay the horizontal axes either way (frames.py:
# a car's length along x or y, its front either end), so an error is also given up to that
LABEL_TOLERANT = ('airplane', 'car')
# the turns about the up axis (z) the labels of those categories disagree by
UP_TURNS = upright_turns(np.array([0.0, 0.0, 1.0]), np.array([0.0, 0.0, 1.0]), 4)


def geodesic_deg(R_est: np.ndarray, R_true: np.ndarray) -> float:
    """Return the angle of the rotation that takes one to the other, in degrees."""
    return rotation_angle_deg(R_est, R_true)


def label_tolerant_deg(R_est: np.ndarray, R_true: np.ndarray) -> float:
    """
    Return the rotation error up to a quarter or half turn of the labels about the up axis.

    The least geodesic_deg(R_est, R_true @ Z) over the four turns Z: what the error would be had
    the query been labelled the way the gallery object it was registered to was.
    """
    return min(geodesic_deg(R_est, R_true @ Z) for Z in UP_TURNS)


def pose_error(R_est: np.ndarray, R_true: np.ndarray, category: str) -> dict:
    """
    {'error': the rotation error, 'tolerant': the same up to the labels}, in degrees.

    Tolerant: label_tolerant_deg for the LABEL_TOLERANT categories, the error itself for others.
    """
    error = geodesic_deg(R_est, R_true)
    tolerant = label_tolerant_deg(R_est, R_true) if category in LABEL_TOLERANT else error
    return {'error': error, 'tolerant': tolerant}


def euler_errors(R_est: np.ndarray, R_true: np.ndarray) -> np.ndarray:
    """
    Return differences of the x, y, z Euler angles (degrees, wrapped to [-180, 180)).

    As the registration tables of R-PointHop, DCP and PRNet report them.
    """
    d = Rotation.from_matrix(R_est).as_euler('xyz', degrees=True) - Rotation.from_matrix(
        R_true
    ).as_euler('xyz', degrees=True)
    return (d + 180.0) % 360.0 - 180.0


def mse_rmse_mae(diffs) -> dict:
    """Over every component of every query (3 angles or 3 translations each)."""
    d = np.asarray(diffs, dtype=np.float64).ravel()
    if d.size == 0:
        return {'mse': float('nan'), 'rmse': float('nan'), 'mae': float('nan')}
    mse = float(np.mean(d ** 2))
    return {'mse': mse, 'rmse': float(np.sqrt(mse)), 'mae': float(np.mean(np.abs(d)))}


def rotation_summary(errors_deg) -> dict:
    e = np.asarray(errors_deg, dtype=np.float64)
    if e.size == 0:
        return {'n': 0}
    return {
        'n': int(e.size),
        'mean': float(e.mean()),
        'median': float(np.median(e)),
        'under_5': float(np.mean(e < 5)),
        'under_10': float(np.mean(e < 10)),
        'under_30': float(np.mean(e < 30)),
    }


def chamfer(
    a: np.ndarray, b: np.ndarray, tree_a: cKDTree | None = None, tree_b: cKDTree | None = None
) -> float:
    """
    Symmetric chamfer distance.

    The mean distance from each point of a to its nearest point of b, plus the same from b to a
    (not squared; in the clouds' units, here unit-sphere radii).
    """
    tree_a = tree_a or cKDTree(a)
    tree_b = tree_b or cKDTree(b)
    return float(tree_b.query(a)[0].mean() + tree_a.query(b)[0].mean())


def precision_at_10(ranked: np.ndarray, chamfers: np.ndarray) -> tuple[float, float]:
    """
    (strict, CORSAIR) Precision@10 of one query.

    ranked: gallery indices as the method orders them; chamfers: the chamfer distance from the
    unrotated query to each gallery object. Strict: the share of the method's top 10 among the 10
    nearest by chamfer. CORSAIR's: the share of the top 10 among the nearest 10 % by chamfer.
    """
    top = np.asarray(ranked)[:10]
    order = np.argsort(chamfers, kind='stable')
    strict = np.isin(top, order[:10]).mean()
    corsair = np.isin(top, order[: max(10, int(round(0.1 * len(chamfers))))]).mean()
    return float(strict), float(corsair)
