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
The final pose.

The chosen hypothesis refined in full on the candidates that fit it nearly as well as the best,
their poses averaged, and for a whole cloud its mirror plane laid on the chosen object's.

Each pre-aligned candidate gives its own estimate of the query's canonical pose, off by how that
instance differs from the query; averaging the candidates that agree cancels much of that. For
whole clouds each is first refined once more with matches taken both ways, so that it sits
centred on the candidate rather than wherever the query's points happen to touch its surface.
"""

from __future__ import annotations

import numpy as np
from pcrp_core.category.fitting import Fitter
from pcrp_core.category.hypothesis import Hypothesis, rotation_cosine
from pcrp_core.category.prepared import Prepared
from pcrp_core.registration import icp_symmetric
from pcrp_core.registration.mirror import gallery_mirror, mirror_plane, snap, trimmed_rms

AGREE_DEG = 15.0  # candidates' poses within this of the best one's are averaged with it


def finalists(vote_chamfers: np.ndarray, ratio: float) -> np.ndarray:
    """
    Return indices of the candidates whose fit in the vote is within ratio of the best.

    Only they go on to the full refinement (measured: the others do not end near the best).
    """
    return np.flatnonzero(vote_chamfers <= ratio * vote_chamfers.min())


def resume(
    fitter: Fitter, hyp: Hypothesis, gallery: Prepared, vote: Hypothesis, vote_iterations: int
) -> Hypothesis:
    """
    Return hyp fully refined on gallery.

    The vote already ran the first ICP iterations of that very run when it used the same points, so
    the run resumes where the vote stopped.
    """
    opts = fitter.opts
    same_points = fitter.coarse_src is fitter.src
    if opts.refine and same_points and 0 < vote_iterations <= opts.icp_iterations:
        if not vote.icp_moving:
            return vote.renamed(hyp.source)
        return fitter.refine_many(
            [vote.R],
            [vote.t],
            gallery,
            opts.icp_iterations - vote_iterations,
            [hyp.source],
            on='full',
            prev=[vote.icp_prev],
        )[0]
    return fitter.refine(hyp.R, hyp.t, gallery, opts.icp_iterations, hyp.source, on='full')


def both_ways(fitter: Fitter, hyp: Hypothesis, gallery: Prepared) -> tuple[np.ndarray, np.ndarray]:
    """
    (R, t) of hyp refined further by icp_symmetric, for a whole cloud.

    a one-sided view lacks the far side that the gallery-to-query matches would look for.
    """
    opts = fitter.opts
    return icp_symmetric(
        fitter.src,
        gallery.points,
        gallery.tree,
        hyp.R,
        hyp.t,
        opts.symmetric_iterations,
        opts.icp_trim,
        reverse_trim=opts.symmetric_reverse_trim,
        dense_src=fitter.query.points,
        dense_tree=fitter.query.tree,
    )


def agreeing(hyps: list[Hypothesis], anchor: Hypothesis, within: float) -> list[int]:
    """
    Return indices of the candidates whose pose agrees with the best one's.

    Only those that also fit nearly as well.
    """
    cos_max = np.cos(np.radians(AGREE_DEG))
    return [
        n
        for n, h in enumerate(hyps)
        if rotation_cosine(h.R, anchor.R) > cos_max and h.chamfer <= within * anchor.chamfer
    ]


def average(poses: list[tuple[np.ndarray, np.ndarray]], anchor: Hypothesis) -> Hypothesis:
    """
    Return the (R, t) poses of candidates that agree (see agreeing) averaged.

    With the anchor's scores.

    Equal weights: fit differences between instances that all sit well say little about whose
    frame is truer, and an exact gallery match stands alone anyway, since no relative fits
    within a factor of it.
    """
    U, _, Vt = np.linalg.svd(sum(R for R, _ in poses))
    R = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt
    t = np.mean([t for _, t in poses], axis=0)
    return Hypothesis(
        R, t, anchor.fitness, anchor.rmse, anchor.chamfer, anchor.source + f'+avg{len(poses)}'
    )


def finish(fitter: Fitter, hyp: Hypothesis, gallery: Prepared) -> Hypothesis:
    """
    Return hyp with its mirror plane laid on the gallery object's, scored on gallery.

    Laid where that applies (see PoseOptions.mirror_snap).
    """
    R, t, source = hyp.R, hyp.t, hyp.source
    opts, q = fitter.opts, fitter.query
    target = None
    if fitter.viewpoint is None and opts.refine and opts.mirror_snap:
        # (a one-sided view has no mirror image of itself to find)
        target = gallery.memo(
            ('mirror', opts.mirror_tolerance, opts.mirror_max_deg),
            lambda: gallery_mirror(
                gallery.points, gallery.tree, opts.mirror_tolerance, opts.mirror_max_deg
            ),
        )
    if target is not None:
        plane = mirror_plane(q.points, q.tree, R.T @ target.normal)
        tilt = np.degrees(np.arccos(np.clip((R @ plane.normal) @ target.normal, -1.0, 1.0)))
        # whichever fits the query more tightly places it more precisely: its own mirror image
        # or the gallery object. The very object (a known one) fits far better than any mirror
        # image (measured, noisy known objects: at most 0.73 of the mirror image's rms); other
        # instances of a category mostly fit worse (1.0-3.7 times).
        fit = trimmed_rms(gallery.tree.query(q.points @ R.T + t)[0])
        is_mirror = plane.residual < opts.mirror_tolerance and tilt <= opts.mirror_max_deg
        if is_mirror and plane.rms < fit:
            R, t = snap(R, t, plane, target, q.points.mean(axis=0))
            source += '+mirror'
    return fitter.refine(R, t, gallery, 0, source, on='full')
