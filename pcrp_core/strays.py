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
Points of a camera's view that lie apart from the object: what a segmenter's mask took in.

A mask a little too wide takes in background pixels behind the object's outline and the flying
pixels a depth camera measures at its edges (depths between the object's and the background's);
a loose cluster takes in a speck of something else. A few dozen such points among thousands
threw the answer off: farthest-point sampling keeps every one of them, and the view's shape (its
spread along its principal axes, which shortlists the objects) is theirs. Validation views (seed
1000, 78 YCB objects free in space, docs/results/SEGMENTATION_validation.md) with 20 points in a
blob behind the object: 17 % posed right against 99 % clean; half the outline's pixels flying:
13 %; the mask a pixel too wide: 6 %.

The points are linked to their nearest neighbours within LINK_SPACINGS spacings; the object is
the largest linked group. A group is a stray when it is a speck (at most SPECK points: flying
pixels lie alone between an edge and the background), or lies farther from the object than
reach (the largest gallery object's diameter: no object of the gallery spans that far, so this
never cuts a view of one), or is small (under SMALL_SHARE of the points) and lies farther from
the object than FAR_SHARE of its size. Chosen on the validation views, with the share of clean
views it changes (a sparse face seen edge-on, a part cut off by an occluder) kept near nil.
"""
from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

NEIGHBOURS = 8          # linked at most to this many nearest points: cost O(n), a radius is not
LINK_SPACINGS = 12.0    # a face seen edge-on is sparse: its points lie several spacings apart
SPECK = 4
SMALL_SHARE = 0.05
FAR_SHARE = 0.5


def strays(points: np.ndarray, reach: float) -> np.ndarray:
    """
    Return a mask of the points that lie apart from the object (see the module's docstring).

    points: (N, 3) one camera's view of one object, duplicates merged; reach: the largest
    gallery object's diameter, in the points' units. All False when nothing lies apart.
    """
    n = len(points)
    if n <= NEIGHBOURS:
        return np.zeros(n, dtype=bool)
    # an unbalanced tree builds in half the time and answers these queries as fast
    tree = cKDTree(points, balanced_tree=False, compact_nodes=False)
    dist, idx = tree.query(points, k=NEIGHBOURS + 1)
    spacing = float(np.median(dist[:, 1]))
    linked = dist[:, 1:] <= LINK_SPACINGS * spacing
    rows = np.repeat(np.arange(n), NEIGHBOURS)[linked.ravel()]
    graph = coo_matrix((np.ones(len(rows)), (rows, idx[:, 1:][linked])), shape=(n, n))
    count, group = connected_components(graph, directed=False)
    if count == 1:
        return np.zeros(n, dtype=bool)
    sizes = np.bincount(group)
    main = int(np.argmax(sizes))
    body = points[group == main]
    size = float(np.linalg.norm(np.ptp(body, axis=0)))
    # each group's gap to the object: the least distance of its points to the object's
    others = group != main
    gaps = np.full(count, np.inf)
    np.minimum.at(gaps, group[others], cKDTree(body).query(points[others])[0])
    small_and_far = (sizes < SMALL_SHARE * n) & (gaps > FAR_SHARE * size)
    apart = (sizes <= SPECK) | (gaps > reach) | small_and_far
    apart[main] = False
    return apart[group]
