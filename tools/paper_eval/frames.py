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
How consistently a category's objects share one canonical frame.

The bound the data itself sets on pose error.

A gallery-based method answers in the gallery's frame. When the objects of one category disagree
about which way is front (in this copy of ModelNet40 some cars and airplanes face along x, others
along y), a test object whose frame differs from its look-alikes' cannot come back right, whatever
the registration. For each test object this finds, among the train objects of its category, the one
whose shape is nearest under the best of the 24 rotations that map axes onto axes, and records
whether that best rotation is the identity: an upper bound, measured without any of the package's
own machinery, on how many queries a method that retrieves the nearest look-alike and registers it
perfectly can get right.

A second check needs no shape matching at all: which horizontal axis (z is up) an object's long
side lies along. For a category whose long side is always the same part (a car's length, a sofa's
width), objects lying both ways are labels turned by a quarter turn against each other.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.category.frames import chamfer_by_rotation, IDENTITY, subsample
from pcrp_core.hypotheses import AXIS_ROTATIONS
from scipy.spatial import cKDTree
from tools.paper_eval.metrics import geodesic_deg
from tools.paper_eval.protocol import load_split

ELONGATED = 1.5  # long side / short side: which side is longer is then the object's, not noise
_GALLERIES: dict = {}


def _gallery(data, category: str, exclude=(), limit: int | None = None):
    """
    (train clouds subsampled, their trees).

    But those named in exclude, once per process and category; limit: an evenly spread subset of
    that many (a quick run's), as load_split takes it.
    """
    key = (category, tuple(exclude), limit)
    if key not in _GALLERIES:
        names, pts = load_split(data, category, 'train', limit)
        skip = set(exclude)
        clouds = [subsample(p, i) for i, (n, p) in enumerate(zip(names, pts)) if n not in skip]
        _GALLERIES[key] = (np.stack(clouds), [cKDTree(c) for c in clouds])
    return _GALLERIES[key]


def audit_one(state: dict, item) -> dict:
    """
    Audit one object's frame against its category's train objects.

    item: (name, category, points) of one test object (or of a train object named in
    state["exclude"][category], which the train objects it is compared with then leave out).
    state["limit"]: compare with only that many train objects a category (None: all of them).
    """
    name, category, points = item
    clouds, trees = _gallery(state['data'], category, state.get('exclude', {}).get(category, ()),
                             state.get('limit'))
    cost = chamfer_by_rotation(subsample(points, 0), clouds, trees)
    best = cost.argmin(1)
    nearest = np.argsort(cost.min(1))
    return {'name': name, 'category': category,
            'nearest_agrees': bool(best[nearest[0]] == IDENTITY),
            'share_agreeing': float(np.mean(best == IDENTITY)),
            'nearest_turn_deg': geodesic_deg(AXIS_ROTATIONS[best[nearest[0]]], np.eye(3))}


def long_side_along_y(points: np.ndarray) -> np.ndarray:
    """
    (n,) for (n, m, 3) clouds.

    1.0 where the long horizontal side lies along y, 0.0 along x, NaN where the object is less than
    ELONGATED times longer than wide (the side that is longer could flip).
    """
    extent = points.max(1) - points.min(1)
    along_y = (extent[:, 1] > extent[:, 0]).astype(float)
    ratio = extent[:, :2].max(1) / np.maximum(extent[:, :2].min(1), 1e-12)
    return np.where(ratio >= ELONGATED, along_y, np.nan)


def long_sides(train: np.ndarray, test: np.ndarray) -> dict:
    """Share of a category's elongated objects whose long side lies along y, per split."""
    out = {}
    for split, points in (('train', train), ('test', test)):
        y = long_side_along_y(points)
        y = y[~np.isnan(y)]
        out[split] = {
            'elongated': int(len(y)),
            'along_y': float(y.mean()) if len(y) else float('nan'),
        }
    return out


def summarise(rows: list[dict]) -> dict:
    out = {}
    for cat in sorted({r['category'] for r in rows}):
        sel = [r for r in rows if r['category'] == cat]
        turns = np.array([r['nearest_turn_deg'] for r in sel])
        out[cat] = {
            'objects': len(sel),
            # what retrieving the nearest look-alike and registering it perfectly would score
            'look_alike_mean_deg': float(turns.mean()),
            'look_alike_median_deg': float(np.median(turns)),
            'nearest_agrees': float(np.mean([r['nearest_agrees'] for r in sel])),
            'share_agreeing_median': float(np.median([r['share_agreeing'] for r in sel])),
            'quarter_turns': float(np.mean(np.isclose(turns, 90.0, atol=1))),
            'half_turns': float(np.mean(np.isclose(turns, 180.0, atol=1))),
        }
    return out
