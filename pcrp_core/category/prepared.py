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
A cloud ready to register.

Its points and tree, and for feature matching its sampled points, their features and their symmetry
halves.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pcrp_core.registration.nearest import NearestPoints
from pcrp_core.symmetry import split_halves


@dataclass
class Prepared:
    """
    One cloud ready to register.

    All points and their tree; for feature matching also the sampled points, their features and
    their symmetry halves (None where not computed).
    """

    points: np.ndarray
    tree: NearestPoints
    sampled: np.ndarray | None = None
    features: np.ndarray | None = None
    halves: np.ndarray | None = None
    # what is worked out about a gallery object once and kept as long as it stays in the cache
    _memo: dict = field(default_factory=dict, repr=False)

    def memo(self, key, compute):
        """compute(), worked out on first use for this key and remembered."""
        if key not in self._memo:
            self._memo[key] = compute()
        return self._memo[key]


def prepare(points: np.ndarray, sampled_idx=None, features=None) -> Prepared:
    if sampled_idx is None:
        return Prepared(points, NearestPoints(points))
    sampled = points[sampled_idx]
    return Prepared(points, NearestPoints(points), sampled, features, split_halves(sampled))
