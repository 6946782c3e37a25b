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

"""FPFH from Open3D, on normals oriented so that the descriptor rotates with the cloud."""
from __future__ import annotations

import numpy as np
import open3d as o3d


def oriented_normals(
    points: np.ndarray, k: int = 20, viewpoint: np.ndarray | None = None
) -> np.ndarray:
    """
    Return unit normals pointing away from the centroid.

    Or towards the sensor when its position (viewpoint) is known.

    Open3D's estimated normals have arbitrary signs, and FPFH changes with them. Both rules
    are rotation-invariant and give outward normals: the centroid rule on complete objects
    (the gallery), the sensor rule on what a depth camera sees, whose centroid lies off the
    object's and would flip the normals of whole surfaces.
    """
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    pcd.estimate_normals(o3d.geometry.KDTreeSearchParamKNN(knn=k))
    normals = np.asarray(pcd.normals)
    if viewpoint is None:
        outward = np.einsum('ni,ni->n', normals, points - points.mean(axis=0))
    else:
        outward = np.einsum('ni,ni->n', normals, viewpoint - points)
    return normals * np.where(outward < 0, -1.0, 1.0)[:, None]


def fpfh(points: np.ndarray, normals: np.ndarray, radius: float, max_nn: int = 100) -> np.ndarray:
    """(N, 33) FPFH histograms, each scaled to sum to 1 (Open3D's sum to 300 per point)."""
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    pcd.normals = o3d.utility.Vector3dVector(normals)
    feat = o3d.pipelines.registration.compute_fpfh_feature(
        pcd, o3d.geometry.KDTreeSearchParamHybrid(radius=radius, max_nn=max_nn))
    hist = np.asarray(feat.data).T
    return hist / np.maximum(hist.sum(axis=1, keepdims=True), 1e-12)
