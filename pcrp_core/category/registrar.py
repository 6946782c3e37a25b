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
Pose of a query relative to the retrieved gallery objects: hypotheses, the vote, refinement.

Hypotheses (seeding.py) come from each of the first retrieved candidates; the best few distinct
rotations go to the vote (vote.py), in which every retrieved candidate judges them; the chosen one
is refined in full and averaged over the candidates that agree (refinement.py). When the caller
knows which way is up, hypotheses that tip the gallery's up axis away from it are dropped before
any of this (upright.py). All of it happens in normalised coordinates, query registered onto
gallery: g ≈ R @ q + t.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.category import evidence, refinement
from pcrp_core.category.fitting import Fitter
from pcrp_core.category.hypothesis import distinct, Hypothesis
from pcrp_core.category.prepared import Prepared
from pcrp_core.category.seeding import seeds
from pcrp_core.category.upright import UpPrior
from pcrp_core.category.vote import vote
from pcrp_core.config import PoseOptions
from pcrp_core.timing import Clock

SEEDS_PER_CANDIDATE = 2  # distinct rotations each seeding candidate hands to the pool


class Effort:
    """
    How much work a cloud gets at each stage.

    whole clouds and one-sided views have settings of their own (a view's hypotheses are more often
    wrong, so it gets more of them; a whole cloud's principal axes and half turns find most poses,
    so it ranks its hypotheses on fewer points, seeds from a candidate's features only when
    retrieval found a near twin, and refines in full only the hypotheses a first round of the vote
    keeps).
    """

    def __init__(self, opts: PoseOptions, whole: bool):
        self.whole_matched = opts.whole_matched if whole else None
        self.twin_ratio = opts.whole_matched_ratio
        self.seed_points = opts.seed_points if whole else opts.coarse_points
        self.seeders = opts.seeders if whole else opts.seeders_view
        self.pool_size = opts.pool_size if whole else opts.pool_size_view
        self.vote_iterations = opts.vote_icp_iterations if whole else opts.vote_icp_iterations_view
        # (survivors, first-round iterations) of the vote: measured on whole clouds only
        self.vote_rounds = (opts.vote_survivors, opts.vote_first_iterations) if whole else (0, 0)
        self.final_ratio = opts.final_ratio if whole else opts.final_ratio_view
        self.exact_ratio = opts.exact_ratio if whole else opts.exact_ratio_view

    def matched(self, n_matched: int, distances) -> int:
        """
        Return how many of the first candidates get point features, of n_matched asked.

        distances: the retrieved candidates' descriptor distances, nearest first.
        """
        if self.whole_matched is None:
            return n_matched
        # a gallery object's point features cost as much as the query's: worth it for a whole
        # cloud only when retrieval found a near twin (config.whole_matched_ratio)
        twin = len(distances) < 2 or distances[0] <= self.twin_ratio * distances[1]
        return min(n_matched, self.whole_matched) if twin else 0


