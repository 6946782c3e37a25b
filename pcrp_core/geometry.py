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

"""Small geometric facts used across the package, written once."""
from __future__ import annotations

import numpy as np

AXES = {'x': (1.0, 0.0, 0.0), 'y': (0.0, 1.0, 0.0), 'z': (0.0, 0.0, 1.0)}


def rotation_angle_deg(R_a, R_b) -> float:
    """Return the geodesic angle between two rotations, in degrees."""
    c = (np.trace(np.asarray(R_a).T @ np.asarray(R_b)) - 1.0) / 2.0
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def angle_deg(a, b) -> float:
    """Return the angle between two vectors, in degrees."""
    a, b = np.asarray(a, dtype=np.float64), np.asarray(b, dtype=np.float64)
    c = a @ b / (np.linalg.norm(a) * np.linalg.norm(b))
    return float(np.degrees(np.arccos(np.clip(c, -1.0, 1.0))))


def rotation_taking(a, b) -> np.ndarray:
    """
    Return the least rotation taking direction a onto direction b (any lengths).

    Written out: scipy's Rotation.align_vectors of one pair of vectors gives other answers before
    scipy 1.12.
    """
    a = np.asarray(a, dtype=np.float64) / np.linalg.norm(a)
    b = np.asarray(b, dtype=np.float64) / np.linalg.norm(b)
    v, c = np.cross(a, b), float(a @ b)
    if c < -1 + 1e-12:   # opposite: a half turn about any axis normal to them
        n = np.cross(a, [1.0, 0.0, 0.0]) if abs(a[0]) < 0.9 else np.cross(a, [0.0, 1.0, 0.0])
        n = n / np.linalg.norm(n)
        return 2.0 * np.outer(n, n) - np.eye(3)
    K = np.array([[0.0, -v[2], v[1]], [v[2], 0.0, -v[0]], [-v[1], v[0], 0.0]])
    return np.eye(3) + K + K @ K / (1.0 + c)


def normalised(points: np.ndarray, unit: float, centre=None) -> np.ndarray:
    """
    Return points in a model's normalised units.

    They are centred on their centroid (or centre) and divided by the model-wide unit, so the
    features' radii mean the same for every object.
    """
    points = np.asarray(points, dtype=np.float64)
    return (points - (points.mean(axis=0) if centre is None else centre)) / unit


def rms_radius(points: np.ndarray) -> float:
    """Root mean square distance from the centroid: a cloud's size."""
    return float(np.sqrt(((points - points.mean(axis=0)) ** 2).sum(axis=1).mean()))


def diameter(points: np.ndarray) -> float:
    """Largest distance between two points (exact over the convex hull's vertices)."""
    from scipy.spatial import ConvexHull
    from scipy.spatial.distance import pdist

    try:
        points = points[ConvexHull(points).vertices]
    except Exception:   # flat or degenerate: all points, still exact
        pass
    return float(pdist(points).max()) if len(points) > 1 else 0.0


def unit_vector(v) -> np.ndarray | None:
    """Return v scaled to length 1, None unless it is a finite, non-zero 3-vector."""
    v = np.asarray(v, dtype=np.float64).reshape(-1)
    n = float(np.linalg.norm(v)) if v.shape == (3,) and np.all(np.isfinite(v)) else 0.0
    return v / n if n >= 1e-9 else None


def unit_axis(axis) -> np.ndarray:
    """Return a unit vector from 'x', '-z', ... or three numbers; ValueError otherwise."""
    if isinstance(axis, str):
        name = axis.strip().lower()
        sign = -1.0 if name.startswith('-') else 1.0
        if name.lstrip('+-') not in AXES:
            raise ValueError(f'up axis {axis!r}: expected x, y, z, -x, -y or -z')
        return sign * np.array(AXES[name.lstrip('+-')])
    v = unit_vector(axis)
    if v is None:
        raise ValueError(f'up axis {axis!r}: expected a finite, non-zero 3-vector')
    return v


def axis_name(v) -> str:
    """'x', '-y', ... for a coordinate axis, else the vector's three numbers."""
    for name, axis in AXES.items():
        for sign in (1.0, -1.0):
            if np.allclose(v, np.array(axis) * sign):
                return ('' if sign > 0 else '-') + name
    return ','.join(f'{x:.3f}' for x in v)
