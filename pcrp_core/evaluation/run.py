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
Answer every view with a model and count what a robot would care about.

A view's answer is right when it names the right object, or an object the model records as its twin
(the same shape within the sensor's noise: no depth camera tells them apart), and puts the object's
surface where it is: ADD-S below 10 % of the object's diameter (for a twin, the mean distance from
the true surface to the answer's). Since a robot acts on what it accepts, the summary also
separates the wrong answers the model accepted (the dangerous ones: it would grasp air) from the
right ones it rejected (the lost ones: it would ask again), and says how well the confidence ranks
right answers above wrong ones. Errors of answers naming another object are not measured (their
pose is of another object's frame); they count as failures in the AUC.
"""
from __future__ import annotations

from dataclasses import dataclass
import time

import numpy as np
from pcrp_core.evaluation import metrics
from pcrp_core.evaluation.scenes import Scene
from pcrp_core.sources.camera import Mesh

# points of an answer's surface: their spacing (3 % of a ball's diameter) is what a twin's
# surface error has over its true value, well under the 10 % that makes a pose right
SURFACE_POINTS = 4000


@dataclass(frozen=True)
class Truth:
    """What scoring needs of one object, computed once per object."""

    points: np.ndarray      # model points ADD and ADD-S average over
    diameter: float
    centre: np.ndarray      # the mean of those points, where the translation error is measured


class Truths(dict):
    """object_id -> Truth, filled on first use from the meshes."""

    def __init__(self, meshes: dict[str, Mesh]):
        super().__init__()
        self.meshes = meshes
        self._surfaces = {}

    def __missing__(self, object_id: str) -> Truth:
        mesh = self.meshes[object_id]
        pts = metrics.model_points(mesh)
        self[object_id] = Truth(pts, metrics.diameter(mesh), pts.mean(0))
        return self[object_id]

    def surface(self, object_id: str) -> np.ndarray | None:
        """
        Dense points of an object's surface, where an answer naming it puts it.

        None for an object without a mesh here (a user's folder need not hold the whole gallery).
        """
        if object_id not in self._surfaces:
            mesh = self.meshes.get(object_id)
            self._surfaces[object_id] = None if mesh is None else mesh.sample(SURFACE_POINTS, 1)
        return self._surfaces[object_id]


def twin_pairs(model) -> frozenset:
    """
    Return the pairs of gallery objects the model found to have one shape.

    They are read from model.meta['twins'].
    """
    meta = getattr(model, 'meta', None) or {}
    return frozenset(frozenset(p) for p in meta.get('twins') or ())


def record(scene: Scene, answer, seconds: float, truths: Truths, reason: str = '',
           twins=frozenset()) -> dict:
    """
    One view's row.

    answer: anything with gallery_id, rotation, translation, rejected, reason and a confidence
    (or score) in [0, 1]; None when the method gave no answer (reason says why). twins: pairs
    (frozensets) of gallery objects no depth camera tells apart; an answer naming the shown
    object's twin is judged by where it puts the surface (surface_error), not by its frame.
    candidate_rank: the true object's 1-based rank among the answer's retrieval candidates (0:
    not among them; None: the method lists none).
    """
    truth = truths[scene.object_id]
    row = {'object_id': scene.object_id, 'family': metrics.family(scene.object_id),
           'scenario': scene.scenario, 'view': scene.view, 'seed': scene.seed,
           'distance': round(scene.distance, 4), 'occluded_share': round(scene.occluded_share, 4),
           'n_points': int(len(scene.points)), 'diameter': round(truth.diameter, 5),
           'gallery_id': None, 'right_object': False, 'twin': False, 'right_or_twin': False,
           'add': None, 'add_s': None, 'surface_error': None, 'pose_right': False,
           'rotation_error_deg': None, 'translation_error': None, 'rejected': True,
           'reason': reason, 'confidence': 0.0, 'candidate_rank': None, 'stray_share': 0.0,
           'table_share': 0.0, 'seconds': float(seconds), 'timings': {}}
    if answer is None:
        return row
    right = answer.gallery_id == scene.object_id
    twin = frozenset((answer.gallery_id, scene.object_id)) in twins
    # where retrieval put the true object, to tell a retrieval miss from a wrong pick
    listed = [g for g, _ in getattr(answer, 'candidates', ())]
    rank = (
        (listed.index(scene.object_id) + 1 if scene.object_id in listed else 0) if listed else None
    )
    confidence = getattr(answer, 'confidence', getattr(answer, 'score', 0.0))
    row.update(gallery_id=answer.gallery_id, right_object=bool(right), twin=bool(twin),
               right_or_twin=bool(right or twin), rejected=bool(answer.rejected),
               reason=answer.reason, confidence=float(confidence), candidate_rank=rank,
               stray_share=float(getattr(answer, 'stray_share', 0.0)),
               table_share=float(getattr(answer, 'table_share', 0.0)),
               timings={k: float(v) for k, v in (getattr(answer, 'timings', None) or {}).items()})
    R = np.asarray(answer.rotation, dtype=np.float64)
    t = np.asarray(answer.translation, dtype=np.float64)
    if right:
        adds = metrics.add_s(R, t, scene.R, scene.t, truth.points)
        row.update(add=metrics.add(R, t, scene.R, scene.t, truth.points), add_s=adds,
                   surface_error=adds, pose_right=metrics.pose_right(adds, truth.diameter),
                   rotation_error_deg=metrics.rotation_error_deg(R, scene.R),
                   translation_error=metrics.translation_error(R, t, scene.R, scene.t,
                                                               truth.centre))
    elif twin and truths.surface(answer.gallery_id) is not None:
        error = metrics.surface_error(R, t, truths.surface(answer.gallery_id), scene.R, scene.t,
                                      truth.points)
        row.update(surface_error=error, pose_right=metrics.pose_right(error, truth.diameter))
    return row


def evaluate(model, scenes: list[Scene], meshes: dict[str, Mesh], use_up: bool = False,
             progress=None, truths: Truths | None = None, twins=None,
             use_scene: bool = False) -> list[dict]:
    """
    Per-view records of model.estimate on every scene, as the node calls it.

    The cloud is in the camera's frame (viewpoint at the origin) and, with use_up, the table's
    normal is given as up; with use_scene, what the camera measured of the object and its occluder
    is given as the scene, a depth image as the node reads a camera's depth cloud. seconds is the
    wall time of the call. A cloud the model refuses (InvalidCloud) is a rejected view without an
    answer. twins: by default the model's own.
    """
    from pcrp_core.errors import InvalidCloud

    truths = truths if truths is not None else Truths(meshes)
    twins = twin_pairs(model) if twins is None else twins
    rows = []
    for scene in progress(scenes, desc='estimate') if progress is not None else scenes:
        up = scene.up if use_up else None
        seen = scene.depth_image() if use_scene and scene.occluder is not None else None
        t0 = time.perf_counter()
        try:
            answer, reason = model.estimate(scene.points, viewpoint=np.zeros(3), up=up,
                                            scene=seen), ''
        except InvalidCloud as e:
            answer, reason = None, f'invalid cloud ({e.reason})'
        rows.append(record(scene, answer, time.perf_counter() - t0, truths, reason, twins))
    return rows


def jsonable(x, digits: int | None = None):
    """
    Return x with numpy scalars as Python numbers and nan/inf as None (JSON has neither).

    Floats to `digits` significant digits when given.
    """
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float):
        return None if not np.isfinite(x) else (float(f'{x:.{digits}g}') if digits else x)
    if isinstance(x, dict):
        return {k: jsonable(v, digits) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v, digits) for v in x]
    return x


def _median(values) -> float:
    v = [x for x in values if x is not None]
    return float(np.median(v)) if v else float('nan')


def rejected_at(row: dict, min_confidence: float | None) -> bool:
    """
    Whether the row's answer is rejected at min_confidence (None: as the method decided).

    A view without an answer stays rejected; the model rejects exactly the answers whose confidence
    is below min_confidence, so any threshold can be read off the records.
    """
    if min_confidence is None or row['gallery_id'] is None:
        return row['rejected']
    return row['confidence'] < min_confidence


def statistics(rows: list[dict], min_confidence: float | None = None) -> dict:
    """
    Figures of a set of views.

    Shares are of all views in rows, except right_rejected, which is of the right answers (how
    many of them a robot loses); error medians are over the views answered with the right object
    (accepted or not). Right: pose_right, the right object or a twin with the surface in place.
    confidence_auc: the chance that a right answer is more confident than a wrong one, over the
    views with an answer. min_confidence: read rejections at this threshold instead.
    """
    n = len(rows)
    if n == 0:
        return {'views': 0}
    rejected = np.array([rejected_at(r, min_confidence) for r in rows])
    right = np.array([r['pose_right'] for r in rows])
    seconds = np.array([r['seconds'] for r in rows])
    answered = [r for r in rows if r['gallery_id'] is not None]
    return {'views': n, 'right_object': float(np.mean([r['right_object'] for r in rows])),
            'right_or_twin': float(np.mean([r['right_or_twin'] for r in rows])),
            'pose_right': float(right.mean()),
            'auc': metrics.adds_auc([r['surface_error'] for r in rows]),
            'rotation_median_deg': _median([r['rotation_error_deg'] for r in rows]),
            'translation_median': _median([r['translation_error'] for r in rows]),
            'accepted': float(np.mean(~rejected)),
            'right_accepted': float(np.mean(right & ~rejected)),
            'wrong_accepted': float(np.mean(~right & ~rejected)),
            'right_rejected': float((right & rejected).sum() / right.sum()) if right.any()
            else float('nan'),
            'confidence_auc': metrics.roc_auc(
                [r['confidence'] for r in answered if r['pose_right']],
                [r['confidence'] for r in answered if not r['pose_right']]),
            'seconds_median': float(np.median(seconds)),
            'seconds_p95': float(np.quantile(seconds, 0.95))}


def unknown_statistics(known: list[dict], unknown: list[dict],
                       min_confidence: float | None = None) -> dict:
    """
    Figures of views of objects the gallery lacks (every answer to them is wrong).

    rejected: the share of those views rejected; auc: the chance that a right answer on an object
    the gallery holds (known: their views) is more confident than an answer on one it lacks.
    """
    if not unknown:
        return {'views': 0}
    right = [r['confidence'] for r in known if r['gallery_id'] is not None and r['pose_right']]
    return {'views': len(unknown),
            'rejected': float(np.mean([rejected_at(r, min_confidence) for r in unknown])),
            'auc': metrics.roc_auc(right, [r['confidence'] for r in unknown
                                           if r['gallery_id'] is not None])}


def format_unknown(stats: dict, meshes: int) -> str:
    """Return unknown_statistics as one line of text."""
    text = (f"objects the gallery lacks: {stats['views']} views of {meshes} meshes, "
            f"{stats['rejected']:.0%} rejected")
    if np.isfinite(stats['auc']):   # there were right answers on the gallery's own objects
        text += (f"; conf AUC {stats['auc']:.2f} (right answers on the gallery's objects "
                 'against answers on these)')
    return text


def stage_means(rows: list[dict]) -> dict:
    """Mean seconds per stage of the answers' timings, in the order the stages ran."""
    keys = list(dict.fromkeys(k for r in rows for k in r.get('timings') or {}))
    return {k: float(np.mean([r['timings'][k] for r in rows if k in (r.get('timings') or {})]))
            for k in keys}


def summarise(rows: list[dict], min_confidence: float | None = None) -> dict:
    """Statistics overall and per YCB family (in the families' order), and stage times."""
    order = [name for name, _, _ in metrics.FAMILIES] + ['all']
    present = sorted({r['family'] for r in rows}, key=order.index)
    return {'overall': statistics(rows, min_confidence),
            'families': {f: statistics([r for r in rows if r['family'] == f], min_confidence)
                         for f in present},
            'stages': stage_means(rows)}


ACCURACY_COLUMNS = (
    ('views', 'views', '{:d}'), ('right_object', 'right obj', '{:.0%}'),
    ('right_or_twin', 'obj or twin', '{:.0%}'), ('pose_right', 'pose right', '{:.0%}'),
    ('auc', 'ADD-S AUC', '{:.3f}'), ('rotation_median_deg', 'rot med', '{:.1f}°'),
    ('translation_median', 'trans med', '{:.1f} mm'))
CONFIDENCE_COLUMNS = (
    ('accepted', 'accepted', '{:.0%}'), ('wrong_accepted', 'wrong acc', '{:.0%}'),
    ('right_rejected', 'right rej', '{:.0%}'), ('confidence_auc', 'conf AUC', '{:.2f}'),
    ('seconds_median', 'time med', '{:.2f} s'), ('seconds_p95', 'time p95', '{:.2f} s'))
COLUMNS = ACCURACY_COLUMNS + CONFIDENCE_COLUMNS
LEGEND = '\n'.join([
    'right obj: the object shown; obj or twin: or one the model records as the same shape (no',
    'depth camera tells them apart); pose right: either, with ADD-S (for a twin: the distance',
    "to its surface) under 10 % of the diameter. accepted: at the model's min_confidence; wrong",
    'acc: accepted and not right (shares of the views); right rej: share of the right answers',
    "rejected; conf AUC: chance a right answer's confidence beats a wrong one's (0.5: none)."])


def cell(key: str, value) -> str:
    fmt = {k: f for k, _, f in COLUMNS}[key]
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return '-'
    return fmt.format(value * 1000 if key == 'translation_median' else value)


def _text_table(header: list[str], rows: list[list[str]]) -> str:
    table = [header] + rows
    widths = [max(len(r[i]) for r in table) for i in range(len(header))]
    return '\n'.join('  '.join(c.ljust(w) if i == 0 else c.rjust(w)
                               for i, (c, w) in enumerate(zip(r, widths))) for r in table)


def format_summary(summary: dict) -> str:
    """
    Return the summary as plain text.

    Accuracy, then confidence and time, one row per family and one for all views; then the mean
    seconds per stage.
    """
    rows = [(f, s) for f, s in summary['families'].items()
            if f != 'all' or len(summary['families']) > 1]
    rows.append(('overall', summary['overall']))
    parts = [_text_table(['family'] + [t for _, t, _ in columns],
                         [[name] + [cell(k, s.get(k)) for k, _, _ in columns] for name, s in rows])
             for columns in (ACCURACY_COLUMNS, CONFIDENCE_COLUMNS)]
    stages = summary.get('stages') or {}
    if stages:
        parts.append('mean ms per stage: ' + ', '.join(f'{k} {v * 1000:.1f}'
                                                       for k, v in stages.items()))
    return '\n\n'.join(parts + [LEGEND])
