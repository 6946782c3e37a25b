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
The embedded default data: procedural airplanes, chairs, sofas and cars.

Objects follow ModelNet40's conventions so that a model built on one makes sense on the
other: z up, centred on the point mean, farthest point at distance 1, and the category's
canonical heading as measured on ModelNet40's training objects (chairs face -y with the back
at +y; sofas run along y with the back at +x; cars run along y, front at -y; airplanes'
fuselage along y, nose at -y, fin at the +y end). Every object has a front and a back and a
top and a bottom, so its pose is well defined. Variety: proportions, part styles and counts.

IDs: `proc_<category>_<NNNN>` for the train split (seeds 0, 1, ...) and
`proc_<category>_t<NNN>` for the test split (seeds from 100000 on), so the two never overlap.
"""
from __future__ import annotations

import numpy as np
from pcrp_core.sources.gallery_object import GalleryObject
from pcrp_core.sources.primitives import Box, Cylinder, Ellipsoid, ROT_X, ROT_Z, sample_parts

CATEGORIES = ('airplane', 'chair', 'sofa', 'car')
TEST_SEED_OFFSET = 100_000
_AXIS_X = np.array([[0, 0, 1], [0, 1, 0], [-1, 0, 0]], float)   # local z -> x
_AXIS_Y = np.array([[1, 0, 0], [0, 0, 1], [0, -1, 0]], float)   # local z -> y


def _chair(r):
    w, d = r.uniform(0.4, 0.6), r.uniform(0.4, 0.6)
    seat_h, t = r.uniform(0.4, 0.5), r.uniform(0.03, 0.08)
    parts = [Box([0, 0, seat_h], [w, d, t])]
    if r.random() < 0.3:   # pedestal with a star base (office chair)
        parts.append(Cylinder([0, 0, seat_h / 2], 0.03, seat_h))
        for a in np.arange(5) * 2 * np.pi / 5 + r.uniform(0, 1):
            parts.append(
                Box([0.15 * np.cos(a), 0.15 * np.sin(a), 0.03], [0.3, 0.04, 0.04], ROT_Z(a))
            )
    else:
        leg = r.uniform(0.025, 0.05)
        for sx in (-1, 1):
            for sy in (-1, 1):
                parts.append(
                    Box([sx * (w / 2 - leg), sy * (d / 2 - leg), seat_h / 2], [leg, leg, seat_h])
                )
    back_h, tilt = r.uniform(0.35, 0.7), r.uniform(0.0, 0.3)
    R = ROT_X(-tilt)
    parts.append(
        Box(np.array([0, d / 2, seat_h]) + R @ [0, 0.02, back_h / 2], [w, 0.04, back_h], R)
    )
    if r.random() < 0.4:
        for sx in (-1, 1):
            parts.append(Box([sx * w / 2, 0, seat_h + 0.2], [0.05, d * 0.9, 0.04]))
            parts.append(Box([sx * w / 2, -d * 0.35, seat_h + 0.1], [0.04, 0.04, 0.2]))
    return parts


def _sofa(r):
    seats, depth = r.integers(2, 5), r.uniform(0.8, 1.0)
    length = seats * r.uniform(0.55, 0.7)
    base_h, leg_h = r.uniform(0.2, 0.35), r.choice([0.0, r.uniform(0.05, 0.15)])
    z0 = leg_h + base_h / 2
    parts = [Box([0, 0, z0], [depth, length, base_h])]
    cushion = r.uniform(0.1, 0.18)
    for k in range(seats):
        y = -length / 2 + (k + 0.5) * length / seats
        parts.append(
            Box(
                [-0.05, y, leg_h + base_h + cushion / 2],
                [depth * 0.8, length / seats * 0.95, cushion],
            )
        )
    back_h, back_t = r.uniform(0.35, 0.6), r.uniform(0.15, 0.25)
    parts.append(
        Box([depth / 2 - back_t / 2, 0, leg_h + base_h + back_h / 2], [back_t, length, back_h])
    )
    arm_h, arm_w = r.uniform(0.1, 0.35), r.uniform(0.08, 0.25)
    for s in (-1, 1):
        parts.append(
            Box(
                [0, s * (length / 2 + arm_w / 2), leg_h + (base_h + arm_h) / 2],
                [depth, arm_w, base_h + arm_h],
            )
        )
    if leg_h > 0:
        for sx in (-1, 1):
            for sy in (-1, 1):
                parts.append(
                    Cylinder(
                        [sx * (depth / 2 - 0.06), sy * (length / 2 - 0.06), leg_h / 2], 0.03, leg_h
                    )
                )
    return parts


def _car(r):
    L, W = r.uniform(1.7, 2.2), r.uniform(0.75, 0.9)
    body_h, clear, wheel_r = r.uniform(0.25, 0.4), r.uniform(0.08, 0.15), r.uniform(0.13, 0.2)
    parts = [Box([0, 0, clear + body_h / 2], [W, L, body_h])]
    style = r.choice(['sedan', 'hatch', 'suv', 'pickup'])
    cab_h = r.uniform(0.22, 0.35) * (1.3 if style == 'suv' else 1.0)
    if style == 'sedan':
        cab_len, cab_y = L * r.uniform(0.4, 0.5), r.uniform(0.0, 0.1) * L
    elif style == 'pickup':
        cab_len, cab_y = L * r.uniform(0.25, 0.35), -L * r.uniform(0.02, 0.12)
        bed_y0, bed_y1 = cab_y + cab_len / 2, L / 2
        for s in (-1, 1):
            parts.append(
                Box(
                    [s * W / 2, (bed_y0 + bed_y1) / 2, clear + body_h + 0.08],
                    [0.04, bed_y1 - bed_y0, 0.16],
                )
            )
    else:
        cab_len = L * r.uniform(0.55, 0.7)
        cab_y = L / 2 - cab_len / 2 - 0.05
    # the windscreen slopes: a tilted slab at the cabin's front sets front apart from back
    parts.append(Box([0, cab_y, clear + body_h + cab_h / 2], [W * 0.9, cab_len, cab_h]))
    R = ROT_X(r.uniform(0.6, 1.0))
    parts.append(
        Box(
            [0, cab_y - cab_len / 2 - 0.08, clear + body_h + cab_h * 0.4], [W * 0.88, 0.3, 0.03], R
        )
    )
    for sy in (-1, 1):
        for sx in (-1, 1):
            parts.append(
                Cylinder(
                    [sx * (W / 2 - 0.05), sy * (L / 2 - r.uniform(0.28, 0.38)), wheel_r],
                    wheel_r,
                    0.12,
                    _AXIS_X,
                )
            )
    return parts


def _airplane(r):
    L, rad = r.uniform(1.6, 2.2), r.uniform(0.07, 0.14)
    parts = [Ellipsoid([0, 0, 0], [rad, L / 2, rad])]
    span, chord = r.uniform(1.3, 2.2), r.uniform(0.2, 0.4)
    wing_y, sweep = r.uniform(-0.1, 0.15) * L, r.uniform(0.0, 0.5)
    wing_z = r.choice([-0.6, 0.0, 0.6]) * rad
    for s in (-1, 1):
        parts.append(
            Box(
                [s * span / 4, wing_y + sweep * span / 4, wing_z],
                [span / 2, chord, 0.025],
                ROT_Z(-s * sweep),
            )
        )
    tail_y = L / 2 - r.uniform(0.08, 0.15)
    tspan = span * r.uniform(0.25, 0.4)
    parts.append(Box([0, tail_y, rad * 0.3], [tspan, chord * 0.6, 0.02]))
    fin_h = r.uniform(0.2, 0.4)
    parts.append(
        Box([0, tail_y, rad + fin_h / 2], [0.02, chord * 0.8, fin_h], ROT_X(r.uniform(0.0, 0.4)))
    )
    for k in range(r.choice([0, 1, 2])):
        x = span * (0.18 + 0.15 * k)
        for s in (-1, 1):
            parts.append(Cylinder([s * x, wing_y - 0.1, wing_z - 0.09], 0.05, 0.3, _AXIS_Y))
    return parts


_BUILDERS = {'airplane': _airplane, 'chair': _chair, 'sofa': _sofa, 'car': _car}


def generate_object(category: str, seed: int, n_points: int = 1024) -> np.ndarray:
    """(n_points, 3) float32 surface points of one object, deterministic in (category, seed)."""
    if category not in _BUILDERS:
        raise ValueError(
            f"unknown procedural category {category!r}; known: {', '.join(CATEGORIES)}"
        )
    rng = np.random.default_rng([CATEGORIES.index(category), seed])
    pts = sample_parts(_BUILDERS[category](rng), n_points, rng)
    pts -= pts.mean(0)
    return (pts / np.linalg.norm(pts, axis=1).max()).astype(np.float32)


def generate_gallery(
    n_per_category: int,
    seed: int = 0,
    n_points: int = 1024,
    split: str = 'train',
    categories=CATEGORIES,
):
    offset = TEST_SEED_OFFSET if split == 'test' else 0
    objects = []
    for c in categories:
        for k in range(n_per_category):
            gid = f'proc_{c}_t{k:03d}' if split == 'test' else f'proc_{c}_{k:04d}'
            objects.append(
                GalleryObject(
                    gid, c, generate_object(c, seed * 10_000 + offset + k, n_points), up='z'
                )
            )
    return objects
