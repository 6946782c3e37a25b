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
right one, so the margin of the vote over the best other pose is small.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.category.vote import vote_scores, voting_candidates

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
)
RIGHT_DEG = 15.0  # an answer this close in rotation, and of the right category, is right
NO_RIVAL = 1.0  # the pose margin when no other pose was voted on


def from_vote(ch: np.ndarray, groups, k: int, weight: float) -> dict:
    """
    Evidence the vote gives, ch: (hypotheses, candidates) chamfers, k: the chosen hypothesis.

    pose_margin: how much worse the best other hypothesis scores (vote_scores, relative to the
    chosen one's score); agreement: the share of voting candidates whose own best hypothesis is the
    chosen one; candidate_ratio: the best candidate's fit of the chosen pose over the second best's
    (well under 1 when one candidate is the very object); category_share: the share of candidates
    that vote (of the best-fitting candidate's category).
    """
    voters = voting_candidates(ch, groups)
    scores = vote_scores(ch, voters, weight)
    others = np.delete(scores, k)
    margin = float((others.min() - scores[k]) / max(scores[k], 1e-12)) if len(others) else NO_RIVAL
    agreement = float(np.mean(np.argmin(ch[:, voters], axis=0) == k))
    fits = np.sort(ch[k])
    ratio = float(fits[0] / max(fits[1], 1e-12)) if len(fits) > 1 else 1.0
    return {
        'pose_margin': margin,
        'agreement': agreement,
        'candidate_ratio': ratio,
        'category_share': float(voters.mean()),
    }


def alone() -> dict:
    """Return the same when there was no vote (one candidate, or the vote switched off)."""
    return {
        'pose_margin': NO_RIVAL,
        'agreement': 1.0,
        'candidate_ratio': 1.0,
        'category_share': 1.0,
    }


def features(vote_evidence: dict, hyp, averaged: int, distance: float, whole: bool) -> dict:
    """
    Return the named FEATURES of one answer.

    hyp its final hypothesis, averaged how many candidates' poses it averages, distance the
    retrieval distance of the first candidate.
    """
    return {
        **vote_evidence,
        'fitness': float(hyp.fitness),
        'chamfer': float(hyp.chamfer),
        'averaged': float(averaged),
        'retrieval_distance': float(distance),
        'whole': float(whole),
    }
