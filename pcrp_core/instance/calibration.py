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
The evidence an instance answer gives about itself, and the answers a confidence is learnt on.

Views for calibration are rendered when the model is built, from the gallery's own meshes, with
seeds of their own (CALIBRATION_SEED: never a benchmark's): in free space and, when the objects'
up axis is z, standing on a table with gravity given; half of them partly hidden behind an
occluder. Each view is answered twice: as it is, and with its object left out of the gallery,
which is what an object the gallery does not hold looks like to the matcher.

Twins. Some objects have the same shape within the sensor's noise (two duplo bricks, two
screwdrivers with one handle): with one left out, the other explains its views as well as it
does itself. No depth camera tells such objects apart, so they are found here (each explains
the other's views at most TWIN_RATIO times worse than the object itself, mutually), recorded in
the model, and an answer naming a twin with the surface where the object's is counts as right;
a left-out object answered by its twin is not an object the gallery lacks, and is not used.
"""
from __future__ import annotations

from collections import defaultdict

import numpy as np
from scipy.spatial import cKDTree

CALIBRATION_SEED = 2_000_003
# views answered for calibration, in all: enough for boosted trees over a dozen features
# (hundreds of right and of wrong answers) whatever the gallery's size, so each object of a small
# gallery gets more (at most 12 per kind)
CALIBRATION_VIEWS = 600
FEATURES = (
    'cost',
    'unexplained',
    'unshown',
    'fit',
    'coverage',
    'margin',
    'coarse_margin',
    'rms_ratio',
    'log_points',
    'off_noise',
    'missing_noise',
    'shape_gap',
    'searched',
)
# right and wrong answers each at least this many: the calibration is boosted trees, which then
# learn where the evidence turns without learning the noise; fewer, a logistic regression
LEAST_FOR_TREES = 50
TWIN_RATIO = 1.4
POSE_RIGHT = 0.1   # of the object's diameter, as ADD-S counts it


def features(match, n_points: int) -> dict:
    """Return what a Match says about how likely it is right."""
    best = match.best.fit
    second = min((c.fit.cost for c in match.others), default=2.0)
    coarse = [c for c, _ in match.coarse]
    noise = max(match.noise, 1e-6)
    return {
        'cost': best.cost,
        'unexplained': best.unexplained,
        'unshown': best.unshown,
        'fit': best.fit,
        'coverage': best.coverage,
        'margin': max(second, best.cost) - best.cost,
        'coarse_margin': (
            float(np.log(max(coarse[1], 1e-9) / max(coarse[0], 1e-9))) if len(coarse) > 1 else 2.0
        ),
        'rms_ratio': best.rms / match.tau,
        'log_points': float(np.log(max(n_points, 1))),
        'off_noise': best.median_off / noise,
        'missing_noise': best.median_missing / noise,
        'shape_gap': match.shape_gap,
        'searched': match.searched,
    }


def calibration_views(
    meshes: list, up_axis, views_per_object: int = 2, seed: int = CALIBRATION_SEED
):
    """
    (object index, Scene) pairs: views_per_object per object and kind, alternately occluded.

    Table views only for objects modelled z up (as the scene sampler stands them).
    """
    from pcrp_core.evaluation.scenes import sample_scene

    kinds = (
        ('free', 'table')
        if up_axis is not None and np.allclose(up_axis, [0.0, 0.0, 1.0])
        else ('free',)
    )
    return [(i, sample_scene(mesh, str(i), i, v, kind, occlusion=v % 2 == 1, seed=seed))
            for i, mesh in enumerate(meshes) for kind in kinds for v in range(views_per_object)]


def answer_view(model, index: int, scene) -> dict:
    """
    Answer one calibration view with its object in the gallery and left out.

    Returns each answer's features, object, cost and surface error (mean distance from the object's
    true surface to the answer's posed surface, which for the object itself is ADD-S).
    """
    tpl = model.templates
    points = model.prepare(scene.points.astype(np.float64))
    use_up = scene.up is not None and model.up_axis is not None
    up, up_object = (scene.up, model.up_axis) if use_up else (None, None)
    truth = tpl.points[index] @ scene.R.T + scene.t
    out = {'index': index, 'occluded': scene.occluded, 'diameter': float(tpl.diameter[index])}
    for name, exclude in (('known', ()), ('unknown', (index,))):
        if exclude and len(tpl) < 2:   # a gallery of one object has nothing to answer with instead
            continue
        m = model.matcher.match(
            points,
            model.instance_options,
            up,
            up_object,
            np.random.default_rng(0),
            exclude=exclude,
        )
        b = m.best
        error = float(cKDTree(tpl.points[b.index] @ b.R.T + b.t).query(truth)[0].mean())
        out[name] = {
            'features': features(m, len(points)),
            'answer': b.index,
            'cost': b.fit.cost,
            'error': error,
        }
    return out


def calibration_answers(state: dict, index_and_scene) -> dict:
    """Answer one (index, scene) pair with the state's model, in a worker process."""
    index, scene = index_and_scene
    return answer_view(state['model'], index, scene)


def find_twins(views: list[dict]) -> list[tuple[int, int]]:
    """
    Find the pairs (i, j) of objects each of which, left out, is answered as the other.

    Answered so in most of its unoccluded views, at a cost at most TWIN_RATIO times that of the
    answer with it in the gallery (median; that answer may itself be the twin).
    """
    ratios, answers = defaultdict(list), defaultdict(list)
    for v in views:
        if v['occluded'] or 'unknown' not in v:
            continue
        ratios[v['index']].append(v['unknown']['cost'] / max(v['known']['cost'], 1e-9))
        answers[v['index']].append(v['unknown']['answer'])
    like = {}
    for i, seen in answers.items():
        j = max(set(seen), key=seen.count)
        if seen.count(j) >= 2 * len(seen) / 3 and np.median(ratios[i]) <= TWIN_RATIO:
            like[i] = j
    return sorted({tuple(sorted((i, j))) for i, j in like.items() if like.get(j) == i})


def labelled_samples(views: list[dict], twins: list[tuple[int, int]]) -> tuple[list, list]:
    """
    Return (features, right) of the calibration answers.

    Right when the answer is the object or its twin, with the surface within a tenth of the
    diameter; a left-out object answered by its twin is left out of the samples (not an object the
    gallery lacks).
    """
    pairs = {frozenset(p) for p in twins}
    same = lambda i, j: i == j or frozenset((i, j)) in pairs   # noqa: E731
    X, y = [], []
    for v in views:
        k = v['known']
        X.append(k['features'])
        y.append(same(k['answer'], v['index']) and k['error'] < POSE_RIGHT * v['diameter'])
        if 'unknown' in v and not same(v['unknown']['answer'], v['index']):
            X.append(v['unknown']['features'])
            y.append(False)
    return X, y


def calibrate(
    model, meshes: list, n_jobs=None, progress=None, views_per_object: int | None = None
):
    """
    Learn the calibration of the model's instance answers on views of its own meshes.

    Returns (the calibration, twin pairs as gallery IDs); no calibration when the views give no
    wrong answer to learn from (a gallery of one object), and the confidence is then a monotone
    stand-in (instance/answer.py).
    """
    from pcrp_core.parallel import parallel_map

    if views_per_object is None:
        kinds = 2 if model.up_axis is not None else 1
        views_per_object = int(np.clip(CALIBRATION_VIEWS // (kinds * len(meshes)), 2, 12))
    views = calibration_views(meshes, model.up_axis, views_per_object)
    answered = parallel_map(
        calibration_answers, views, {'model': model}, n_jobs, progress, 'calibration'
    )
    twins = find_twins(answered)
    X, y = labelled_samples(answered, twins)
    ids = model.gallery.ids
    return fit_view_calibration(X, y), [[ids[i], ids[j]] for i, j in twins]


def fit_view_calibration(X: list[dict], y: list[bool]):
    """
    Learn the calibration of labelled answers; None when they are all right or all wrong.

    Boosted trees given answers enough of each kind, a logistic regression otherwise. On the
    robot report's validation views (two draws, 312 one-sided a draw) trees rejected 85-88 % of
    the views of objects the gallery lacked where the regression rejected 75-81 %, right against
    unknown ROC AUC 0.98 against 0.96-0.97, and answered partly hidden objects about as well.
    """
    from pcrp_core.confidence import fit_boosted_calibration, fit_calibration

    n_right = int(sum(y))
    if not 0 < n_right < len(y):
        return None
    if min(n_right, len(y) - n_right) >= LEAST_FOR_TREES:
        return fit_boosted_calibration(X, y, FEATURES)
    return fit_calibration(X, y, FEATURES)