class Registrar:
    """Registers one query (a Prepared cloud in normalised units) to retrieved gallery objects."""

    def __init__(
        self,
        query: Prepared,
        opts: PoseOptions,
        rng: np.random.Generator,
        viewpoint=None,
        timings: dict | None = None,
        up=None,
    ):
        """
        Set up the stages of registration.

        timings, when given, gets seconds added per stage: correspondences, ransac, hypotheses
        (principal axes, flips, their coarse ICP), verification (the vote) and refinement (final
        ICP, averaging, the mirror-plane finish). up: (the up direction in the query's frame, the
        gallery's up axis), unit vectors, when the caller knows which way is up.
        """
        self.query, self.opts, self.rng = query, opts, rng
        self.clock = Clock(timings)
        self.viewpoint = viewpoint
        self.up = UpPrior(up, opts.up_tolerance_deg)
        self.effort = Effort(opts, viewpoint is None)
        self.fitter = Fitter(query, opts, rng, viewpoint, self.effort.seed_points)
        # what the last best_pose saw that says how far to trust its answer (evidence.py)
        self.evidence = evidence.alone()
        self.averaged = 1

    def upright(self, Rs) -> np.ndarray:
        return self.up.upright(Rs)

    def seeds(self, gallery: Prepared, rank: int = 0) -> list[Hypothesis]:
        """Coarsely refined hypotheses for one gallery object (seeding.seeds)."""
        return seeds(self.fitter, gallery, rank, self.up, self.rng, self.clock)

    def pool(self, matched: list[Prepared], verifiers: list[Prepared]) -> list[Hypothesis]:
        """Return the distinct hypotheses that go to the vote, best first."""
        n_seed = (
            len(verifiers) if self.effort.seeders <= 0 else max(len(matched), self.effort.seeders)
        )
        pool = []
        for rank, g in enumerate(verifiers[:n_seed]):
            pool += distinct(
                sorted(self.seeds(g, rank), key=lambda h: h.chamfer), SEEDS_PER_CANDIDATE
            )
        # a seeder with no upright hypothesis hands back all of its own: drop those if others
        # have some
        pool = self.up.keep(pool)
        # the best few distinct rotations go to the vote; the rest only cost time
        return distinct(sorted(pool, key=lambda h: h.chamfer), self.effort.pool_size)

    def best_pose(
        self, matched: list[Prepared], verifiers: list[Prepared], groups=None
    ) -> tuple[int, Hypothesis]:
        """
        (index into verifiers of the best-fitting object, its refined hypothesis).

        matched: the first retrieved objects, with features, that seed hypotheses; verifiers: all
        top retrieved objects (matched first) that vote on them; groups: each verifier's category,
        when known: only those of the best-fitting object's category vote (a chair has no say on
        which way an airplane faces).
        """
        opts, fitter, effort = self.opts, self.fitter, self.effort
        self.clock.lap('gallery_features')  # what the caller spent preparing the candidates
        pool = self.pool(matched, verifiers)
        if not opts.consensus or len(verifiers) == 1:
            best = min(pool, key=lambda h: h.chamfer)
            final = fitter.refine(
                best.R, best.t, verifiers[0], opts.icp_iterations, best.source, on='full'
            )
            final = refinement.finish(fitter, final, verifiers[0])
            self.clock.lap('refinement')
            self.evidence, self.averaged = evidence.alone(final.chamfer), 1
            return 0, final
        k, votes, ch = vote(
            fitter,
            pool,
            verifiers,
            effort.vote_iterations,
            groups,
            effort.exact_ratio,
            *effort.vote_rounds,
        )
        self.evidence = evidence.from_vote(ch, groups, k, opts.consensus_weight)
        best = pool[k]
        self.clock.lap('verification')
        return self._refined(best, k, votes, verifiers)

    def _refined(self, best: Hypothesis, k: int, votes, verifiers) -> tuple[int, Hypothesis]:
        opts, fitter = self.opts, self.fitter
        chosen = refinement.finalists(
            np.array([row[k].chamfer for row in votes]), self.effort.final_ratio
        )
        refined = [
            refinement.resume(fitter, best, verifiers[n], votes[n][k], self.effort.vote_iterations)
            for n in chosen
        ]
        jj = int(np.argmin([h.chamfer for h in refined]))
        near = refinement.agreeing(refined, refined[jj], opts.average_within)
        if self.viewpoint is None and opts.refine and opts.symmetric_iterations > 0:
            poses = [refinement.both_ways(fitter, refined[n], verifiers[chosen[n]]) for n in near]
        else:
            poses = [(refined[n].R, refined[n].t) for n in near]
        # only the poses are averaged; the result is scored once, on the best candidate
        j = int(chosen[jj])
        self.averaged = len(poses)
        final = refinement.finish(fitter, refinement.average(poses, refined[jj]), verifiers[j])
        self.clock.lap('refinement')
        return j, final
