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

"""Point matches by feature nearest neighbour, kept within corresponding symmetry halves."""
from __future__ import annotations

import numpy as np


def nearest_features(query: np.ndarray, gallery: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """For each query row, the index of and squared distance to its nearest gallery row."""
    d2 = (query ** 2).sum(1)[:, None] - 2.0 * query @ gallery.T + (gallery ** 2).sum(1)[None]
    idx = np.argmin(d2, axis=1)
    return idx, d2[np.arange(len(query)), idx]


def matches_within_halves(q_feat, g_feat, q_half, g_half, same_side: bool):
    """
    (query index, gallery index, feature distance) arrays.

    a query point on side s of its symmetry plane is matched among the gallery points on side s (or
    on the other side, when the two axes point opposite ways: same_side=False).
    """
    qi, gi, dist = [], [], []
    for side in (True, False):
        q_idx = np.flatnonzero(q_half == side)
        g_idx = np.flatnonzero(g_half == (side if same_side else not side))
        if len(q_idx) == 0 or len(g_idx) == 0:
            continue
        nn, d2 = nearest_features(q_feat[q_idx], g_feat[g_idx])
        qi.append(q_idx)
        gi.append(g_idx[nn])
        dist.append(d2)
    if not qi:
        return np.empty(0, int), np.empty(0, int), np.empty(0)
    return np.concatenate(qi), np.concatenate(gi), np.concatenate(dist)
