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
The classical pipelines a user would otherwise reach for.

Built from Open3D as its tutorials do, with the settings measured to work best on this data:
normals oriented away from the centroid (as our FPFH hop does), FPFH radius 0.30 on unit-sphere
objects, FGR with `decrease_mu`, RANSAC with edge-length and distance checkers, each followed by
point-to-point ICP. Each takes the query cloud and a prepared target and returns the 4x4 transform
that moves the query onto the target (p_target = T @ p_query).
"""

from __future__ import annotations

import numpy as np
import open3d as o3d
from pcrp_core.features.fpfh import oriented_normals

REG = o3d.pipelines.registration
FPFH_RADIUS = 0.30
DISTANCE = 0.075      # correspondence distance for FGR/RANSAC, in unit-sphere units
ICP_DISTANCE = 0.05


def quiet() -> None:
    """
    Open3D warns on every FGR run whose mutual filter leaves few matches.

    An evaluation of hundreds of runs would drown its progress in them.
    """
    o3d.utility.set_verbosity_level(o3d.utility.VerbosityLevel.Error)


def with_fpfh(points: np.ndarray):
    """(point cloud with oriented normals, its FPFH): what an Open3D user computes per cloud."""
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(points, dtype=np.float64)))
    pcd.normals = o3d.utility.Vector3dVector(oriented_normals(np.asarray(pcd.points)))
    feature = REG.compute_fpfh_feature(
        pcd, o3d.geometry.KDTreeSearchParamHybrid(radius=FPFH_RADIUS, max_nn=100)
    )
    return pcd, feature


prepare_target = with_fpfh


def _icp(src, tgt, init) -> np.ndarray:
    return REG.registration_icp(
        src, tgt, ICP_DISTANCE, init, REG.TransformationEstimationPointToPoint()
    ).transformation


def fgr_icp(query: np.ndarray, target) -> np.ndarray:
    src, src_f = with_fpfh(query)
    tgt, tgt_f = target
    option = REG.FastGlobalRegistrationOption(
        maximum_correspondence_distance=DISTANCE, decrease_mu=True
    )
    coarse = REG.registration_fgr_based_on_feature_matching(src, tgt, src_f, tgt_f, option)
    return np.asarray(_icp(src, tgt, coarse.transformation))


def ransac_icp(query: np.ndarray, target, seed: int = 0) -> np.ndarray:
    o3d.utility.random.seed(seed)
    src, src_f = with_fpfh(query)
    tgt, tgt_f = target
    coarse = REG.registration_ransac_based_on_feature_matching(
        src,
        tgt,
        src_f,
        tgt_f,
        True,
        DISTANCE,
        REG.TransformationEstimationPointToPoint(False),
        3,
        [
            REG.CorrespondenceCheckerBasedOnEdgeLength(0.9),
            REG.CorrespondenceCheckerBasedOnDistance(DISTANCE),
        ],
        REG.RANSACConvergenceCriteria(100000, 0.999),
    )
    return np.asarray(_icp(src, tgt, coarse.transformation))


def icp_only(query: np.ndarray, target) -> np.ndarray:
    """ICP from the centroids' offset: what registration without features can do."""
    src = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(np.asarray(query, dtype=np.float64)))
    tgt = target[0]
    init = np.eye(4)
    init[:3, 3] = np.asarray(tgt.get_center()) - np.asarray(src.get_center())
    return np.asarray(_icp(src, tgt, init))


OPEN3D_PIPELINES = {'fpfh_fgr_icp': fgr_icp, 'fpfh_ransac_icp': ransac_icp}
