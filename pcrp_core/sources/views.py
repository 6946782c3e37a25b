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

"""What a robot's depth camera sees of an object: one side, with noise along the rays."""
from __future__ import annotations

import numpy as np
from pcrp_core.visibility import visible_from
from scipy.spatial.transform import Rotation


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """Uniform over all rotations."""
    return Rotation.random(random_state=rng).as_matrix()


def sensor_view(points: np.ndarray, camera: np.ndarray, rng: np.random.Generator,
                noise_sigma: float = 0.0) -> np.ndarray:
    """
    Return the points a sensor at `camera` sees, with Gaussian noise along each viewing ray.

    The noise has sigma noise_sigma (in the points' units), as a depth camera's range error.
    """
    seen = points[visible_from(points, camera)]
    rays = seen - camera
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    return (seen + rays * rng.normal(scale=noise_sigma, size=(len(seen), 1))).astype(np.float32)


def partial_view(
    points: np.ndarray,
    rng: np.random.Generator,
    noise_sigma: float = 0.005,
    min_keep: float = 0.25,
    distance: float = 3.0,
    tries: int = 10,
    with_camera: bool = False,
):
    """
    Return the side of the object seen from a random direction at `distance` object radii.

    With Gaussian noise of noise_sigma (in object radii) along each viewing ray. Retries another
    direction when less than min_keep of the points would be seen. with_camera: return (points,
    camera position) instead.
    """
    centre = points.mean(0)
    radius = np.linalg.norm(points - centre, axis=1).max()
    for _ in range(tries):
        d = rng.normal(size=3)
        camera = centre + distance * radius * d / np.linalg.norm(d)
        idx = visible_from(points, camera)
        if len(idx) >= min_keep * len(points):
            break
    seen = sensor_view(points, camera, rng, noise_sigma * radius)
    return (seen, camera) if with_camera else seen


def crop_half_plane(points: np.ndarray, rng: np.random.Generator, keep: float = 0.7) -> np.ndarray:
    """
    Return the share `keep` of the points on one side of a plane of random direction.

    The paper's partial protocol.
    """
    d = rng.normal(size=3)
    proj = (points - points.mean(0)) @ (d / np.linalg.norm(d))
    return points[proj <= np.quantile(proj, keep)]
