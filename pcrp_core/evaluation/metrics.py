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
Pose errors as the YCB-Video and BOP benchmarks count them, so figures compare with theirs.

ADD is the mean distance between the model's points under the true and the estimated pose; ADD-S
(YCB-Video's ADD-S, BOP's ADI) the mean distance from each truly-posed point to the nearest
estimated-posed one, so a can turned about its axis, or a box turned a half turn about a
symmetry axis, costs nothing: many household objects are symmetric, and a depth camera cannot
tell those poses apart. A pose is right when ADD-S is below a tenth of the object's diameter;
the AUC is YCB-Video's area under the share-of-views-below-threshold curve from 0 to 10 cm.
"""
from __future__ import annotations

import re

import numpy as np
from pcrp_core.geometry import rotation_angle_deg
from pcrp_core.sources.camera import Mesh
from scipy.spatial import cKDTree

MODEL_POINTS = 1000
POSE_RIGHT_SHARE = 0.1      # of the diameter
AUC_MAX = 0.10              # metres
# YCB object-set families by id (the set's own grouping; README of the data)
FAMILIES = (
    ('food', 2, 19),
    ('kitchen', 21, 33),
    ('tools', 35, 52),
    ('balls', 53, 58),
    ('shape/task', 59, 77),
)
_YCB_ID = re.compile(r'^(\d{3})(?:-[a-z])?_')


def model_points(mesh: Mesh, n: int = MODEL_POINTS, seed: int = 0) -> np.ndarray:
    """(n, 3) points spread evenly over the surface: what ADD and ADD-S average over."""
    return mesh.sample(n, seed)


def diameter(mesh: Mesh) -> float:
    return mesh.diameter


def _posed(points: np.ndarray, R, t) -> np.ndarray:
    return points @ np.asarray(R, dtype=np.float64).T + np.asarray(t, dtype=np.float64)


def add(R_est, t_est, R, t, points: np.ndarray) -> float:
    """Mean distance between each model point under the true and under the estimated pose."""
    return float(
        np.linalg.norm(_posed(points, R_est, t_est) - _posed(points, R, t), axis=1).mean()
    )


def add_s(R_est, t_est, R, t, points: np.ndarray) -> float:
    """
    Return ADD-S.

    The mean over the truly-posed model points of the distance to the nearest estimated-posed one.
    """
    return float(cKDTree(_posed(points, R_est, t_est)).query(_posed(points, R, t))[0].mean())


def pose_right(adds: float | None, diam: float, share: float = POSE_RIGHT_SHARE) -> bool:
    return adds is not None and np.isfinite(adds) and adds < share * diam


def adds_auc(values, max_threshold: float = AUC_MAX) -> float:
    """
    Area under the curve of the share of views with ADD-S below a threshold.

    Over thresholds 0..max_threshold, divided by max_threshold (1 = every view exact). A view
    without a usable answer (None, inf, nan) counts as failing at every threshold. Exact: each view
    contributes the length of the threshold range it passes, max(0, max_threshold - ADD-S).
    """
    v = np.array([np.inf if x is None else x for x in values], dtype=np.float64)
    if v.size == 0:
        return float('nan')
    v = np.where(np.isfinite(v), v, np.inf)
    return float(np.clip(1.0 - v / max_threshold, 0.0, 1.0).mean())


def share_below(values, thresholds) -> np.ndarray:
    """Return the curve adds_auc integrates: for each threshold, the share of views below it."""
    v = np.array([np.inf if x is None else x for x in values], dtype=np.float64)
    v = np.where(np.isfinite(v), v, np.inf)
    return (v[None, :] < np.asarray(thresholds, dtype=np.float64)[:, None]).mean(axis=1)


def rotation_error_deg(R_est, R) -> float:
    """
    Geodesic angle between two rotations (degrees).

    Blind to symmetry: a can's pose turned about its axis is 'wrong' by this measure and right by
    ADD-S.
    """
    return rotation_angle_deg(R_est, R)


def translation_error(R_est, t_est, R, t, centre=np.zeros(3)) -> float:
    """
    Return the distance between where the two poses put the object's centre.

    The centre is a point of its own frame; the origin gives |t_est - t|. A mesh's origin can lie
    anywhere (YCB's often sit at a corner), so the centre is what says how far off the object is.
    """
    c = np.asarray(centre, dtype=np.float64)
    return float(np.linalg.norm((np.asarray(R_est) @ c + t_est) - (np.asarray(R) @ c + t)))


def family(object_id: str) -> str:
    """
    Return the YCB family of an object id (`025_mug` -> kitchen).

    "all" for ids outside the YCB set's numbering, so other galleries are summarised as one group.
    """
    m = _YCB_ID.match(object_id.rsplit('/', 1)[-1])
    if m:
        number = int(m.group(1))
        for name, lo, hi in FAMILIES:
            if lo <= number <= hi:
                return name
    return 'all'


def surface_error(R_est, t_est, answer_surface: np.ndarray, R, t, points: np.ndarray) -> float:
    """
    Mean distance from the shown object's truly-posed points to the answer's posed surface.

    For the object itself with its own points this is ADD-S. For another object (a twin of the one
    shown) it says whether the robot would find the surface where it was told to: frames of two
    objects differ, so their poses cannot be compared, but the surfaces they put can.
    answer_surface should be dense (a few thousand points) so that its spacing adds little.
    """
    tree = cKDTree(_posed(answer_surface, R_est, t_est))
    return float(tree.query(_posed(points, R, t))[0].mean())


def roc_auc(positive, negative) -> float:
    """
    Chance that a positive's score beats a negative's (ties count half): 0.5 is no signal.

    This is the area under the ROC curve, computed from ranks so that thousands of scores cost no
    more than sorting them; nan when either side is empty.
    """
    a = np.asarray(positive, dtype=np.float64)
    b = np.asarray(negative, dtype=np.float64)
    if a.size == 0 or b.size == 0:
        return float('nan')
    from scipy.stats import rankdata

    ranks = rankdata(np.concatenate([a, b]))
    return float((ranks[: a.size].sum() - a.size * (a.size + 1) / 2) / (a.size * b.size))


def roc_curve(positive, negative) -> tuple[np.ndarray, np.ndarray]:
    """
    Return (false positive rate, true positive rate) over every threshold.

    From (0, 0) to (1, 1).
    """
    a = np.asarray(positive, dtype=np.float64)
    b = np.asarray(negative, dtype=np.float64)
    thresholds = np.unique(np.concatenate([a, b, [np.inf]]))[::-1]
    tpr = np.array([(a >= s).mean() if a.size else np.nan for s in thresholds])
    fpr = np.array([(b >= s).mean() if b.size else np.nan for s in thresholds])
    return np.concatenate([fpr, [1.0]]), np.concatenate([tpr, [1.0]])
