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
Nearest points of a fixed cloud, asked many times: what ICP and every fit score spend most on.

Open3D's index (nanoflann, compiled, answering a whole batch per call) gives the same distances as
scipy's cKDTree about twice as fast on one thread for the few hundred points a query registers;
the index is built on first use, and left out when the cloud is pickled (to a worker process).
"""
from __future__ import annotations

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree


class NearestPoints:
    """cKDTree.query's answer, (distances, indices), for a fixed cloud, by Open3D's index."""

    def __init__(self, points: np.ndarray):
        self.points = np.ascontiguousarray(points, dtype=np.float64)
        self._index = None

    def query(self, x: np.ndarray, k: int = 1) -> tuple[np.ndarray, np.ndarray]:
        """
        Return the distances and indices of each point's k nearest, nearest first.

        As cKDTree.query: (m,) arrays for k = 1, (m, k) for more.
        """
        x = np.ascontiguousarray(np.reshape(x, (-1, 3)), dtype=np.float64)
        if len(x) == 0:
            shape = (0,) if k == 1 else (0, k)
            return np.zeros(shape), np.zeros(shape, dtype=np.int64)
        if self._index is None:
            self._index = o3d.core.nns.NearestNeighborSearch(o3d.core.Tensor(self.points))
            self._index.knn_index()
        idx, d2 = self._index.knn_search(o3d.core.Tensor(x), k)
        dist, idx = np.sqrt(d2.numpy()), idx.numpy().astype(np.int64)
        return (dist[:, 0], idx[:, 0]) if k == 1 else (dist, idx)

    def __getstate__(self) -> dict:
        return {'points': self.points, '_index': None}


# what registration queries: this index, or scipy's cKDTree where a caller (the build) has one
Tree = NearestPoints | cKDTree
