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
What an imperfect segmenter adds to a perfectly segmented view (pcrp_core/evaluation/scenes.py).

Each fault returns the view's points with more of them: what a real mask or cluster takes in
beside the object. The background behind the object is the table for a table scene (where a ray
meets it before the wall) and otherwise a wall 0.1-1 m behind the object's farthest point. Drawn
from a generator seeded by (seed, object index, view, fault), so every run adds the same points.
"""
from __future__ import annotations

import numpy as np
from pcrp_core.sources.camera import RangeNoise
from scipy import ndimage

FAULTS = {
    'clean': 'nothing: the perfect mask of the other reports',
    'speck_behind': '20 points of something else, a 1 cm blob 0.1-1 m behind the object',
    'speck_near': '20 points of something else, a 1 cm blob 2-10 cm behind the object',
    'wide_mask': "the mask a pixel too wide: the background's pixels around the outline (with "
                 'range noise)',
    'flying_pixels': "half the outline's pixels measured between the edge's depth and the "
                     "background's (a depth camera's flying pixels)",
}
WALL_BEHIND = (0.1, 1.0)    # metres behind the object's farthest point
SPECK_POINTS = 20


def fault_rng(seed: int, object_index: int, view: int, fault: str) -> np.random.Generator:
    return np.random.default_rng([seed, object_index, view, list(FAULTS).index(fault)])


def with_fault(scene, mesh, fault: str) -> np.ndarray:
    """Return (N + k, 3) float64: the scene's points and what the fault adds."""
    if fault not in FAULTS:
        raise ValueError(f"fault {fault!r}: expected one of {', '.join(FAULTS)}")
    points = scene.points.astype(np.float64)
    if fault == 'clean':
        return points
    rng = fault_rng(scene.seed, scene.object_index, scene.view, fault)
    if fault.startswith('speck'):
        side, behind = (0.2, WALL_BEHIND) if fault == 'speck_behind' else (0.1, (0.02, 0.1))
        c = points.mean(axis=0)
        centre = np.array([c[0] + rng.uniform(-side, side), c[1] + rng.uniform(-side, side),
                           points[:, 2].max() + rng.uniform(*behind)])
        return np.vstack([points, centre + rng.normal(0.0, 0.01, (SPECK_POINTS, 3))])
    mask = _pixels(points, scene.camera)
    v, u = np.nonzero(ndimage.binary_dilation(mask) & ~mask)
    rays = np.column_stack([(u - scene.camera.cx) / scene.camera.fx,
                            (v - scene.camera.cy) / scene.camera.fy, np.ones(len(u))])
    far = _background(scene, mesh, rays, points[:, 2].max() + rng.uniform(*WALL_BEHIND))
    if fault == 'wide_mask':
        # measured as the object's pixels are: with the camera's range error
        return np.vstack([points, RangeNoise().apply(rays * far[:, None], rng)])
    half = rng.random(len(u)) < 0.5
    edge = _edge_depth(points, mask, scene.camera)[v[half], u[half]]
    z = edge + rng.uniform(0.0, 1.0, int(half.sum())) * (far[half] - edge)
    return np.vstack([points, rays[half] * z[:, None]])


def _pixels(points: np.ndarray, camera) -> np.ndarray:
    """Return the view's mask: the pixels its points were measured at."""
    uv = np.rint(camera.project(points)).astype(int)
    mask = np.zeros((camera.height, camera.width), dtype=bool)
    inside = (uv[:, 0] >= 0) & (uv[:, 0] < camera.width) & (uv[:, 1] >= 0) & (
        uv[:, 1] < camera.height)
    mask[uv[inside, 1], uv[inside, 0]] = True
    return mask


def _background(scene, mesh, rays: np.ndarray, wall: float) -> np.ndarray:
    """Return the depth along each ray (z = 1) of the table, where nearer than the wall."""
    z = np.full(len(rays), wall)
    if scene.up is not None:
        table = float(((mesh.vertices @ scene.R.T + scene.t) @ scene.up).min())
        along = rays @ scene.up
        with np.errstate(divide='ignore', invalid='ignore'):
            hit = table / along
        meets = (hit > 0) & (hit < wall)
        z[meets] = hit[meets]
    return z


def _edge_depth(points: np.ndarray, mask: np.ndarray, camera) -> np.ndarray:
    """Return (H, W): the depth of each pixel's nearest object pixel."""
    depth = np.zeros(mask.shape)
    uv = np.rint(camera.project(points)).astype(int)
    depth[uv[:, 1].clip(0, camera.height - 1), uv[:, 0].clip(0, camera.width - 1)] = points[:, 2]
    rows, cols = ndimage.distance_transform_edt(~mask, return_distances=False,
                                                return_indices=True)
    return depth[rows, cols]
