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
Where gallery objects and queries come from.

ModelNet40 archives, the user's folders, the generator.
"""
from __future__ import annotations

from pathlib import Path

from pcrp_core.sources.gallery_object import GalleryObject

__all__ = ['GalleryObject', 'load_source', 'load_sources']


def load_source(spec: str, split: str = 'train', n_points: int = 1024, seed: int = 0,
                limit_per_category: int | None = None) -> list[GalleryObject]:
    """
    Load the gallery objects of one source.

    `household[:N]` (the embedded gallery of household meshes in metres, or N variants of its
    kinds), `procedural[:N]` (the embedded generator, N per category, default 25), a ModelNet40
    category archive (`chair.npz`), or a folder of meshes or clouds (one object per file, or one
    sub-folder per category).
    """
    if spec == 'household' or spec.startswith('household:'):
        from pcrp_core.sources.household import household_gallery

        return household_gallery(
            int(spec.split(':', 1)[1]) if ':' in spec else None, seed=seed, n_points=n_points
        )
    if spec == 'procedural' or spec.startswith('procedural:'):
        from pcrp_core.sources.procedural import generate_gallery

        n = int(spec.split(':', 1)[1]) if ':' in spec else 25
        if limit_per_category is not None:
            n = min(n, limit_per_category)
        return generate_gallery(n, seed=0, n_points=n_points, split=split)
    path = Path(spec)
    if path.suffix == '.npz':
        if not path.is_file():
            raise ValueError(f'{spec}: no such archive')
        from pcrp_core.sources.modelnet import load_archive

        return load_archive(path, split, n_points, seed, limit_per_category)
    if path.is_dir():
        from pcrp_core.sources.folder import load_folder

        return load_folder(path, n_points, seed, limit_per_category)
    raise ValueError(f'{spec}: not a ModelNet40 archive (.npz), a folder, or procedural[:N]')


def load_sources(specs, **kwargs) -> list[GalleryObject]:
    objects = [o for spec in specs for o in load_source(spec, **kwargs)]
    seen = set()
    for o in objects:
        if o.gallery_id in seen:
            raise ValueError(f'gallery ID {o.gallery_id!r} appears twice among the sources')
        seen.add(o.gallery_id)
    return objects
