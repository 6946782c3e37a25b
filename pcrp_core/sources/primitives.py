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
Surface sampling of simple solids, area-uniform.

For the procedural generator, and for objects of no category (random_solid).
"""
from __future__ import annotations

import numpy as np


def _rot_x(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[1, 0, 0], [0, c, -s], [0, s, c]])


def _rot_z(a):
    c, s = np.cos(a), np.sin(a)
    return np.array([[c, -s, 0], [s, c, 0], [0, 0, 1]])


class Box:
    def __init__(self, centre, size, R=None):
        self.c, self.s, self.R = (
            np.asarray(centre, float),
            np.asarray(size, float),
            np.eye(3) if R is None else R,
        )

    def area(self):
        a, b, c = self.s
        return 2 * (a * b + b * c + a * c)

    def sample(self, n, rng):
        a, b, c = self.s
        faces = np.array([b * c, b * c, a * c, a * c, a * b, a * b])
        face = rng.choice(6, n, p=faces / faces.sum())
        u = rng.uniform(-0.5, 0.5, (n, 3))
        axis = face // 2
        u[np.arange(n), axis] = np.where(face % 2 == 0, -0.5, 0.5)
        return (u * self.s) @ self.R.T + self.c


class Cylinder:
    """Closed cylinder along the local z axis, then rotated by R."""

    def __init__(self, centre, radius, length, R=None):
        self.c, self.r, self.h, self.R = (
            np.asarray(centre, float),
            radius,
            length,
            np.eye(3) if R is None else R,
        )

    def area(self):
        return 2 * np.pi * self.r * self.h + 2 * np.pi * self.r ** 2

    def sample(self, n, rng):
        side = 2 * np.pi * self.r * self.h
        on_side = rng.uniform(0, self.area(), n) < side
        theta = rng.uniform(0, 2 * np.pi, n)
        rad = np.where(on_side, self.r, self.r * np.sqrt(rng.uniform(0, 1, n)))
        z = np.where(on_side, rng.uniform(-self.h / 2, self.h / 2, n),
                     np.where(rng.uniform(0, 1, n) < 0.5, -self.h / 2, self.h / 2))
        p = np.column_stack([rad * np.cos(theta), rad * np.sin(theta), z])
        return p @ self.R.T + self.c


class Ellipsoid:
    def __init__(self, centre, radii):
        self.c, self.r = np.asarray(centre, float), np.asarray(radii, float)

    def area(self):
        a, b, c = self.r  # Knud Thomsen's approximation
        p = 1.6075
        return 4 * np.pi * (((a * b) ** p + (a * c) ** p + (b * c) ** p) / 3) ** (1 / p)

    def sample(self, n, rng):
        v = rng.normal(size=(n, 3))
        return v / np.linalg.norm(v, axis=1, keepdims=True) * self.r + self.c


def sample_parts(parts, n, rng) -> np.ndarray:
    """Sample n points over all parts, each part getting points in proportion to its area."""
    areas = np.array([p.area() for p in parts])
    counts = rng.multinomial(n, areas / areas.sum())
    return np.concatenate([p.sample(k, rng) for p, k in zip(parts, counts) if k])


def random_solid(rng: np.random.Generator, n: int, parts: int = 3) -> np.ndarray:
    """
    Return (n, 3) points on one to `parts` boxes, cylinders and ellipsoids, centred.

    Each part of random proportions (boxes and cylinders also turned; an ellipsoid keeps its axes),
    centred on a point of the part before it: an object of no category, to learn what an answer to
    an object no gallery holds looks like (category/calibration.py).
    """
    from pcrp_core.sources.views import random_rotation

    solids = []
    for _ in range(rng.integers(1, parts + 1)):
        centre = sample_parts(solids[-1:], 1, rng)[0] if solids else np.zeros(3)
        a, b, c = rng.uniform(0.05, 1.0, 3)
        R = random_rotation(rng)   # drawn for every part, so each kind draws alike
        kind = rng.integers(3)
        if kind == 0:
            solids.append(Box(centre, (a, b, c), R))
        elif kind == 1:
            solids.append(Cylinder(centre, a / 2, 2 * b, R))
        else:
            solids.append(Ellipsoid(centre, (a / 2, b / 2, c / 2)))
    points = sample_parts(solids, n, rng)
    return points - points.mean(0)


ROT_X = _rot_x
ROT_Z = _rot_z
