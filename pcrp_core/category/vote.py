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
The candidates' vote.

Every hypothesis refined briefly on every retrieved candidate, and the rotation that sits best on
all of them together chosen.

Because the gallery is pre-aligned, all candidates share one canonical frame, so a right
rotation fits every candidate of the category, while a flip that happens to suit one instance
is outvoted by the others.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.category.fitting import Fitter
from pcrp_core.category.hypothesis import Hypothesis
from pcrp_core.category.prepared import Prepared


def vote_scores(ch: np.ndarray, voters: np.ndarray, weight: float) -> np.ndarray:
    """
    Return (hypotheses,) the vote's score of each hypothesis, lower is better.

    ch: (hypotheses, candidates) chamfers.

    The best fit decides when one candidate is the very object; the median over the voting
    candidates decides between near-symmetric flips that one instance happens to suit. Both as
    ratios: each candidate judges a hypothesis by how much worse it fits than its own best one,
    so relatives that differ from the query in size or proportions, whose chamfers are larger
    whatever the pose, weigh no more than close ones (measured on held-out sofas: 23 -> 17 half
    turns in 300 queries, other categories even).
    """
    own_best = np.maximum(ch[:, voters].min(axis=0), 1e-12)
    return ch.min(axis=1) / own_best.min() + weight * np.median(ch[:, voters] / own_best, axis=1)


def choose(ch: np.ndarray, voters: np.ndarray, weight: float, among=None) -> int:
    """
    Return the index of the hypothesis the candidates choose, by vote_scores.

    among: the indices of the hypotheses that may be chosen (all when None); every row of ch still
    counts in each candidate's own best.
    """
    scores = vote_scores(ch, voters, weight)
    among = np.arange(len(scores)) if among is None else np.asarray(among)
    return int(among[np.argmin(scores[among])])


def voting_candidates(ch: np.ndarray, groups) -> np.ndarray:
    """
    (candidates,) which candidates vote.

    With their categories known, only those of the best-fitting candidate's category (a chair has
    no say on which way an airplane faces).
    """
    if groups is None:
        return np.ones(ch.shape[1], bool)
    return np.asarray(groups) == groups[int(np.argmin(ch.min(axis=0)))]


def vote(
    fitter: Fitter,
    pool: list[Hypothesis],
    verifiers: list[Prepared],
    iterations: int,
    groups,
    exact_ratio: float,
    survivors: int = 0,
    first_iterations: int = 0,
) -> tuple[int, list[list[Hypothesis]], np.ndarray]:
    """
    Run the vote.

    Return (index into pool of the chosen hypothesis, each candidate's refined hypotheses, their
    (hypotheses, candidates) chamfers).

    survivors > 0 (fewer than the pool): a first round refines every hypothesis on every candidate
    by first_iterations on the seed points and ranks them by vote_scores; only the best survivors
    (and the best fit on any one candidate) are refined in full and may be chosen. The others keep
    their first-round fits, which still count in each candidate's own best (vote_scores) and are
    what evidence.from_vote sees of them: most of the vote's cost was the full ICP of hypotheses
    the first round already rules out.
    """
    opts = fitter.opts
    Rs, ts = [h.R for h in pool], [h.t for h in pool]
    keep = np.arange(len(pool))
    if 0 < survivors < len(pool):
        votes = [
            fitter.refine_many(Rs, ts, g, first_iterations, [''] * len(pool), 'seed')
            for g in verifiers
        ]
        first = _chamfers(votes)
        scores = vote_scores(first, voting_candidates(first, groups), opts.consensus_weight)
        # and the one that fits some candidate best: the very object's pose, when the gallery
        # holds it, which the exact-fit rule below must still be able to choose
        keep = np.union1d(
            np.argsort(scores, kind='stable')[:survivors], np.argmin(first.min(axis=1))
        )
    else:
        votes = [[None] * len(pool) for _ in verifiers]
    for row, g in zip(votes, verifiers):
        refined = fitter.refine_many(
            [Rs[k] for k in keep], [ts[k] for k in keep], g, iterations, [''] * len(keep)
        )
        for k, h in zip(keep, refined):
            row[k] = h
    ch = _chamfers(votes)
    # the candidates' vote decides, among the survivors...
    k = choose(ch, voting_candidates(ch, groups), opts.consensus_weight, keep)
    # ...unless one candidate explains the cloud far better than every other: then it is the
    # very object (a gallery of known objects), and relatives turned otherwise must not outvote
    # it. Stricter for clouds from a sensor: a partial cloud fits some wrong pose of one
    # candidate closely often enough that only a wide margin, or else the consensus, decides.
    per_candidate = np.sort(ch.min(axis=0))
    if len(per_candidate) > 1 and per_candidate[0] < exact_ratio * per_candidate[1]:
        k = int(keep[np.argmin(ch[keep].min(axis=1))])
    return k, votes, ch


def _chamfers(votes: list[list[Hypothesis]]) -> np.ndarray:
    """(hypotheses, candidates) chamfers of each candidate's row of refined hypotheses."""
    return np.array([[h.chamfer for h in row] for row in votes]).T
