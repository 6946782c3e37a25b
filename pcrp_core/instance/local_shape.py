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
Poses from matched local shape: FPFH of the cloud and of an object, matched, in RANSAC.

The view hypotheses (hypotheses.py) place an object by the centroid and silhouette of what the
camera saw. When something in front hides part of the object both move, and the right object's
poses start in another basin, which ICP does not leave. The shape of the surface around a
point does not move with what is hidden, so matches of it find the pose still; at a cost of tens
of milliseconds an object, which is why the matcher asks for them only when its answer fits
poorly. Open3D's C++ does the RANSAC.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import open3d as o3d

REG = o3d.pipelines.registration
# fewer mutual matches than this and every cloud point keeps its nearest: the rule of Open3D's own
# feature matcher (three times the three points a RANSAC draw takes)
LEAST_MUTUAL = 9


@dataclass
class LocalShape:
    """A cloud thinned on a voxel grid, with the FPFH of each of its points."""

    cloud: o3d.geometry.PointCloud
    features: np.ndarray    # (n, 33) float32, a row per point
    norms: np.ndarray       # (n,) the rows' squared lengths

    @property
    def points(self) -> o3d.geometry.PointCloud:
        # without normals: RANSAC copies and moves its whole source cloud for every draw that
        # passes the checkers, to count how much of it then lies near the object
        return o3d.geometry.PointCloud(self.cloud.points)


def _describe(cloud: o3d.geometry.PointCloud, radius: float) -> LocalShape:
    search = o3d.geometry.KDTreeSearchParamHybrid(radius=radius, max_nn=100)
    # float32: the bins are percentages, and single precision halves what the matches' matrix
    # product and its minima read, their cost
    features = np.ascontiguousarray(
        np.asarray(REG.compute_fpfh_feature(cloud, search).data).T, dtype=np.float32
    )
    return LocalShape(cloud, features, np.einsum('ij,ij->i', features, features))


def of_object(points: np.ndarray, normals: np.ndarray, voxel: float, radius: float) -> LocalShape:
    """Describe an object's surface points (its frame), given their outward normals."""
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.array(points, dtype=np.float64)))
    cloud.normals = o3d.utility.Vector3dVector(np.array(normals, dtype=np.float64))
    # thinned like the cloud, so that both sides' histograms count neighbours alike
    cloud = cloud.voxel_down_sample(voxel)
    cloud.normalize_normals()
    return _describe(cloud, radius)


def of_cloud(points: np.ndarray, voxel: float, radius: float) -> LocalShape:
    """Describe a camera's cloud (its frame, camera at the origin), normals towards the camera."""
    cloud = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points)).voxel_down_sample(voxel)
    # normals from a fixed radius rather than a number of neighbours: the object's and the
    # cloud's are then estimated over the same patch of surface, however densely each is sampled
    cloud.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=2.0 * voxel, max_nn=30))
    cloud.orient_normals_towards_camera_location(np.zeros(3))
    return _describe(cloud, radius)


def matches(cloud: LocalShape, obj: LocalShape) -> np.ndarray:
    """
    Return (k, 2) pairs (cloud point, object point) whose FPFH are each other's nearest.

    Or, when fewer than LEAST_MUTUAL are, every cloud point with its nearest: the pairs Open3D's
    feature matcher gives, but for which of two equally near features is taken. Every distance
    comes from one matrix product (a cloud has a few hundred points, an object a few thousand),
    where that matcher built a KD-tree of each side's 33-dimensional features on every call: a
    third of what local shape took an object.
    """
    if not len(cloud.features) or not len(obj.features):
        return np.zeros((0, 2), dtype=np.int32)
    # squared distances, less the cloud row's own length, which no row's nearest depends on
    d = obj.norms[None, :] - 2.0 * (cloud.features @ obj.features.T)
    nearest = d.argmin(axis=1)
    # nearest back only from the object points some cloud point chose: no other can be mutual
    chosen, column = np.unique(nearest, return_inverse=True)
    back = (d[:, chosen] + cloud.norms[:, None]).argmin(axis=0)
    rows = np.flatnonzero(back[column] == np.arange(len(nearest)))
    if len(rows) < LEAST_MUTUAL:
        rows = np.arange(len(nearest))
    return np.stack([rows, nearest[rows]], axis=1).astype(np.int32)


def pose(cloud: LocalShape, obj: LocalShape, distance: float, iterations: int,
         seed: int) -> tuple[np.ndarray, np.ndarray]:
    """
    Return the object's pose in the cloud's frame, (R, t): p_cloud = R @ p_object + t.

    From mutual nearest FPFH matches, triples of which must keep their lengths (to 10 %) and
    land within distance of each other (Open3D's RANSAC checkers).
    """
    o3d.utility.random.seed(seed)
    result = REG.registration_ransac_based_on_correspondence(
        cloud.points,
        obj.cloud,
        o3d.utility.Vector2iVector(matches(cloud, obj)),
        distance,
        REG.TransformationEstimationPointToPoint(False),
        3,
        [
            REG.CorrespondenceCheckerBasedOnEdgeLength(0.9),
            REG.CorrespondenceCheckerBasedOnDistance(distance),
        ],
        REG.RANSACConvergenceCriteria(iterations, 0.999),
    )
    T = np.asarray(result.transformation)    # takes the cloud onto the object
    R = T[:3, :3].T
    return R, -R @ T[:3, 3]
