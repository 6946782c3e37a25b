"""A cloud ready to register: its points and tree, and for feature matching its sampled points,
their features and their symmetry halves."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from pcrp_core.symmetry import split_halves


@dataclass
class Prepared:
    """One cloud ready to register: all points and their tree; for feature matching also the
    sampled points, their features and their symmetry halves (None where not computed)."""

    points: np.ndarray
    tree: cKDTree
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
        return Prepared(points, cKDTree(points))
    sampled = points[sampled_idx]
    return Prepared(points, cKDTree(points), sampled, features, split_halves(sampled))
