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
How well a posed object explains a cloud from a camera, and the cloud what the object shows.

Two sets of distances decide: from each point of the cloud to the object's surface (is every
measured point on the object?) and from each surface point the camera would see under the pose
to the cloud (is everything the object would show there?). The first alone lets a larger
object swallow a smaller one's view; the second catches it, because the larger one would show
more. Distances are to the local tangent plane where a neighbour is near, so that how densely
either side is sampled does not count as misfit, and each is capped at tau, the distance
beyond which a point is simply not explained (clutter, occlusion, a wrong pose): a truncated
quadratic, the robust cost of a point that is either measured with noise or not there at all.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pcrp_core.instance.occlusion import hidden, Occluders
from scipy.spatial import cKDTree


@dataclass
class Surface:
    """A cloud with what the distances need: its tree, normals and point spacing."""

    points: np.ndarray
    normals: np.ndarray
    tree: cKDTree
    spacing: float
    # a query cloud given the rest of its scene: what the camera saw in front of it (occlusion.py)
    occluders: Occluders | None = None
    # a query cloud cut at the table (support.py): (up, the height along it under which its
    # points were set aside)
    floor: tuple[np.ndarray, float] | None = None


def local_planes(points: np.ndarray, tree: cKDTree, k: int = 10) -> tuple[np.ndarray, np.ndarray]:
    """Fit a plane to each point's k nearest neighbours: (normals (N, 3), residual rms (N,))."""
    k = min(k, len(points))
    nb = points[tree.query(points, k)[1]]
    centred = nb - nb.mean(axis=1, keepdims=True)
    eig, vec = np.linalg.eigh(centred.transpose(0, 2, 1) @ centred / k)
    return vec[:, :, 0], np.sqrt(np.maximum(eig[:, 0], 0.0))


def query_surface(points: np.ndarray) -> tuple[Surface, float]:
    """
    Return the cloud as a Surface, and its noise.

    The noise is the median distance of points from the planes of their neighbourhoods (the range
    noise of the camera as this cloud shows it).
    """
    tree = cKDTree(points)
    normals, residual = local_planes(points, tree)
    spacing = float(np.median(tree.query(points, 2)[0][:, 1]))
    return Surface(points, normals, tree, spacing), float(np.median(residual))


def distances(points: np.ndarray, surface: Surface, k: int = 3) -> np.ndarray:
    """
    Return the (N,) distance from each point to the surface.

    To the nearest of the tangent planes of its k nearest surface points that lie within two
    spacings (at an edge, one of them is on the right face), else to the nearest point itself.
    """
    d, i = surface.tree.query(points, k)
    along_normal = np.abs(
        np.einsum('nkj,nkj->nk', points[:, None] - surface.points[i], surface.normals[i])
    )
    near = d < 2.0 * surface.spacing
    return np.where(near.any(axis=1), np.where(near, along_normal, np.inf).min(axis=1), d[:, 0])


def visible_points(visible: np.ndarray, directions: np.ndarray, centre: np.ndarray, R: np.ndarray,
                   t: np.ndarray) -> np.ndarray:
    """
    Return the object's surface points a camera at the origin sees under pose (R, t), as indices.

    Those seen from the stored visibility direction nearest the camera's.
    """
    camera = -R.T @ t
    return np.flatnonzero(visible[int(np.argmax(directions @ (camera - centre)))])


@dataclass
class Fit:
    """
    The verdict on one posed object.

    Its cost (lower is better), made of the mean capped squared distance of the cloud to the object
    (unexplained) and of the expected surface to the cloud (unshown), in units of tau squared, each
    in [0, 1]; the shares of cloud points on the object (fit) and of expected surface points in the
    cloud (coverage), both within tau; and the rms of the explained distances.
    """

    cost: float
    unexplained: float
    unshown: float
    fit: float
    coverage: float
    rms: float
    n_expected: int
    median_off: float = 0.0       # median distance of the cloud's points to the object
    median_missing: float = 0.0   # median distance of the expected surface points to the cloud
    n_hidden: int = 0             # expected surface points the scene shows hidden, not counted

    @property
    def hidden_share(self) -> float:
        """Share of the surface the camera would see under the pose that the scene hid."""
        return self.n_hidden / max(self.n_expected + self.n_hidden, 1)


def judge(query: Surface, surface: Surface, expected: np.ndarray, R: np.ndarray, t: np.ndarray,
          tau: float, unshown_weight: float = 1.0) -> Fit:
    """
    Return the Fit of the object (surface, in its own frame) at pose (R, t) to the query.

    expected: indices of the surface points the camera would see (less those the query's
    occluders hide, and those under its floor). unshown_weight: how much an expected point
    missing from the cloud costs against a cloud point off the object (less than 1: the segmenter
    may have cut away what something in front of the object hid).
    """
    to_object = distances((query.points - t) @ R, surface)
    shown = surface.points[expected] @ R.T + t
    n_hidden = 0
    if query.occluders is not None and len(expected):
        keep = ~hidden(shown, query.occluders, tau)
        n_hidden = int(len(keep) - keep.sum())
        expected, shown = expected[keep], shown[keep]
    if query.floor is not None and len(expected):
        # the cloud lost what lay that low with the table; the object's surface there too
        up, top = query.floor
        keep = shown @ up >= top
        expected, shown = expected[keep], shown[keep]
    if len(expected):
        to_query = distances(shown, query)
    else:
        to_query = np.full(1, np.inf)
    unexplained = float(np.mean(np.minimum(to_object, tau) ** 2)) / tau ** 2
    unshown = float(np.mean(np.minimum(to_query, tau) ** 2)) / tau ** 2
    inside = to_object < tau
    rms = float(np.sqrt(np.mean(to_object[inside] ** 2))) if inside.any() else float(tau)
    return Fit(unexplained + unshown_weight * unshown, unexplained, unshown, float(inside.mean()),
               float(np.mean(to_query < tau)), rms, len(expected), float(np.median(to_object)),
               float(np.median(to_query)), n_hidden)
