"""k-nearest neighbourhoods, shared by normals, frames and octant aggregation."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree


def knn(points: np.ndarray, centres: np.ndarray, k: int, tree: cKDTree | None = None) -> np.ndarray:
    """(M, k) indices into points of each centre's k nearest neighbours (itself included)."""
    k = min(k, len(points))
    tree = tree if tree is not None else cKDTree(points)
    _, idx = tree.query(centres, k=k)
    return idx.reshape(len(centres), k)
