"""Which points of a cloud a sensor at a given position sees (Open3D hidden point removal)."""
from __future__ import annotations

import numpy as np
import open3d as o3d


def visible_from(points: np.ndarray, camera: np.ndarray) -> np.ndarray:
    """Indices of the points visible from `camera`."""
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    diameter = np.linalg.norm(points.max(0) - points.min(0))
    _, idx = pcd.hidden_point_removal(np.asarray(camera, dtype=np.float64), diameter * 100)
    return np.asarray(idx)
