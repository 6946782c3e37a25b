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
The embedded default: a procedural household gallery of meshes in metres, as a robot meets them.

Cans, boxes, a mug, a bowl, a bottle, a plate, balls and fruit, tools: shapes of a grasping
benchmark's kind, built from solids of revolution and boxes, each standing on z = 0 with z up,
in metres. `household` is the 16 objects of the shipped model; `household:N` draws N objects
of the same kinds with other proportions (seeded), a validation set that shares no object with
any benchmark. No mesh files are needed, so the demo and the tests run anywhere.
"""
from __future__ import annotations

import numpy as np

from pcrp_core.sources.camera import Mesh
from pcrp_core.sources.gallery_object import GalleryObject

SEGMENTS = 48


def lathe(profile, segments: int = SEGMENTS) -> Mesh:
    """
    Return the surface swept by turning profile [(radius, z), ...] about the z axis.

    Ends on the axis (radius 0) close it, so a profile out along the bottom, up the side and back
    in at the top is a closed solid, and one that returns down inside is a thin-walled vessel.
    """
    profile = np.asarray(profile, dtype=np.float64)
    angles = np.arange(segments) * 2 * np.pi / segments
    rings, verts = [], []
    for r, z in profile:
        if r <= 1e-12:
            rings.append([len(verts)])
            verts.append([0.0, 0.0, z])
        else:
            rings.append(list(range(len(verts), len(verts) + segments)))
            verts += [[r * np.cos(a), r * np.sin(a), z] for a in angles]
    tris = []
    for a, b in zip(rings[:-1], rings[1:]):
        for k in range(segments):
            k1 = (k + 1) % segments
            if len(a) == 1 and len(b) > 1:
                tris.append([a[0], b[k1], b[k]])
            elif len(b) == 1 and len(a) > 1:
                tris.append([a[k], a[k1], b[0]])
            elif len(a) > 1:
                tris += [[a[k], a[k1], b[k1]], [a[k], b[k1], b[k]]]
    return Mesh(np.array(verts), np.array(tris, dtype=np.int64))


def box(size, centre=(0.0, 0.0, 0.0)) -> Mesh:
    """Make an axis-aligned box of size (x, y, z) about centre."""
    sx, sy, sz = np.asarray(size, dtype=np.float64) / 2
    v = np.array(
        [[x, y, z] for x in (-sx, sx) for y in (-sy, sy) for z in (-sz, sz)]
    ) + np.asarray(centre)
    faces = [[0, 1, 3, 2], [4, 6, 7, 5], [0, 4, 5, 1], [2, 3, 7, 6], [0, 2, 6, 4], [1, 5, 7, 3]]
    tris = [[f[0], f[1], f[2]] for f in faces] + [[f[0], f[2], f[3]] for f in faces]
    return Mesh(v, np.array(tris, dtype=np.int64))


def union(*meshes: Mesh) -> Mesh:
    """
    Put the meshes side by side in one.

    Overlaps keep their inner faces, which no camera sees.
    """
    verts, tris, n = [], [], 0
    for m in meshes:
        verts.append(m.vertices)
        tris.append(m.triangles + n)
        n += len(m.vertices)
    return Mesh(np.concatenate(verts), np.concatenate(tris))


def _cylinder(r, h):
    return lathe([(0, 0), (r, 0), (r, h), (0, h)])


def _vessel(r_bottom, r_top, h, wall, bottom=0.006):
    """Make a cup or bowl: outside up, over the rim, inside down to the floor."""
    return lathe(
        [
            (0, 0),
            (r_bottom, 0),
            (r_top, h),
            (r_top - wall, h),
            (r_bottom - wall, bottom),
            (0, bottom),
        ]
    )


def _ball(r, squash=1.0, rings=16):
    t = np.linspace(0, np.pi, rings + 1)
    return lathe([(r * np.sin(a), r * squash * (1 - np.cos(a))) for a in t])


def _mug(r, h, p):
    handle = union(box([0.012, 0.012, 0.6 * h], [r + 0.022, 0, 0.5 * h]),
                   box([0.03, 0.012, 0.012], [r + 0.010, 0, 0.8 * h]),
                   box([0.03, 0.012, 0.012], [r + 0.010, 0, 0.2 * h]))
    return union(_vessel(r, r, h, 0.004), handle)


def _bottle(r, h, p):
    return lathe([(0, 0), (r, 0), (r, 0.65 * h), (0.35 * r, 0.85 * h), (0.35 * r, h), (0, h)])


def _hammer(length, p):
    return union(
        box([0.025, 0.032, length], [0, 0, length / 2]),
        box([0.11, 0.03, 0.03], [0.025, 0, length]),
    )


def _drill(size, p):
    body = box([0.18 * size, 0.06 * size, 0.07 * size], [0.02 * size, 0, 0.16 * size])
    grip = box([0.045 * size, 0.05 * size, 0.14 * size], [0, 0, 0.07 * size])
    chuck = box([0.05 * size, 0.035 * size, 0.035 * size], [0.135 * size, 0, 0.16 * size])
    return union(body, grip, chuck)


def _bracket(a, b, p):
    return union(box([a, 0.04, 0.01], [a / 2, 0, 0.005]), box([0.01, 0.04, b], [0.005, 0, b / 2]))


def _spatula(length, p):
    return union(
        box([0.07, 0.09, 0.003], [0, 0.045, 0.0015]),
        box([0.022, length, 0.012], [0, 0.09 + length / 2, 0.006]),
    )


def _cone(r, h, p):
    return lathe([(0, 0), (r, 0), (r, 0.02), (0.25 * r, h), (0, h)])


def _plate(r, p):
    return lathe(
        [(0, 0), (0.6 * r, 0), (r, 0.02), (r - 0.006, 0.022), (0.6 * r - 0.006, 0.006), (0, 0.006)]
    )


def _crate(x, y, z, p):
    """Make a box with a lid overhanging on two sides: not a plain box from any side."""
    return union(box([x, y, z], [0, 0, z / 2]), box([x + 0.02, y, 0.012], [0, 0, z + 0.006]))


# kind: (builder, parameter ranges for household:N), in the shipped order and proportions
KINDS = {
    'can': (lambda p: _cylinder(p[0], p[1]), [(0.033, 0.033), (0.10, 0.10)]),
    'tall_can': (lambda p: _cylinder(p[0], p[1]), [(0.05, 0.05), (0.14, 0.14)]),
    'cereal_box': (
        lambda p: box([p[0], p[1], p[2]], [0, 0, p[2] / 2]),
        [(0.07, 0.07), (0.19, 0.19), (0.25, 0.25)],
    ),
    'sugar_box': (
        lambda p: box([p[0], p[1], p[2]], [0, 0, p[2] / 2]),
        [(0.05, 0.05), (0.09, 0.09), (0.17, 0.17)],
    ),
    'mug': (lambda p: _mug(p[0], p[1], p), [(0.04, 0.04), (0.09, 0.09)]),
    'bowl': (
        lambda p: _vessel(p[0], p[1], p[2], 0.004),
        [(0.04, 0.04), (0.08, 0.08), (0.055, 0.055)],
    ),
    'bottle': (lambda p: _bottle(p[0], p[1], p), [(0.035, 0.035), (0.22, 0.22)]),
    'plate': (lambda p: _plate(p[0], p), [(0.12, 0.12)]),
    'ball': (lambda p: _ball(p[0]), [(0.035, 0.035)]),
    'fruit': (lambda p: _ball(p[0], p[1]), [(0.038, 0.038), (0.85, 0.85)]),
    'hammer': (lambda p: _hammer(p[0], p), [(0.30, 0.30)]),
    'drill': (lambda p: _drill(p[0], p), [(1.0, 1.0)]),
    'bracket': (lambda p: _bracket(p[0], p[1], p), [(0.10, 0.10), (0.07, 0.07)]),
    'spatula': (lambda p: _spatula(p[0], p), [(0.20, 0.20)]),
    'cone': (lambda p: _cone(p[0], p[1], p), [(0.05, 0.05), (0.15, 0.15)]),
    'crate': (lambda p: _crate(p[0], p[1], p[2], p), [(0.12, 0.12), (0.08, 0.08), (0.06, 0.06)]),
}
# how far household:N may stretch each parameter of a kind (relative)
VARIATION = (0.6, 1.5)


def household_mesh(kind: str, params=None) -> Mesh:
    builder, ranges = KINDS[kind]
    return builder([lo for lo, _ in ranges] if params is None else params)


def household_gallery(
    n: int | None = None, seed: int = 0, n_points: int = 1024
) -> list[GalleryObject]:
    """
    Return the shipped 16 objects (n None), or n objects of the same kinds.

    The n objects have proportions drawn from seed (IDs `<kind>_<k>`); all are GalleryObjects with
    meshes, z up.
    """
    out = []
    if n is None:
        items = [(kind, kind, None) for kind in KINDS]
    else:
        rng = np.random.default_rng([seed, 31])
        kinds = list(KINDS)
        items = []
        for k in range(n):
            kind = kinds[k % len(kinds)]
            params = [lo * rng.uniform(*VARIATION) for lo, _ in KINDS[kind][1]]
            if kind == 'fruit':
                params[1] = rng.uniform(0.8, 1.1)
            items.append((f'{kind}_{k:03d}', kind, params))
    for gallery_id, kind, params in items:
        mesh = household_mesh(kind, params)
        points = mesh.sample(4 * n_points, seed=0)
        out.append(GalleryObject(gallery_id, kind, points.astype(np.float32), up='z', mesh=mesh))
    return out
