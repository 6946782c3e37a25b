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
A confidence for the category-level path.

Learnt when the model is built on the gallery's own objects, with seeds of its own
(CALIBRATION_SEED: never a benchmark's).

A robot meets three kinds of object: one the gallery holds, an instance of a known category
that the gallery does not hold (every category-level query is one), and an object of a
category the gallery lacks. All are simulated with the gallery itself. A few objects of each
category are queried, whole (with noise) and as one-sided views, under random rotations: as
they are, with the object left out of the gallery, and with its whole category left out. An
answer is right when its category is and its rotation is within evidence.RIGHT_DEG; with the
object left out, also when it is that close to laying the object it answered with on the cloud
(frames.py: a gallery whose objects disagree about which way is front defines the pose no better
than that, and the answered object at the answered pose is what a user acts on); with the
category left out, none is; nor is any answer to a random solid of a gallery object's size
(boxes, cylinders and ellipsoids joined: sources/primitives.py), whole, one per object queried: the
objects a robot meets that no category resembles (thin, flat or odd shapes that fit one part of a
candidate well). Logistic regression on the answers' evidence (evidence.FEATURES)
gives the probability that an answer is right, one regression for whole clouds and one for
one-sided views (the same evidence means less on a view, whose right answers lack most of their
object).
"""

from __future__ import annotations

import time

import numpy as np
from pcrp_core.category.evidence import FEATURES, RIGHT_DEG
from pcrp_core.category.frames import axis_turn
from pcrp_core.geometry import rms_radius, rotation_angle_deg

CALIBRATION_SEED = 3_000_017
PER_CATEGORY = 16  # objects of each category queried, at most
TOTAL = 96  # objects queried in all, at most: a gallery of many categories gets fewer of each
VIEW_NOISE = 0.005  # range noise of the one-sided views, in object radii
WHOLE_NOISE = 0.01  # noise of the whole clouds, in object radii: an object measured again


rotation_error_deg = rotation_angle_deg


def calibration_queries(model, per_category: int = PER_CATEGORY, seed: int = CALIBRATION_SEED):
    """
    (gallery index, points, viewpoint or None, true rotation) of each calibration query.

    Up to per_category objects of each category (an eighth of it at most, TOTAL in all), whole and
    one-sided.
    """
    rng = np.random.default_rng(seed)
    cats = np.array(model.gallery.categories)
    names = sorted(set(cats))
    per_category = max(1, min(per_category, TOTAL // len(names)))
    out = []
    for c in names:
        members = np.flatnonzero(cats == c)
        n = min(per_category, max(1, len(members) // 8))
        for i in np.sort(rng.choice(members, n, replace=False)):
            cloud = model.gallery.clouds[i].astype(np.float64)
            for view in (False, True):
                out.append((int(i), *_posed(cloud, view, rng, model.radii[i])))
    return out


def solid_queries(model, n: int, seed: int = CALIBRATION_SEED):
    """
    Return (None, points, None, None) of n whole random solids, as calibration_queries poses them.

    Each with a random gallery object's number of points and size (rms radius).
    """
    from pcrp_core.sources.primitives import random_solid

    rng = np.random.default_rng([seed, 1])
    out = []
    for _ in range(n):
        cloud = model.gallery.clouds[rng.integers(len(model.gallery.clouds))]
        size = rms_radius(cloud)
        solid = random_solid(rng, len(cloud))
        solid *= size / max(rms_radius(solid), 1e-12)
        points, _, _ = _posed(solid, False, rng, size)
        out.append((None, points, None, None))
    return out


def _posed(cloud: np.ndarray, view: bool, rng, shift: float):
    """
    (points, viewpoint or None, R) of a cloud seen as a query sees it.

    Whole with noise, or one side of it; turned by a random R and moved up to shift / 2 each way.
    """
    from pcrp_core.sources.views import partial_view, random_rotation

    radius = np.linalg.norm(cloud - cloud.mean(0), axis=1).max()
    part, camera = (
        partial_view(cloud, rng, VIEW_NOISE, with_camera=True)
        if view
        else (cloud + rng.normal(scale=WHOLE_NOISE * radius, size=cloud.shape), None)
    )
    R, t = random_rotation(rng), rng.uniform(-0.5, 0.5, 3) * shift
    vp = None if camera is None else R @ camera + t
    return np.asarray(part, dtype=np.float64) @ R.T + t, vp, R


def answer_without(model, points, viewpoint, drop, evidence_out: dict):
    """
    Return model.estimate(points, viewpoint) by the category-level path.

    As if the gallery lacked the objects drop (indices), its evidence into evidence_out.
    """
    from pcrp_core.category.answer import answer

    t0 = time.perf_counter()
    pts = model.prepare(points)
    return answer(
        model,
        pts,
        viewpoint,
        None,
        model.options,
        model.pose_options,
        {'preprocess': time.perf_counter() - t0},
        t0,
        evidence_out,
        drop,
    )


def answer_query(state: dict, item) -> list[tuple[dict, bool]]:
    """
    (evidence, right) of one calibration query answered as it is.

    With its object left out and, when the gallery holds other categories, with its whole category
    left out.
    """
    model = state['model']
    index, points, viewpoint, R = item
    if index is None:   # a solid of no category: every answer to it is wrong
        ev = {}
        answer_without(model, points, viewpoint, [], ev)
        return [(ev, False)]
    category = model.gallery.categories[index]
    same = [n for n, c in enumerate(model.gallery.categories) if c == category]
    out = []
    for drop, known in (([], True), ([index], True), (same, False)):
        if len(drop) == len(model.gallery.ids):
            continue
        ev = {}
        r = answer_without(model, points, viewpoint, drop, ev)
        truths = [R] if known and r.category == category else []
        if drop and truths and r.gallery_id in model.gallery.index:
            # left out, it comes back in the answered object's frame: R @ M.T when M lays it there
            answered = model.gallery.clouds[model.gallery.index[r.gallery_id]]
            truths.append(R @ axis_turn(model.gallery.clouds[index], answered).T)
        right = any(rotation_error_deg(r.rotation, T) < RIGHT_DEG for T in truths)
        out.append((ev, bool(right)))
    return out


def calibrate(model, n_jobs=None, progress=None, per_category: int = PER_CATEGORY):
    """
    Return the SplitCalibration (whole clouds, views) of the model's category-level answers.

    Or None when its calibration answers are all right or all wrong (nothing to learn from).
    """
    from pcrp_core.confidence import fit_split_calibration
    from pcrp_core.parallel import parallel_map

    queries = calibration_queries(model, per_category)
    # as many solids as objects queried (each object is asked whole and as a view)
    queries += solid_queries(model, len(queries) // 2)
    answered = parallel_map(
        answer_query, queries, {'model': model}, n_jobs, progress, 'calibration', chunksize=4
    )
    samples = [s for rows in answered for s in rows]
    X, y = [ev for ev, _ in samples], [right for _, right in samples]
    if len(set(y)) < 2:
        return None
    return fit_split_calibration(X, y, FEATURES, 'whole')
