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
Trimmed point-to-point ICP: refine a pose by pulling the query onto the gallery surface.

Trimming keeps only the closest share of matches each iteration, so a partial view, clutter left by
the segmenter, or parts in which two instances of a category differ do not pull the pose away.
"""
from __future__ import annotations

import numpy as np
from pcrp_core.registration.nearest import NearestPoints, Tree
from pcrp_core.registration.procrustes import procrustes, procrustes_batch


def icp(src: np.ndarray, dst: np.ndarray, dst_tree: Tree, R: np.ndarray, t: np.ndarray,
        iterations: int = 20, trim: float = 0.8, tolerance: float = 1e-6):
    """Refined R, t with dst ≈ R @ src + t."""
    keep = max(3, int(trim * len(src)))
    prev = np.inf
    for _ in range(iterations):
        dist, nn = dst_tree.query(src @ R.T + t)
        order = np.argpartition(dist, keep - 1)[:keep]
        R, t = procrustes(src[order], dst[nn[order]])
        err = float(np.mean(dist[order] ** 2))
        if prev - err < tolerance:
            break
        prev = err
    return R, t


def transform_batch(src: np.ndarray, R: np.ndarray, t: np.ndarray) -> np.ndarray:
    """
    (H, n, 3): src (n, 3) moved by each of the poses R (H, 3, 3), t (H, 3).

    One 2-D product with the rotations side by side; numpy's stacked matmul of 3x3 blocks is
    several times slower.
    """
    h, n = len(R), len(src)
    side = R.transpose(2, 0, 1).reshape(3, 3 * h)              # [R_0^T | R_1^T | ...]
    return (src @ side).reshape(n, h, 3).transpose(1, 0, 2) + t[:, None, :]


def icp_batch(
    src: np.ndarray,
    dst: np.ndarray,
    dst_tree: Tree,
    R: np.ndarray,
    t: np.ndarray,
    iterations: int = 20,
    trim: float = 0.8,
    tolerance: float = 1e-6,
    prev=None,
    state: bool = False,
):
    """
    icp() for many starting poses at once: R (H, 3, 3), t (H, 3) -> refined R, t.

    Each pose iterates and stops exactly as icp() would, but one tree query and one batched
    Procrustes serve all poses still moving: per-call overhead, not arithmetic, is what a few
    hundred points per query cost in Python.

    state=True also returns each pose's last error and whether it was still moving; passing that
    error back as prev resumes the run, so n iterations then m more give exactly what n + m
    iterations at once would.
    """
    R, t = np.array(R, dtype=np.float64), np.array(t, dtype=np.float64)
    keep = max(3, int(trim * len(src)))
    prev = np.full(len(R), np.inf) if prev is None else np.array(prev, dtype=np.float64)
    active = np.arange(len(R))
    for _ in range(iterations):
        if len(active) == 0:
            break
        moved = transform_batch(src, R[active], t[active])
        dist, nn = dst_tree.query(moved.reshape(-1, 3))
        dist, nn = dist.reshape(len(active), -1), nn.reshape(len(active), -1)
        order = np.argpartition(dist, keep - 1, axis=1)[:, :keep]
        R[active], t[active] = procrustes_batch(
            np.take(src, order, axis=0), np.take(dst, np.take_along_axis(nn, order, 1), axis=0)
        )
        err = np.mean(np.take_along_axis(dist, order, 1) ** 2, axis=1)
        moving = prev[active] - err >= tolerance
        prev[active] = err
        active = active[moving]
    if state:
        moving = np.zeros(len(R), bool)
        moving[active] = True
        return R, t, prev, moving
    return R, t


def icp_symmetric(
    src: np.ndarray,
    dst: np.ndarray,
    dst_tree: Tree,
    R: np.ndarray,
    t: np.ndarray,
    iterations: int = 20,
    trim: float = 0.8,
    tolerance: float = 1e-7,
    reverse_points: int = 256,
    reverse_trim: float | None = None,
    dense_src: np.ndarray | None = None,
    dense_tree: Tree | None = None,
):
    """
    icp() with matches taken both ways.

    Each query point to its nearest gallery point and each gallery point to its nearest posed query
    point, trimmed separately, solved together.

    Two instances of a category never coincide: pulling only the query onto the gallery lets a
    part the gallery object lacks (a thicker back, a deeper seat) tilt the pose until the query's
    points sit somewhere on the gallery's surface. Matches the other way pull just as hard from
    the gallery's side, so the pose settles where the two shapes are centred on each other.

    dense_src: all of the query's points, for the gallery's matches: a point's nearest neighbour
    among a few hundred query points lies off the surface by about their spacing, in a direction
    that is the same for neighbouring gallery points, which biases the pose of even the very
    object. dense_tree: its tree, when the caller has one. The gallery's points are taken back into
    the query's frame for their matches, so that one tree serves every iteration.
    """
    dense = src if dense_src is None else dense_src
    g = dst[:: max(1, len(dst) // reverse_points)]
    reverse_trim = trim if reverse_trim is None else reverse_trim
    keep_q, keep_g = max(3, int(trim * len(src))), max(3, int(reverse_trim * len(g)))
    dense_tree = NearestPoints(dense) if dense_tree is None else dense_tree
    prev = np.inf
    for _ in range(iterations):
        moved = src @ R.T + t
        d_q, nn_q = dst_tree.query(moved)
        d_g, nn_g = dense_tree.query((g - t) @ R)
        o_q = np.argpartition(d_q, keep_q - 1)[:keep_q]
        o_g = np.argpartition(d_g, keep_g - 1)[:keep_g]
        R, t = procrustes(
            np.vstack([src[o_q], dense[nn_g[o_g]]]), np.vstack([dst[nn_q[o_q]], g[o_g]])
        )
        err = float(np.mean(d_q[o_q] ** 2) + np.mean(d_g[o_g] ** 2))
        if prev - err < tolerance:
            break
        prev = err
    return R, t


def icp_point_to_plane(
    source, target, R: np.ndarray, t: np.ndarray, stages
) -> tuple[np.ndarray, np.ndarray]:
    """
    Run Open3D's point-to-plane ICP of the cloud source onto target.

    Open3D's is compiled, robust to outliers with a Tukey loss; target is an Open3D PointCloud with
    normals; it starts from the pose that takes target into source's frame (p_source = R @ p_target
    + t). stages: (max correspondence distance, Tukey width, iterations), coarse to fine. Returns
    the refined pose, in the same direction.
    """
    import open3d as o3d

    reg = o3d.pipelines.registration
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = R.T, -R.T @ t          # Open3D moves the source onto the target
    for distance, width, iterations in stages:
        T = reg.registration_icp(
            source,
            target,
            distance,
            T,
            reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=width)),
            reg.ICPConvergenceCriteria(max_iteration=int(iterations)),
        ).transformation
    Rq, tq = T[:3, :3], T[:3, 3]
    return Rq.T, -Rq.T @ tq
