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

"""ModelNet40 category archives as laid out in shared/data/modelnet40 (one .npz per category)."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from pcrp_core.sources.gallery_object import GalleryObject


def load_archive(
    path, split: str = 'train', n_points: int = 1024, seed: int = 0, limit: int | None = None
):
    path = Path(path)
    if split not in ('train', 'test'):
        raise ValueError(f'split must be train or test, got {split!r}')
    try:
        with np.load(path, allow_pickle=False) as npz:
            points, names = npz[f'{split}_points'], npz[f'{split}_names']
    except KeyError:
        raise ValueError(
            f'{path}: not a ModelNet40 category archive (no {split}_points / {split}_names)'
        ) from None
    if limit is not None:
        points, names = points[:limit], names[:limit]
    rng = np.random.default_rng(seed)
    objects = []
    for p, name in zip(points, names):
        if n_points < len(p):
            p = p[np.sort(rng.choice(len(p), n_points, replace=False))]
        # ModelNet's own axes: z up (its README; airplanes and cars are flattest along z)
        objects.append(
            GalleryObject(str(name), path.stem, np.asarray(p, dtype=np.float32), up='z')
        )
    return objects


def modelnet_categories(data_dir) -> list[str]:
    return sorted(p.stem for p in Path(data_dir).glob('*.npz'))
