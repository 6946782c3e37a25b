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

"""Which points of a cloud a sensor at a given position sees (Open3D hidden point removal)."""
from __future__ import annotations

import numpy as np
import open3d as o3d

# Hidden point removal flips points about a sphere of this many diameters around the camera, and
# is only valid while the sphere holds the whole cloud (Katz et al.); a camera further than
# FAR_DIAMETERS away is moved in along its line of sight to that distance, where the view is
# already as good as orthographic, so the same points are seen.
RADIUS_DIAMETERS = 100.0
FAR_DIAMETERS = 20.0


def visible_from(points: np.ndarray, camera: np.ndarray) -> np.ndarray:
    """Return the indices of the points visible from `camera`."""
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    diameter = np.linalg.norm(points.max(0) - points.min(0))
    camera = np.asarray(camera, dtype=np.float64)
    centre = points.mean(0)
    dist = float(np.linalg.norm(camera - centre))
    if dist > FAR_DIAMETERS * diameter:
        camera = centre + (camera - centre) * (FAR_DIAMETERS * diameter / dist)
    _, idx = pcd.hidden_point_removal(camera, diameter * RADIUS_DIAMETERS)
    return np.asarray(idx)


def sphere_directions(n: int) -> np.ndarray:
    """
    Return n unit vectors spread evenly over the sphere (Fibonacci lattice).

    Where to put sensors around an object, or where one may have stood.
    """
    k = np.arange(n) + 0.5
    z = 1 - 2 * k / n
    phi = np.pi * (1 + 5 ** 0.5) * k
    r = np.sqrt(1 - z ** 2)
    return np.column_stack([r * np.cos(phi), r * np.sin(phi), z])
