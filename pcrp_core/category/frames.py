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
Which way one gallery object is turned against another.

A gallery defines a pose only as far as its objects agree on their frames. When the objects of one
category disagree about which way is front (some face along x, others along y), an object left out
of the gallery comes back in the frame of the object it is answered with, not in its own; the
calibration (calibration.py) counts that answer right when it lays the answered object on the
cloud. Measured on shape alone: which of the 24 rotations that map axes onto axes lays one object
on the other.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.hypotheses import AXIS_ROTATIONS
from scipy.spatial import cKDTree

POINTS = 128  # per cloud: enough to tell a quarter or half turn of an object apart
IDENTITY = int(np.flatnonzero([np.allclose(M, np.eye(3)) for M in AXIS_ROTATIONS])[0])


def subsample(points: np.ndarray, seed: int) -> np.ndarray:
    """POINTS of the cloud (some twice when it has fewer), about the cloud's mean."""
    points = np.asarray(points, dtype=np.float64)
    pick = np.random.default_rng(seed).choice(len(points), POINTS, replace=len(points) < POINTS)
    return points[pick] - points.mean(0)


def chamfer_by_rotation(query: np.ndarray, clouds: np.ndarray, trees) -> np.ndarray:
    """(G, 24) symmetric chamfers of the query turned by each axis map to (G, n, 3) clouds."""
    rotated = np.einsum('rij,nj->rni', AXIS_ROTATIONS, query)                   # (24, n, 3)
    g, n = clouds.shape[:2]
    flat = clouds.reshape(-1, 3)
    back = np.stack([cKDTree(r).query(flat)[0].reshape(g, n).mean(1) for r in rotated], axis=1)
    forth = np.stack(
        [t.query(rotated.reshape(-1, 3))[0].reshape(len(rotated), -1).mean(1) for t in trees]
    )
    return back + forth


def axis_turn(cloud: np.ndarray, onto: np.ndarray) -> np.ndarray:
    """Return the axis map M that best lays the cloud on the other (M @ cloud ~ onto)."""
    other = subsample(onto, 1)
    cost = chamfer_by_rotation(subsample(cloud, 0), other[None], [cKDTree(other)])
    return AXIS_ROTATIONS[int(np.argmin(cost[0]))].copy()
