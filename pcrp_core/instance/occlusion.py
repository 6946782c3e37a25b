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
What the camera saw in front of an object: surface hidden behind it is not missing.

A partly hidden object's cloud lacks the surface behind whatever hid it, and the verifier
(verification.py) counts expected surface the cloud lacks against the pose: a right pose then
pays for the occluder. Given the rest of what the camera measured (the scene: its whole depth
cloud, or whatever of it lies in front of the object), an expected point is hidden when the
scene holds a point on nearly the same ray more than tau nearer the camera that is not the
object's own cloud. The camera could not have seen the point, so its absence says nothing: the
visibility test BOP's VSD makes with the depth image. Points of the object's own cloud never
hide: a pose that puts the object behind its own measured surface is wrong, and the cloud's
points it leaves unexplained say so.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pcrp_core.instance.depth_image import DepthImage
from scipy.ndimage import minimum_filter


MAX_CELLS = 1024


@dataclass
class Occluders:
    """
    The nearest depth the scene measured on each cell of rays around an object: a depth image.

    Cells are squares in ray coordinates (x / z, y / z) about as wide as the object's cloud's
    point spacing; inf where nothing can hide the object (nothing measured in front, or the object
    itself was seen there).
    """

    near: np.ndarray      # (nx, ny) metres
    origin: np.ndarray    # (2,) ray coordinates of cell [0, 0]'s corner
    cell: float | np.ndarray   # a cell's side in ray coordinates, or its two sides


def _rays(points: np.ndarray) -> np.ndarray:
    return points[:, :2] / points[:, 2:3]


def _window(cloud: np.ndarray, reach: float) -> tuple[np.ndarray, np.ndarray]:
    """Return the corners (ray coordinates) of the cloud's rays widened by reach at its nearest."""
    own = _rays(cloud)
    widen = reach / max(float(cloud[:, 2].min()), 1e-6)
    return own.min(axis=0) - widen, own.max(axis=0) + widen


def in_reach(scene, cloud: np.ndarray, reach: float):
    """
    Return the part of the scene that can hide part of an object the cloud shows.

    Camera at the origin. Those in front of the camera, nearer than the cloud's farthest point plus
    reach, on rays within reach of the cloud's (at its nearest depth): an answer's surface lies at
    most reach (the largest object's diameter) beyond its cloud. scene: points, returned as (K, 3)
    floats without NaN holes, or a DepthImage, returned cropped.
    """
    lo, hi = _window(cloud, reach)
    far = float(cloud[:, 2].max()) + reach
    if isinstance(scene, DepthImage):
        return scene.crop(lo, hi, far)
    scene = np.asarray(scene).reshape(-1, 3)
    z = scene[:, 2]
    with np.errstate(invalid='ignore'):
        scene = scene[(z > 1e-6) & (z < far)]
        rays = _rays(scene)
        window = (rays >= lo) & (rays <= hi)
    return scene[window.all(axis=1)].astype(np.float64)


def seen_from(scene, viewpoint: np.ndarray):
    """
    Return the scene with the camera at viewpoint moved to the origin.

    A DepthImage's camera is at its frame's origin: it stays an image when viewpoint is zero
    and becomes its points otherwise.
    """
    if isinstance(scene, DepthImage):
        if not np.any(viewpoint):
            return scene
        scene = scene.points()
    return np.asarray(scene) - viewpoint


def _cells(rays: np.ndarray, origin: np.ndarray, cell: float) -> np.ndarray:
    return np.floor((rays - origin) / cell).astype(np.int64)


def occluders(scene, cloud: np.ndarray, spacing: float, reach: float) -> Occluders | None:
    """
    Return what of the scene can hide the object the cloud shows, or None when nothing can.

    scene: (M, 3) what the camera measured, in the cloud's frame with the camera at the origin (it
    may hold the cloud's own points, NaNs and everything behind), or its DepthImage. spacing: the
    cloud's point spacing. reach: as in_reach.
    """
    if float(cloud[:, 2].min()) <= 1e-6:   # not a view from this camera: no rays to follow
        return None
    origin, corner = _window(cloud, reach)
    # at most MAX_CELLS a side, whatever a clumped cloud's spacing
    cell = max(spacing / float(np.median(cloud[:, 2])), float((corner - origin).max()) / MAX_CELLS)
    scene = in_reach(scene, cloud, reach)
    if isinstance(scene, DepthImage):
        grid, origin, cell = _image_grid(scene, cell)
    else:
        grid = _point_grid(scene, origin, corner, cell)
    if not np.isfinite(grid).any():
        return None
    # a scene sparser than the cloud (or thinned) leaves cells empty between its points
    grid = minimum_filter(grid, size=3, mode='nearest')
    # where the object itself was seen nothing hid it (its cells and their neighbours: a cloud
    # thinned to its spacing leaves some of its own cells empty)
    i, j = _cells(_rays(cloud), origin, cell).T
    last = np.array(grid.shape) - 1
    for di in (-1, 0, 1):
        for dj in (-1, 0, 1):
            grid[np.clip(i + di, 0, last[0]), np.clip(j + dj, 0, last[1])] = np.inf
    if not np.isfinite(grid).any():
        return None
    return Occluders(grid, origin, cell)


def _point_grid(scene: np.ndarray, origin, corner, cell: float) -> np.ndarray:
    """Return the nearest depth of the scene's points per cell of the window, inf where none."""
    shape = _cells(corner, origin, cell) + 1
    grid = np.full(tuple(shape), np.inf)
    if len(scene):
        ij = np.clip(_cells(_rays(scene), origin, cell), 0, shape - 1)
        np.minimum.at(grid, (ij[:, 0], ij[:, 1]), scene[:, 2])
    return grid


def _image_grid(image: DepthImage, cell: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """
    Return (nearest depth per cell, origin, cell sides) of a cropped image.

    Cells are blocks of whole pixels about cell wide, so the grid is a block minimum.
    """
    block = np.maximum(np.rint(cell * image.focal), 1).astype(np.int64)   # columns, rows
    origin, sides = (-0.5 - image.centre) / image.focal, block / image.focal
    rows, cols = image.z.shape
    if not rows or not cols:
        return np.full((1, 1), np.inf), origin, sides
    padded = np.full((-(-rows // block[1]) * block[1], -(-cols // block[0]) * block[0]), np.inf,
                     dtype=np.float32)
    padded[:rows, :cols] = image.z
    near = padded.reshape(len(padded) // block[1], block[1], -1, block[0]).min(axis=(1, 3))
    # pixel k's ray is (k - centre) / focal, so block 0 starts half a pixel before it
    return near.T.astype(np.float64), origin, sides


def hidden(points: np.ndarray, occ: Occluders, tau: float) -> np.ndarray:
    """
    Return (N,) bool: which points (camera frame) lie more than tau behind an occluder.

    A point not in front of the camera is not hidden (a hypothesis far off, as an identity pose
    placing an object at the camera, can put some there), nor one on rays the scene was not kept
    for.
    """
    out = np.zeros(len(points), dtype=bool)
    ahead = np.flatnonzero(points[:, 2] > 1e-6)
    ij = _cells(_rays(points[ahead]), occ.origin, occ.cell)
    inside = ((ij >= 0) & (ij < occ.near.shape)).all(axis=1)
    ahead, ij = ahead[inside], ij[inside]
    out[ahead] = occ.near[ij[:, 0], ij[:, 1]] < points[ahead, 2] - tau
    return out
