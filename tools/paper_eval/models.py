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
The models the evaluation needs.

Built once with `PCRP.build` and kept in a cache folder, and loaded once per worker process.
"""

from __future__ import annotations

import json
from pathlib import Path
import zlib

import numpy as np
from pcrp_core.pipeline import PCRP
from pcrp_core.sources import load_sources
from tools.paper_eval.protocol import load_split

_LOADED: dict[str, PCRP] = {}
_SUBSETS: dict[tuple, PCRP] = {}


def ensure_model(cache: Path, name: str, data: Path, categories, limit: int | None, progress=None,
                 n_jobs: int | None = None, log=print, split: str = 'train', views: int = 0,
                 holdout: int = 0, calibrate: bool = False) -> tuple[Path, bool]:
    """
    (path, whether it was built now) of the model of these categories' train (or test) splits.

    At most `limit` objects each, built with the package's defaults and seed 0 (and `views`
    one-sided views per object, as `pcrp build --views` makes for depth cameras), reused while its
    recipe is unchanged. holdout: that many objects of each category (held_out()) are kept out.
    calibrate: learn the category-level confidence, as a build does by default (only the model
    whose confidence is reported needs it: it costs minutes per model).
    """
    path = Path(cache) / name
    recipe = {
        'categories': list(categories),
        'limit': limit,
        'data': str(Path(data).resolve()),
        'split': split,
        'views': views,
    }
    if holdout:     # only then: models cached before the held-out check keep their recipe
        recipe['holdout'] = holdout
    stamp = path / 'eval_recipe.json'
    if stamp.is_file() and json.loads(stamp.read_text()) == recipe:
        _record_up_axis(path)
        _add_mirror_planes(path, n_jobs, log)
        if calibrate:
            _add_category_calibration(path, n_jobs, log)
        return path, False
    objects = load_sources(
        [str(Path(data) / f'{c}.npz') for c in categories], split=split, limit_per_category=limit
    )
    if holdout:
        kept_out = {name for c in categories for name in held_out(data, c, holdout, split)}
        objects = [o for o in objects if o.gallery_id not in kept_out]
    log(
        f'building {name}: {len(objects)} {split} objects of {len(categories)} categories, '
        f'{views} views each'
    )
    model = PCRP.build(
        objects,
        sources=[f'{c}.npz' for c in categories],
        views=views,
        progress=progress,
        n_jobs=n_jobs,
        calibrate=calibrate,
    )
    model.save(path)
    stamp.write_text(json.dumps(recipe))
    return path, True


def _record_up_axis(path: Path) -> None:
    """
    Models cached before builds recorded the up axis get ModelNet's (z, as a build now records it).

    Nothing else in them depends on it, so they need no rebuild.
    """
    meta_path = path / 'model.json'
    meta = json.loads(meta_path.read_text())
    if 'up_axis' not in meta:
        meta['up_axis'] = [0.0, 0.0, 1.0]
        meta_path.write_text(json.dumps(meta, indent=1))


def _add_mirror_planes(path: Path, n_jobs: int | None, log=print) -> None:
    """
    Models cached before builds stored the gallery's mirror planes get them now.

    As a build works them out (the rest of the model does not depend on them).
    """
    model = PCRP.load(path)
    if model.gallery.mirrors is not None:
        return
    from pcrp_core.build import mirror_planes
    log(f'adding mirror planes to {path.name}')
    model.gallery.mirrors = mirror_planes(model.gallery.clouds, model.unit, n_jobs)
    model.save(path)


def _add_category_calibration(path: Path, n_jobs: int | None, log=print) -> None:
    """
    Models cached before builds calibrated the category-level path's confidence get it now.

    As a build learns it (nothing else in them depends on it); so do those whose calibration reads
    other evidence than answers give now, or reads whole clouds and views alike.
    """
    from pcrp_core.category.calibration import calibrate
    from pcrp_core.category.evidence import FEATURES
    from pcrp_core.confidence import SplitCalibration

    model = PCRP.load(path)
    cal = model.category_calibration
    if isinstance(cal, SplitCalibration) and cal.names == FEATURES:
        return
    log(f'calibrating the confidence of {path.name}')
    model.category_calibration = calibrate(model, n_jobs)
    model.save(path)


def held_out(data: Path, category: str, n: int, split: str = 'train') -> list[str]:
    """
    Names of n objects of a category's split.

    Drawn by a fixed generator (at most a third of the split, so the gallery keeps most of it), for
    a model built without them.
    """
    names, _ = load_split(data, category, split)
    n = min(n, len(names) // 3)
    pick = np.random.default_rng([2026, zlib.crc32(category.encode())]).choice(
        len(names), n, replace=False
    )
    return [names[i] for i in sorted(pick)]


def loaded(path) -> PCRP:
    key = str(path)
    if key not in _LOADED:
        _LOADED[key] = PCRP.load(key)
    return _LOADED[key]


def category_model(path, category: str) -> PCRP:
    """
    Return the model searching only one category's objects.

    Like the paper's per-category galleries.
    """
    key = (str(path), category)
    if key not in _SUBSETS:
        model = loaded(path)
        _SUBSETS[key] = model.subset(
            [g for g, c in zip(model.gallery.ids, model.gallery.categories) if c == category]
        )
    return _SUBSETS[key]
