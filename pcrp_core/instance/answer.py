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

"""Answer a camera's cloud from a gallery of meshes, view by view (matcher.py), as a PoseResult."""
from __future__ import annotations

import time

import numpy as np

from pcrp_core.config import QueryOptions
from pcrp_core.instance.calibration import features
from pcrp_core.instance.occlusion import seen_from
from pcrp_core.result import PoseResult


def answer(
    model,
    pts: np.ndarray,
    viewpoint: np.ndarray,
    up_pair,
    opts: QueryOptions,
    timings: dict,
    t0: float,
    scene=None,
    floor: float | None = None,
) -> PoseResult:
    """
    Return the PoseResult of a cleaned cloud pts seen from viewpoint (see PCRP.estimate).

    The cloud is moved so the camera is at the origin; its frame's orientation does not matter.
    floor: the height along up under which the table's layer was set aside (support.py), if it
    was.
    """
    rng = np.random.default_rng(opts.seed)
    up, up_object = (None, None) if up_pair is None else up_pair
    match = model.matcher.match(
        pts - viewpoint, model.instance_options, up, up_object, rng, timings,
        scene=None if scene is None else seen_from(scene, viewpoint),
        floor=None if floor is None else floor - float(viewpoint @ up),
    )
    best = match.best
    if model.view_calibration is not None:
        confidence = model.view_calibration.probability(features(match, len(pts)))
    else:   # a model built before calibration: a monotone stand-in, not a probability
        confidence = float(np.exp(-best.fit.cost))
    rejected = confidence < opts.min_confidence
    timings['total'] = time.perf_counter() - t0
    ids = model.gallery.ids
    return PoseResult(
        gallery_id=ids[best.index],
        category=model.gallery.categories[best.index],
        rotation=best.R,
        translation=best.t + viewpoint,
        scale=1.0,
        score=1.0 - best.fit.cost / 2,
        confidence=confidence,
        fitness=best.fit.fit,
        inlier_rmse=best.fit.rms,
        chamfer=best.fit.cost,
        rejected=rejected,
        reason=(
            f'confidence {confidence:.2f} below min_confidence {opts.min_confidence:.2f}'
            if rejected
            else ''
        ),
        candidates=tuple((ids[c.index], c.fit.cost) for c in [best] + match.others),
        twins=tuple(
            g
            for pair in model.meta.get('twins') or ()
            if ids[best.index] in pair
            for g in pair
            if g != ids[best.index]
        ),
        timings=timings,
        n_points=len(pts),
    )
