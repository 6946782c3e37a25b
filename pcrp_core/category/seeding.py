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
The hypotheses one retrieved candidate contributes, coarsely refined on it.

The paper's RANSAC on feature matches (where the candidate has features), the directions a sensor
could have stood in (the first view_seeders candidates, for one-sided views), principal axes, then
the half turns of the best of those, and, when which way is up is known but nothing is upright, the
query stood up and turned about the vertical. The generators are in pcrp_core/hypotheses.py.
"""

from __future__ import annotations

from pcrp_core import hypotheses
from pcrp_core.category.fitting import Fitter
from pcrp_core.category.hypothesis import Hypothesis
from pcrp_core.category.prepared import Prepared
from pcrp_core.category.upright import UpPrior


def seeds(
    fitter: Fitter, gallery: Prepared, rank: int, up: UpPrior, rng, clock
) -> list[Hypothesis]:
    """Coarsely refined hypotheses for one gallery object; rank: its place among the candidates."""
    clock.lap('hypotheses')
    opts, query, viewpoint = fitter.opts, fitter.query, fitter.viewpoint
    upright = up.upright if up.known else None
    iterations = opts.coarse_icp_iterations
    found = (
        hypotheses.ransac_seeds(query, gallery, opts, rng, clock)
        if gallery.features is not None
        else []
    )
    if viewpoint is not None and rank < opts.view_seeders:
        found += hypotheses.view_seeds(
            query.points,
            viewpoint,
            gallery.points,
            gallery.tree,
            fitter.coarse_src,
            fitter.coarse_tree,
            opts.view_directions,
            opts.view_rolls,
            opts.view_keep,
            opts.view_prefilter,
            upright,
        )
    if opts.pca_hypotheses or not found:
        found += hypotheses.pca_seeds(
            query.points,
            gallery.points,
            fitter.coarse_src,
            gallery.tree,
            opts.pca_seeds,
            opts.pca_prefilter,
            upright,
        )
    Rs, ts, sources = zip(*found)
    hyps = fitter.refine_many(Rs, ts, gallery, iterations, sources, 'seed')
    if opts.flips:
        best = min(up.keep(hyps), key=lambda h: h.chamfer)
        Rs, ts = zip(*hypotheses.flips(best.R, best.t, gallery.points.mean(0)))
        hyps += fitter.refine_many(
            Rs, ts, gallery, iterations, [best.source + '+flip'] * len(Rs), 'seed'
        )
    if up.known and not up.upright([h.R for h in hyps]).any():
        # nothing upright from features or principal axes (a one-sided view's axes need not be
        # the object's): stand the query up and try it turned every way about the vertical
        Rs = hypotheses.upright_turns(*up.up, opts.upright_turns)
        ts = gallery.points.mean(0) - Rs @ query.points.mean(0)
        hyps += fitter.refine_many(Rs, ts, gallery, iterations, ['upright'] * len(Rs), 'seed')
    clock.lap('hypotheses')
    return up.keep(hyps)
