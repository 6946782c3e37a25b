"""FPFH from Open3D, on normals oriented so that the descriptor rotates with the cloud."""
from __future__ import annotations

import numpy as np
import open3d as o3d


def oriented_normals(points: np.ndarray, k: int = 20) -> np.ndarray:
    """Unit normals pointing away from the centroid.

    Open3D's estimated normals have arbitrary signs, and FPFH changes with them; the
    centroid rule is rotation-invariant and needs no camera position, so gallery objects
    (complete) and queries (often one-sided) follow the same rule.
    """
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=k))
    normals = np.asarray(pcd.normals)
    outward = np.einsum("ni,ni->n", normals, points - points.mean(axis=0))
    return normals * np.where(outward < 0, -1.0, 1.0)[:, None]


def fpfh(points: np.ndarray, normals: np.ndarray, radius: float, max_nn: int = 100) -> np.ndarray:
    """(N, 33) FPFH histograms, each scaled to sum to 1 (Open3D's sum to 300 per point)."""
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    pcd.normals = o3d.utility.Vector3dVector(normals)
    feat = o3d.pipelines.registration.compute_fpfh_feature(
        pcd, o3d.geometry.KDTreeSearchParamHybrid(radius=radius, max_nn=max_nn))
    hist = np.asarray(feat.data).T
    return hist / np.maximum(hist.sum(axis=1, keepdims=True), 1e-12)
