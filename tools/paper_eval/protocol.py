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
The queries of each experiment, drawn from one seed.

Every random choice of a query (its rotation, translation, point order, cut or viewpoint) comes
from a generator seeded by (seed, experiment, query index), so a query is the same whichever subset
of the experiments runs, and `--seed` alone reproduces or varies a run.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
import zlib

import numpy as np
from pcrp_core.sources.views import crop_half_plane, partial_view
from scipy.spatial.transform import Rotation

PAPER_CATEGORIES = ('airplane', 'chair', 'sofa', 'car')
ROTATIONS = ('uniform', 'euler45')
PLANE_KEEP = 0.75  # 768 of 1024 points, as PRNet's partial protocol that R-PointHop follows
VIEW_NOISE = 0.005         # range noise along each ray, in object radii
INSTANCE_NOISE = 0.01      # radii: a whole known object's points re-measured
VIEWS = 12  # one-sided views per object in the depth-camera models, as the README recommends


@dataclass
class Query:
    name: str
    category: str
    canonical: np.ndarray  # the object as the archive has it (pre-aligned), for ground truth
    points: np.ndarray             # what the method is given: p = R @ canonical_part + t
    R: np.ndarray
    t: np.ndarray
    viewpoint: np.ndarray | None  # the sensor's position in the query's frame, for one-sided views


def query_rng(seed: int, experiment: str, index: int) -> np.random.Generator:
    return np.random.default_rng([seed, zlib.crc32(experiment.encode()), index])


def random_rotation(rng: np.random.Generator, protocol: str) -> np.ndarray:
    """
    Return a random rotation by the named protocol.

    uniform: uniform over all rotations; euler45: each of the x, y, z Euler angles uniform in [0°,
    45°] (the registration protocol of R-PointHop's Table 1).
    """
    if protocol == 'uniform':
        return Rotation.random(random_state=rng).as_matrix()
    if protocol == 'euler45':
        return Rotation.from_euler('xyz', rng.uniform(0.0, 45.0, 3), degrees=True).as_matrix()
    raise ValueError(f'unknown rotation protocol {protocol!r}')


def make_query(name: str, category: str, canonical: np.ndarray, rng: np.random.Generator,
               rotation: str = 'uniform', cut: str | None = None, noise: float = 0.0) -> Query:
    """
    Make one query of a protocol.

    cut: None (the whole object), 'plane' (the PLANE_KEEP share of points on one side of a random
    plane) or 'view' (what a depth camera 3 radii away in a random direction sees, with range
    noise). noise: Gaussian noise of that many radii added to a whole object's points.
    """
    canonical = np.asarray(canonical, dtype=np.float64)
    part, camera = canonical, None
    if cut == 'plane':
        part = crop_half_plane(canonical, rng, PLANE_KEEP)
    elif cut == 'view':
        part, camera = partial_view(canonical, rng, VIEW_NOISE, with_camera=True)
    elif cut is not None:
        raise ValueError(f'unknown cut {cut!r}')
    if noise and cut is None:
        part = canonical + rng.normal(scale=noise, size=canonical.shape)
    R = random_rotation(rng, rotation)
    t = rng.uniform(-0.5, 0.5, 3)
    points = (np.asarray(part, dtype=np.float64) @ R.T + t)[rng.permutation(len(part))]
    viewpoint = None if camera is None else R @ camera + t
    return Query(name, category, canonical, points, R, t, viewpoint)


def load_split(data: Path, category: str, split: str, limit: int | None = None):
    """
    (names, (n, 1024, 3) points) of one category's split.

    `limit` takes an evenly spread subset.
    """
    with np.load(Path(data) / f'{category}.npz', allow_pickle=False) as f:
        pts, names = f[f'{split}_points'], f[f'{split}_names']
    if limit is not None and limit < len(pts):
        idx = np.linspace(0, len(pts) - 1, limit).round().astype(int)
        pts, names = pts[idx], names[idx]
    return [str(n) for n in names], pts.astype(np.float64)


def queries(
    data: Path,
    categories,
    experiment: str,
    seed: int,
    limit: int | None,
    rotation: str = 'uniform',
    cut: str | None = None,
    noise: float = 0.0,
) -> list[Query]:
    out = []
    for category in categories:
        names, pts = load_split(data, category, 'test', limit)
        for name, p in zip(names, pts):
            out.append(
                make_query(
                    name,
                    category,
                    p,
                    query_rng(seed, f'{experiment}/{name}', 0),
                    rotation,
                    cut,
                    noise,
                )
            )
    return out
