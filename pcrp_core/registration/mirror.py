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
Mirror planes: finish a whole object's pose by laying its mirror plane on its gallery object's.

Most man-made objects are mirror-symmetric (the left and right of a chair, a car, an
airplane), and a pre-aligned gallery puts that plane on a coordinate plane. ICP between two
instances of a category leaves the pose off by however the two differ, in any direction. The
query's own mirror plane is found far more precisely, since its two halves are one shape
(about 0.1 degree on ModelNet40 airplanes), and it fixes two of the three rotation angles: the
ones that tilt the plane. The turn about the plane's normal is left to ICP.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pcrp_core.geometry import rotation_taking
from pcrp_core.registration.icp import icp
from pcrp_core.registration.nearest import Tree

# the share of points whose mirror images are scored and matched: a few parts of a symmetric
# object are not (a door handle on one side), and sampling leaves some images in gaps
TRIM = 0.9


@dataclass
class MirrorPlane:
    """
    A mirror plane {x : normal . x = offset}, with its fit.

    rms: how far the mirrored points land from the cloud (trimmed root mean square); residual: the
    same in units of the cloud's point spacing (about 1 for a mirror-symmetric cloud).
    """

    normal: np.ndarray
    offset: float
    residual: float
    rms: float


def spacing(points: np.ndarray, tree: Tree) -> float:
    """Median distance from a point to its nearest neighbour."""
    return float(np.median(tree.query(points, 2)[0][:, 1]))


def trimmed_rms(dist: np.ndarray) -> float:
    """Root mean square of the TRIM share of smallest distances."""
    k = max(1, int(TRIM * len(dist)))
    return float(np.sqrt(np.mean(np.partition(dist, k - 1)[:k] ** 2)))


def mirror_plane(
    points: np.ndarray, tree: Tree, near: np.ndarray, iterations: int = 30
) -> MirrorPlane:
    """
    Return the mirror plane of a cloud found from the plane through its centroid normal to near.

    The cloud's mirror image in that plane is registered onto the cloud by ICP; the registered
    reflection x -> L x + b is then a reflection in the true plane, L = I - 2 n n^T, b = 2 d n.
    """
    near = np.asarray(near, dtype=np.float64) / np.linalg.norm(near)
    centre = points.mean(axis=0)
    M = np.eye(3) - 2 * np.outer(near, near)
    mirrored = (points - centre) @ M + centre          # M is symmetric: rows times M mirror them
    Rm, tm = icp(mirrored, points, tree, np.eye(3), np.zeros(3), iterations, TRIM, 1e-12)
    L = Rm @ M
    b = Rm @ (centre - M @ centre) + tm
    # L has one eigenvalue -1 (the normal) and two +1 within ICP's error; its symmetric part's
    # lowest eigenvector is the normal however slightly ICP turned the image in the plane
    normal = np.linalg.eigh((L + L.T) / 2)[1][:, 0]
    normal = normal if normal @ near >= 0 else -normal
    rms = trimmed_rms(tree.query(mirrored @ Rm.T + tm)[0])
    return MirrorPlane(normal, float(normal @ b) / 2, rms / spacing(points, tree), rms)


def gallery_mirror(
    points: np.ndarray, tree: Tree, tolerance: float, max_deg: float
) -> MirrorPlane | None:
    """
    Return a pre-aligned gallery object's mirror plane.

    Or None when it has none near a coordinate plane.

    The coordinate plane through the centroid whose mirror images land closest is refined, since
    objects are aligned by hand and sampled unevenly: it must stay within max_deg of that plane
    and its images land within tolerance point spacings (mirror-symmetric ModelNet40 objects:
    0.9-1.05; other axes of the same objects: 1.15 and up).
    """
    centre, gap = points.mean(axis=0), spacing(points, tree)
    residuals = []
    for axis in range(3):
        mirrored = points.copy()
        mirrored[:, axis] = 2 * centre[axis] - mirrored[:, axis]
        residuals.append(trimmed_rms(tree.query(mirrored)[0]) / gap)
    axis = int(np.argmin(residuals))
    plane = mirror_plane(points, tree, np.eye(3)[axis])
    if (
        plane.residual >= tolerance
        or np.degrees(np.arccos(min(1.0, plane.normal[axis]))) > max_deg
    ):
        return None
    return plane


def snap(R: np.ndarray, t: np.ndarray, plane: MirrorPlane, target: MirrorPlane,
         query_centre: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """
    Pose (R, t), mapping the query into the gallery's frame (x_g = R x_q + t).

    Turned the least so that the query's mirror plane (in the query's frame) becomes the gallery's
    (target): a turn about the query's centroid, then a shift along the plane's normal.
    """
    # the shortest turn between two single vectors (as hypotheses.py aligns up axes)
    C = rotation_taking(R @ plane.normal, target.normal)
    c = R @ query_centre + t
    R2, t2 = C @ R, C @ (t - c) + c
    on_plane = R2 @ (plane.offset * plane.normal) + t2
    return R2, t2 + (target.offset - on_plane @ target.normal) * target.normal


def plane_row(plane: MirrorPlane | None) -> np.ndarray:
    """
    Return (normal, offset) of a gallery object's plane as 4 numbers, NaN where it has none.

    What a model stores so that no query waits for the plane of an object it retrieves.
    """
    if plane is None:
        return np.full(4, np.nan)
    return np.append(plane.normal, plane.offset)


def plane_from_row(row: np.ndarray) -> MirrorPlane | None:
    """
    Return the stored plane of plane_row().

    Its residual and rms are not kept (no use reads them).
    """
    row = np.asarray(row, dtype=np.float64)
    if not np.isfinite(row).all():
        return None
    return MirrorPlane(row[:3] / np.linalg.norm(row[:3]), float(row[3]), np.nan, np.nan)
