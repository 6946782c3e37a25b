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
Answering by retrieval and registration: PCRP's pipeline, with this package's extensions.

The cloud is described by FR-PointHop and VLAD, the nearest gallery objects are retrieved, and the
Registrar (registrar.py) registers it to them and lets them vote on the rotation. Works for any
gallery and any cloud (whole or one-sided, known size or not); galleries of meshes answer clouds
from a camera view by view instead (instance/answer.py).
"""

from __future__ import annotations

import time

import numpy as np
from pcrp_core.category import evidence
from pcrp_core.category.prepared import prepare
from pcrp_core.category.registrar import Registrar
from pcrp_core.config import QueryOptions
from pcrp_core.geometry import rms_radius
from pcrp_core.result import PoseResult
from pcrp_core.retrieval import describe


def answer(
    model,
    pts: np.ndarray,
    viewpoint,
    up_pair,
    opts: QueryOptions,
    pose_opts,
    timings: dict,
    t0: float,
    evidence_out: dict | None = None,
    exclude=None,
) -> PoseResult:
    """
    Return the PoseResult of a cleaned cloud pts (see PCRP.estimate for the arguments).

    evidence_out, when given, gets the answer's named evidence (evidence.py); exclude: gallery
    indices answered as if the gallery lacked them (calibration.py).

    Units: every cloud is centred and divided by the model-wide unit. In metric mode the query
    keeps its size (scale 1); in normalize mode it is resized to the gallery's typical size,
    then to the first candidate's, and the reported scale is query size / gallery object size.
    """
    centre = pts.mean(0)
    size = 1.0
    if opts.scale_mode == 'normalize':
        size = float(np.median(model.radii)) / max(rms_radius(pts), 1e-12)
    normed = (pts - centre) * (size / model.unit)
    t1 = time.perf_counter()
    vp = (
        None
        if viewpoint is None
        else (np.asarray(viewpoint, dtype=np.float64) - centre) / model.unit * size
    )
    sampled, feats, vec = describe(model.pointhop, model.vlad, normed, vp, timings)
    t2 = time.perf_counter()
    timings['features'] = t2 - t1
    n_candidates = opts.n_candidates if viewpoint is None else opts.n_candidates_view
    idx, dist = model.gallery.search(vec, max(10, n_candidates), exclude)
    t3 = time.perf_counter()
    timings['retrieval'] = t3 - t2
    rng = np.random.default_rng(opts.seed)
    ratio = 1.0
    if opts.scale_mode == 'normalize':
        ratio = model.radii[idx[0]] / float(np.median(model.radii))
    registrar = Registrar(
        prepare(normed * ratio, sampled, feats),
        pose_opts,
        rng,
        None if vp is None else vp * ratio,
        timings,
        up_pair,
    )
    top = [int(i) for i in idx[:n_candidates]]
    n_matched = registrar.effort.matched(opts.n_matched, dist)
    matched = [model.prepared.get(i, True, opts.cache_size) for i in top[:n_matched]]
    verifiers = matched + [model.prepared.get(i, False, opts.cache_size) for i in top[n_matched:]]
    j, h = registrar.best_pose(matched, verifiers, [model.gallery.categories[i] for i in top])
    i = top[j]
    timings['registration'] = time.perf_counter() - t3
    # g_n = R' (k q_n) + t'  with q_n = (q - centre)/unit, g_n = (g - c_g)/unit, k = size * ratio
    # => q = (1/k) R'^T (g - c_g) - (unit/k) R'^T t' + centre
    k = size * ratio
    c_g = model.gallery.clouds[i].astype(np.float64).mean(0)
    R = h.R.T
    scale = 1.0 / k
    t = centre - scale * (R @ (c_g + model.unit * h.t))
    score = h.fitness
    surface = evidence.both_ways(registrar.fitter, h, verifiers[j], pose_opts.inlier_distance)
    named = evidence.features(
        registrar.evidence, surface, h, registrar.averaged, float(dist[0]), viewpoint is None
    )
    if evidence_out is not None:
        evidence_out.update(named)
    calibration = getattr(model, 'category_calibration', None)
    # a model built before this path was calibrated lets the fit score stand in for a confidence
    confidence = score if calibration is None else calibration.probability(named)
    rejected = confidence < opts.min_confidence
    timings['total'] = time.perf_counter() - t0
    return PoseResult(
        gallery_id=model.gallery.ids[i],
        category=model.gallery.categories[i],
        rotation=R,
        translation=t,
        scale=scale,
        score=score,
        fitness=h.fitness,
        inlier_rmse=h.rmse * model.unit / k,
        chamfer=h.chamfer,
        rejected=rejected,
        confidence=confidence,
        reason=(
            f'confidence {confidence:.2f} below min_confidence {opts.min_confidence:.2f}'
            if rejected
            else ''
        ),
        candidates=tuple((model.gallery.ids[j], float(d)) for j, d in zip(idx, dist)),
        timings=timings,
        n_points=len(pts),
    )
