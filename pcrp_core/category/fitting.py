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
Refining a pose on one gallery object and scoring how well it sits there.

The one operation every stage of registration (hypotheses, the vote, the final refinement) repeats.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.category.hypothesis import Hypothesis
from pcrp_core.category.prepared import Prepared
from pcrp_core.config import PoseOptions
from pcrp_core.registration import fit_quality_batch, icp_batch
from pcrp_core.registration.icp import transform_batch
from pcrp_core.registration.nearest import NearestPoints
from pcrp_core.registration.scoring import distances_back
from pcrp_core.visibility import visible_from


class Fitter:
    """
    Holds the query's subsample used for ICP and scoring, so it is drawn once per query.

    The score (Hypothesis.chamfer, lower is better) is the trimmed distance from the posed query to
    the gallery object plus, for a whole cloud, the gallery's points far from the query (what is
    missing is evidence) or, for a one-sided view, the gallery's points the sensor would see under
    the pose but the query lacks.
    """

    def __init__(
        self,
        query: Prepared,
        opts: PoseOptions,
        rng: np.random.Generator,
        viewpoint=None,
        seed_points: int | None = None,
    ):
        """
        Draw the query's subsamples.

        seed_points: how many of them each candidate first ranks its hypotheses on (coarse_points
        when None; registrar.Effort chooses it for whole clouds and views).
        """
        self.query, self.opts, self.viewpoint = query, opts, viewpoint
        self.trim = opts.icp_trim if viewpoint is None else opts.icp_trim_view
        src = query.sampled if query.sampled is not None else query.points
        if len(src) > opts.icp_points:
            src = src[rng.choice(len(src), opts.icp_points, replace=False)]
        # hypotheses are told apart on fewer points than the final refinement uses, and a whole
        # cloud's are first ranked on fewer still: the vote judges the best of them again
        self.src = src
        self.coarse_src = src if len(src) <= opts.coarse_points else src[: opts.coarse_points]
        n_seed = opts.coarse_points if seed_points is None else seed_points
        coarse = self.coarse_src
        self.seed_src = coarse if len(coarse) <= n_seed else coarse[:n_seed]
        # the gallery's points are taken back into the query's frame to be matched
        # (scoring.distances_back)
        self.tree = NearestPoints(src)
        self.coarse_tree = self.tree if coarse is src else NearestPoints(coarse)
        self.seed_tree = (
            self.coarse_tree if self.seed_src is coarse else NearestPoints(self.seed_src)
        )
        # the query points and their tree each refine_many(on=...) works with
        self._on = {
            'seed': (self.seed_src, self.seed_tree),
            'coarse': (coarse, self.coarse_tree),
            'full': (src, self.tree),
        }

    def refine(
        self, R, t, gallery: Prepared, iterations: int, source: str, on: str = 'coarse'
    ) -> Hypothesis:
        return self.refine_many([R], [t], gallery, iterations, [source], on)[0]

    def refine_many(
        self, Rs, ts, gallery: Prepared, iterations: int, sources, on: str = 'coarse', prev=None
    ) -> list[Hypothesis]:
        """
        refine() of several poses on one gallery object, sharing its tree queries.

        on: the query points used, 'seed', 'coarse' or 'full' (see __init__). prev resumes ICP runs
        that stopped at those poses (see icp_batch).
        """
        opts = self.opts
        src, tree = self._on[on]
        Rs, ts = np.asarray(Rs, dtype=np.float64), np.asarray(ts, dtype=np.float64)
        prev, moving = (np.full(len(Rs), np.inf) if prev is None else prev), np.ones(len(Rs), bool)
        if opts.refine and iterations > 0:
            Rs, ts, prev, moving = icp_batch(
                src,
                gallery.points,
                gallery.tree,
                Rs,
                ts,
                iterations,
                self.trim,
                opts.icp_tolerance,
                prev,
                state=True,
            )
        moved = transform_batch(src, Rs, ts)
        fit, rmse, ch = fit_quality_batch(moved, gallery.tree, opts.inlier_distance)
        if self.viewpoint is not None and opts.visibility_weight > 0:
            ch += opts.visibility_weight * np.array(
                [self._unexplained(tree, R, t, gallery) for R, t in zip(Rs, ts)]
            )
        elif opts.reverse_weight > 0 and len(Rs):
            # the gallery object's points near the query too: absent parts count against a pose
            back = distances_back(
                tree, gallery.points[:: max(1, len(gallery.points) // len(src))], Rs, ts
            )
            k = max(1, int(opts.reverse_trim * back.shape[1]))
            ch += opts.reverse_weight * np.partition(back, k - 1, axis=1)[:, :k].mean(axis=1)
        return [
            Hypothesis(
                Rs[n],
                ts[n],
                float(fit[n]),
                float(rmse[n]),
                float(ch[n]),
                source,
                float(prev[n]),
                bool(moving[n]),
            )
            for n, source in enumerate(sources)
        ]

    def _unexplained(self, tree: NearestPoints, R, t, gallery: Prepared) -> float:
        """
        Return the trimmed mean distance from the gallery points the sensor would see to the query.

        Seen under this pose. A one-sided view only says what is there, not what is missing; seen
        from the sensor, the posed gallery object must show what the query shows, which is what
        tells a sofa seen from the front from one seen from behind.
        """
        g = gallery.points[:: max(1, len(gallery.points) // 256)]
        vis = g[visible_from(g, R @ self.viewpoint + t)]
        if len(vis) == 0:
            return 1.0
        d = distances_back(tree, vis, [R], [t])[0]
        k = max(1, int(0.8 * len(d)))
        return float(np.mean(np.partition(d, k - 1)[:k]))
