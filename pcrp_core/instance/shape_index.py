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
The objects whose views have a query's shape: the shortlist's search.

An object's gap is the distance from the query's shape code (its spread in log metres) to that
of the object's nearest view, where along each axis a query smaller than the view counts
`weight` times as much as one larger. Scanning every view of every object costs in proportion to
the gallery (20 ms at 10,000 objects of 64 views); a KD-tree of the views answers in a time that
barely grows. The weighted distance is not the tree's Euclidean one, but it is at least
min(1, weight) times it, which bounds what a view the tree has not returned can score: the search
widens until no such view can beat the objects found, so the answer is the scan's, exactly.
"""

from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree

# below this many views a scan takes under a millisecond and needs no tree
SCAN_VIEWS = 20_000


class ShapeIndex:
    """The shape codes of each object's views, (objects, views, 3), searched by gap."""

    def __init__(self, shapes: np.ndarray, scan_views: int = SCAN_VIEWS):
        self.shapes = shapes
        n_objects, n_views = shapes.shape[:2]
        self._tree = (
            cKDTree(np.asarray(shapes, dtype=np.float64).reshape(-1, 3))
            if n_objects * n_views > scan_views
            else None
        )

    def gaps(self, shape: np.ndarray, weight: float, objects=slice(None)) -> np.ndarray:
        """
        Return each object's gap (all objects, or those indexed by objects).

        A smaller query counts less because an occluder cuts a view down, while a cloud larger
        than every view of an object is not that object.
        """
        d = shape - self.shapes[objects]
        d = np.where(d < 0, weight * d, d)
        return np.linalg.norm(d, axis=-1).min(axis=-1)

    def nearest(self, shape: np.ndarray, k: int, weight: float, exclude=()):
        """
        Return (indices, gaps) of the k objects of smallest gap, nearest first.

        Equal gaps in index order; objects in exclude are never returned.
        """
        n_objects, n_views = self.shapes.shape[:2]
        excluded = np.zeros(n_objects, bool)
        excluded[list(exclude)] = True
        k = int(min(k, n_objects - excluded.sum()))
        if k <= 0:
            return np.zeros(0, np.int64), np.zeros(0)
        if self._tree is None:
            return _first(np.flatnonzero(~excluded), self.gaps(shape, weight)[~excluded], k)
        reach = min(1.0, weight)   # a view at Euclidean distance e has a gap of at least reach * e
        total = n_objects * n_views
        asked = min(16 * k, total)
        while True:
            distance, flat = self._tree.query(shape, asked)
            found = np.unique(np.atleast_1d(flat) // n_views)
            found = found[~excluded[found]]
            # every view of an object not found lies beyond the farthest view returned; all views
            # returned find every object left, at least k
            if len(found) >= k:
                index, gap = _first(found, self.gaps(shape, weight, found), k)
                if asked == total or gap[-1] <= reach * np.max(distance):
                    return index, gap
            asked = min(4 * asked, total)


def _first(objects: np.ndarray, gaps: np.ndarray, k: int):
    order = np.lexsort((objects, gaps))[:k]
    return objects[order], gaps[order]
