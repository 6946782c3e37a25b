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
Geometric twins: objects of a gallery whose shapes coincide within a few millimetres.

No depth-only method can tell such objects apart (a depth camera sees shape, not colour or print),
so a benchmark should say which they are before counting a confusion between them as a failure of
the method. Two shapes coincide within `within` when, after the best rigid alignment of one onto
the other, the symmetric chamfer distance (the mean of the two one-way mean nearest-point
distances) is below it.

Distances are measured from sampled points to the other's true surface (ray-casting scene), not to
its samples, which would add the sampling's own spacing (about a millimetre here) to every pair.
Every pair is not aligned: shapes that coincide within 2 mm have nearly equal diameters and
principal spreads, so only pairs within 1 cm of diameter and 4 mm of each principal spread are.
Each is aligned from the 24 ways of laying one's principal axes on the other's (which covers every
pose for which both are near their own principal frames), each refined by ICP, and the best kept.
"""
from __future__ import annotations

import itertools

import numpy as np
import open3d as o3d
from pcrp_core.sources.camera import Mesh

N_POINTS = 1500
DIAMETER_GATE = 0.01
SPREAD_GATE = 0.004
ICP_DISTANCE = 0.01


def _proper_axis_maps() -> list[np.ndarray]:
    """Return the 24 rotations that map the coordinate axes onto the coordinate axes."""
    out = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1, -1), repeat=3):
            M = np.zeros((3, 3))
            M[np.arange(3), perm] = signs
            if np.linalg.det(M) > 0:
                out.append(M)
    return out


class Shape:
    def __init__(self, mesh: Mesh, seed: int = 0):
        m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(mesh.vertices),
                                      o3d.utility.Vector3iVector(mesh.triangles.astype(np.int32)))
        o3d.utility.random.seed(seed)
        pts = np.asarray(m.sample_points_uniformly(N_POINTS).points)
        self.points = pts - pts.mean(0)
        evals, evecs = np.linalg.eigh(np.cov(self.points.T))
        self.spread = np.sqrt(np.maximum(evals[::-1], 0.0))
        self.axes = evecs[:, ::-1] * [
            1,
            1,
            np.linalg.det(evecs[:, ::-1]),
        ]  # columns, a proper frame
        self.diameter = mesh.diameter
        self.pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(self.points))
        self.surface = o3d.t.geometry.RaycastingScene()
        self.surface.add_triangles(
            o3d.core.Tensor((mesh.vertices - pts.mean(0)).astype(np.float32)),
            o3d.core.Tensor(mesh.triangles.astype(np.uint32)),
        )

    def distance(self, points: np.ndarray) -> np.ndarray:
        """Distance of each point (this shape's centred frame) to the surface."""
        return self.surface.compute_distance(o3d.core.Tensor(points.astype(np.float32))).numpy()


def chamfer(a: Shape, b: Shape, R: np.ndarray, t: np.ndarray) -> float:
    """
    Symmetric chamfer of a moved by (R, t) and b.

    The mean of the two one-way mean distances from one's points to the other's surface (metres).
    """
    return float(
        (b.distance(a.points @ R.T + t).mean() + a.distance((b.points - t) @ R).mean()) / 2
    )


def best_alignment(a: Shape, b: Shape) -> float:
    """
    Return the smallest symmetric chamfer between a (moved) and b.

    Over the axis-aligned starts + ICP.
    """
    best = np.inf
    reg = o3d.pipelines.registration
    for M in _proper_axis_maps():
        init = np.eye(4)
        init[:3, :3] = b.axes @ M @ a.axes.T
        T = np.asarray(
            reg.registration_icp(
                a.pcd, b.pcd, ICP_DISTANCE, init, reg.TransformationEstimationPointToPoint()
            ).transformation
        )
        best = min(best, chamfer(a, b, T[:3, :3], T[:3, 3]))
    return best


def find_twins(meshes: dict[str, Mesh], within: float = 0.002, also_nearest: int = 5):
    """
    (twins, nearest, pairs_aligned, scored).

    twins as (id_a, id_b, chamfer) within `within`; nearest: the closest pairs that are not twins
    (for context), up to also_nearest of them; scored: every pair aligned, nearest first.
    """
    shapes = {k: Shape(m) for k, m in meshes.items()}
    scored = []
    for (ka, a), (kb, b) in itertools.combinations(shapes.items(), 2):
        if (
            abs(a.diameter - b.diameter) > DIAMETER_GATE
            or np.abs(a.spread - b.spread).max() > SPREAD_GATE
        ):
            continue
        scored.append((ka, kb, best_alignment(a, b)))
    scored.sort(key=lambda s: s[2])
    return ([s for s in scored if s[2] < within],
            [s for s in scored if s[2] >= within][:also_nearest], len(scored), scored)
