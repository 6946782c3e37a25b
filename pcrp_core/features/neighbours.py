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

"""k-nearest neighbourhoods, shared by normals, frames and octant aggregation."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def knn(
    points: np.ndarray, centres: np.ndarray, k: int, tree: cKDTree | None = None
) -> np.ndarray:
    """(M, k) indices into points of each centre's k nearest neighbours (itself included)."""
    k = min(k, len(points))
    tree = tree if tree is not None else cKDTree(points)
    _, idx = tree.query(centres, k=k)
    return idx.reshape(len(centres), k)
