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
What an answer of the category-level path says about itself.

The named features a calibrated confidence (pcrp_core/confidence.py) is learnt on.

A right answer (right category, rotation within RIGHT_DEG) differs from a wrong one in two ways
that registration can see. An object from outside the gallery fits no candidate well and its
candidates disagree: about the category, and about which pose suits them. A turned answer (the
half turn a near-symmetric object is confused by) fits its own candidate nearly as well as the
right one, so the margin of the vote over the best other pose is small. An object from outside
that does fit one candidate (a keyboard laid on a flat sofa) still lacks the parts the candidate
has, and fits the candidate's relatives at that pose much worse: the fit the other way (the
candidate's points far from the cloud) and the category's median fit say so.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.category.vote import vote_scores, voting_candidates
from pcrp_core.registration.icp import transform_batch
from pcrp_core.registration.scoring import distances_back

FEATURES = (
    'fitness',
    'chamfer',
    'pose_margin',
    'agreement',
    'candidate_ratio',
    'category_share',
    'averaged',
    'retrieval_distance',
    'whole',
    'fit_tight',
    'missing',
    'missing_far',
    'category_fit',
    'category_fit_ratio',
    'runner_up',
    'fit_q90',
    'missing_q90',
)
RIGHT_DEG = 15.0  # an answer this close in rotation, and of the right category, is right
NO_RIVAL = 1.0  # the pose margin when no other pose was voted on
TIGHT = 0.4  # fit_tight counts query points within this share of the inlier distance
FAR = 2.0  # missing_far counts gallery points farther than this many inlier distances


def from_vote(ch: np.ndarray, groups, k: int, weight: float) -> dict:
    """
    Evidence the vote gives, ch: (hypotheses, candidates) chamfers, k: the chosen hypothesis.

    pose_margin: how much worse the best other hypothesis scores (vote_scores, relative to the
    chosen one's score); agreement: the share of voting candidates whose own best hypothesis is the
    chosen one; candidate_ratio: the best candidate's fit of the chosen pose over the second best's
    (well under 1 when one candidate is the very object); category_share: the share of candidates
    that vote (of the best-fitting candidate's category); category_fit: the voters' median fit of
    the chosen pose, category_fit_ratio the same over the best fit (an object of the category fits
    its relatives nearly as well as its closest one); runner_up: the best fit of any other pose on
    any voter, over the chosen pose's best.
    """
    voters = voting_candidates(ch, groups)
    scores = vote_scores(ch, voters, weight)
    others = np.delete(scores, k)
    margin = float((others.min() - scores[k]) / max(scores[k], 1e-12)) if len(others) else NO_RIVAL
    agreement = float(np.mean(np.argmin(ch[:, voters], axis=0) == k))
    fits = np.sort(ch[k])
    ratio = float(fits[0] / max(fits[1], 1e-12)) if len(fits) > 1 else 1.0
    best = max(float(fits[0]), 1e-12)
    median = float(np.median(ch[k, voters]))
    rival = np.delete(ch, k, axis=0)[:, voters]
    return {
        'pose_margin': margin,
        'agreement': agreement,
        'candidate_ratio': ratio,
        'category_share': float(voters.mean()),
        'category_fit': median,
        'category_fit_ratio': median / best,
        'runner_up': float(rival.min()) / best if rival.size else 1.0 + NO_RIVAL,
    }


def alone(chamfer: float = 0.0) -> dict:
    """
    Return the same when there was no vote (one candidate, or the vote switched off).

    chamfer: the answer's own fit, all the category's fit there is.
    """
    return {
        'pose_margin': NO_RIVAL,
        'agreement': 1.0,
        'candidate_ratio': 1.0,
        'category_share': 1.0,
        'category_fit': float(chamfer),
        'category_fit_ratio': 1.0,
        'runner_up': 1.0 + NO_RIVAL,
    }


def both_ways(fitter, hyp, gallery, inlier_distance: float) -> dict:
    """
    How the posed query and the gallery object it answered with explain each other.

    fit_tight: the share of the query's points within TIGHT inlier distances of the object (a right
    pose of a relative fits many closely, a wrong object few); missing: the mean distance from the
    object's points to the query, missing_far the share of them farther than FAR inlier distances
    (what of the object the cloud lacks); fit_q90 and missing_q90: the distance, in inlier
    distances, within which nine tenths of the query's points lie of the object, and of the
    object's points of the query (a part that fits nowhere: an object from outside the gallery
    that fits one part of a candidate, or lacks one). One query of each tree, on the points scoring
    uses.
    """
    moved = transform_batch(fitter.src, hyp.R[None], hyp.t[None])[0]
    ahead = gallery.tree.query(moved)[0]
    own = gallery.points[:: max(1, len(gallery.points) // len(fitter.src))]
    back = distances_back(fitter.tree, own, [hyp.R], [hyp.t])[0]
    return {
        'fit_tight': float(np.mean(ahead < TIGHT * inlier_distance)),
        'missing': float(back.mean()),
        'missing_far': float(np.mean(back > FAR * inlier_distance)),
        'fit_q90': float(np.quantile(ahead, 0.9)) / inlier_distance,
        'missing_q90': float(np.quantile(back, 0.9)) / inlier_distance,
    }


def features(
    vote_evidence: dict, surface: dict, hyp, averaged: int, distance: float, whole: bool
) -> dict:
    """
    Return the named FEATURES of one answer.

    surface: both_ways() of its final hypothesis hyp; averaged how many candidates' poses it
    averages, distance the retrieval distance of the first candidate.
    """
    return {
        **vote_evidence,
        **surface,
        'fitness': float(hyp.fitness),
        'chamfer': float(hyp.chamfer),
        'averaged': float(averaged),
        'retrieval_distance': float(distance),
        'whole': float(whole),
    }
