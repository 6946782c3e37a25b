"""Pose of a query relative to the retrieved gallery objects: hypotheses, refinement, verification.

Hypotheses (hypotheses.py) come from the paper's method (feature matches within symmetry
halves, Procrustes in RANSAC) on the first retrieved objects and, beyond it, from principal
axes, from the half turns about the canonical axes of each hypothesis (the turns that
near-symmetric objects, a car's front and back, are confused by) and, for clouds from a
sensor, from the directions the object could have been seen from.

Verification goes past the paper: every surviving hypothesis is refined by ICP against each
of the top retrieved objects, and the rotation that sits best on all of them together wins.
Because the gallery is pre-aligned, all candidates share one canonical frame, so a right
rotation fits every candidate of the category, while a flip that happens to suit one
instance is outvoted by the others. The final pose averages the candidates that agree and
fit nearly as well as the best, each refined once more (for whole clouds) with matches taken
both ways, so that it sits centred on the candidate rather than wherever the query's points
happen to touch its surface; where both are mirror-symmetric, the query's mirror plane is then
laid on the chosen object's (registration/mirror.py). When the caller knows which way is up,
hypotheses that tip the gallery's up axis away from it are dropped before any of this
(Registrar.upright): the turns that near-symmetric shapes are most confused by are upside-down
and lying-down ones. All of it happens in normalised coordinates, query registered onto gallery:
g ≈ R @ q + t.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.spatial import cKDTree

from pcrp_core import hypotheses
from pcrp_core.config import PoseOptions
from pcrp_core.registration import fit_quality_batch, icp_batch, icp_symmetric
from pcrp_core.registration.icp import transform_batch
from pcrp_core.registration.mirror import gallery_mirror, mirror_plane, snap, trimmed_rms
from pcrp_core.registration.scoring import distances_back
from pcrp_core.symmetry import split_halves
from pcrp_core.timing import Clock
from pcrp_core.visibility import visible_from

@dataclass
class Prepared:
    """One cloud ready to register: all points and their tree; for feature matching also the
    sampled points, their features and their symmetry halves (None where not computed)."""
    points: np.ndarray
    tree: cKDTree
    sampled: np.ndarray | None = None
    features: np.ndarray | None = None
    halves: np.ndarray | None = None
    # what is worked out about a gallery object once and kept as long as it stays in the cache
    _memo: dict = field(default_factory=dict, repr=False)

    def memo(self, key, compute):
        """compute(), worked out on first use for this key and remembered."""
        if key not in self._memo:
            self._memo[key] = compute()
        return self._memo[key]


def prepare(points: np.ndarray, sampled_idx=None, features=None) -> Prepared:
    if sampled_idx is None:
        return Prepared(points, cKDTree(points))
    sampled = points[sampled_idx]
    return Prepared(points, cKDTree(points), sampled, features, split_halves(sampled))


@dataclass
class Hypothesis:
    R: np.ndarray
    t: np.ndarray
    fitness: float
    rmse: float
    chamfer: float
    source: str
    # where ICP stopped: its last mean squared error and whether it was still improving
    icp_prev: float = np.inf
    icp_moving: bool = True


class Registrar:
    """Holds the query's subsample used for ICP and scoring, so it is drawn once per query."""

    def __init__(self, query: Prepared, opts: PoseOptions, rng: np.random.Generator, viewpoint=None,
                 timings: dict | None = None, up=None):
        """timings, when given, gets seconds added per stage: correspondences, ransac,
        hypotheses (principal axes, flips, their coarse ICP), verification (the vote) and
        refinement (final ICP, averaging, the mirror-plane finish). up: (the up direction in the
        query's frame, the gallery's up axis), unit vectors, when the caller knows which way is up."""
        self.query, self.opts, self.rng = query, opts, rng
        self.clock = Clock(timings)
        self.viewpoint = viewpoint
        self.up = None if up is None else tuple(np.asarray(u, dtype=np.float64) for u in up)
        # whole clouds and one-sided views have settings of their own for the work spent on them
        whole = viewpoint is None
        self.seeders = opts.seeders if whole else opts.seeders_view
        self.pool_size = opts.pool_size if whole else opts.pool_size_view
        self.vote_iterations = opts.vote_icp_iterations if whole else opts.vote_icp_iterations_view
        self.final_ratio = opts.final_ratio if whole else opts.final_ratio_view
        src = query.sampled if query.sampled is not None else query.points
        if len(src) > opts.icp_points:
            src = src[rng.choice(len(src), opts.icp_points, replace=False)]
        self.src = src
        # hypotheses are told apart on fewer points than the final refinement uses
        self.coarse_src = src if len(src) <= opts.coarse_points else src[: opts.coarse_points]
        # the gallery's points are taken back into the query's frame to be matched (scoring.distances_back)
        self.tree = cKDTree(src)
        self.coarse_tree = self.tree if self.coarse_src is src else cKDTree(self.coarse_src)

    def refine(self, R, t, gallery: Prepared, iterations: int, source: str, coarse: bool = True) -> Hypothesis:
        return self.refine_many([R], [t], gallery, iterations, [source], coarse)[0]

    def refine_many(self, Rs, ts, gallery: Prepared, iterations: int, sources, coarse: bool = True,
                    prev=None) -> list[Hypothesis]:
        """refine() of several poses on one gallery object, sharing its tree queries; prev
        resumes ICP runs that stopped at those poses (see icp_batch)."""
        src, tree = (self.coarse_src, self.coarse_tree) if coarse else (self.src, self.tree)
        Rs, ts = np.asarray(Rs, dtype=np.float64), np.asarray(ts, dtype=np.float64)
        prev, moving = (np.full(len(Rs), np.inf) if prev is None else prev), np.ones(len(Rs), bool)
        if self.opts.refine and iterations > 0:
            Rs, ts, prev, moving = icp_batch(src, gallery.points, gallery.tree, Rs, ts, iterations,
                                             self.opts.icp_trim, self.opts.icp_tolerance, prev, state=True)
        moved = transform_batch(src, Rs, ts)
        fit, rmse, ch = fit_quality_batch(moved, gallery.tree, self.opts.inlier_distance)
        if self.viewpoint is not None and self.opts.visibility_weight > 0:
            ch += self.opts.visibility_weight * np.array([self._unexplained(tree, R, t, gallery) for R, t in zip(Rs, ts)])
        elif self.opts.reverse_weight > 0 and len(Rs):
            # the gallery object's points near the query too: absent parts count against a pose
            back = distances_back(tree, gallery.points[:: max(1, len(gallery.points) // len(src))], Rs, ts)
            k = max(1, int(self.opts.reverse_trim * back.shape[1]))
            ch += self.opts.reverse_weight * np.partition(back, k - 1, axis=1)[:, :k].mean(axis=1)
        return [Hypothesis(Rs[n], ts[n], float(fit[n]), float(rmse[n]), float(ch[n]), source, float(prev[n]),
                           bool(moving[n])) for n, source in enumerate(sources)]

    def _unexplained(self, tree: cKDTree, R, t, gallery: Prepared) -> float:
        """Trimmed mean distance from the gallery points the sensor would see under this pose
        to the query. A one-sided view only says what is there, not what is missing; seen
        from the sensor, the posed gallery object must show what the query shows, which is
        what tells a sofa seen from the front from one seen from behind."""
        g = gallery.points[:: max(1, len(gallery.points) // 256)]
        vis = g[visible_from(g, R @ self.viewpoint + t)]
        if len(vis) == 0:
            return 1.0
        d = distances_back(tree, vis, [R], [t])[0]
        k = max(1, int(0.8 * len(d)))
        return float(np.mean(np.partition(d, k - 1)[:k]))

    def upright(self, Rs) -> np.ndarray:
        """(H,) whether each query-to-gallery rotation keeps the gallery's up axis within
        up_tolerance_deg of the known up direction (all true when up is unknown)."""
        Rs = np.asarray(Rs).reshape(-1, 3, 3)
        if self.up is None:
            return np.ones(len(Rs), bool)
        q_up, g_up = self.up
        return (Rs @ q_up) @ g_up >= np.cos(np.radians(self.opts.up_tolerance_deg)) - 1e-9

    def _keep_upright(self, hyps: list[Hypothesis]) -> list[Hypothesis]:
        """The upright hypotheses; all of them when none is (a prior nothing satisfies, say a
        wrong up parameter, is ignored rather than answered with nothing)."""
        ok = self.upright([h.R for h in hyps]) if hyps else np.zeros(0, bool)
        return [h for h, k in zip(hyps, ok) if k] or hyps

    def seeds(self, gallery: Prepared, rank: int = 0):
        """Coarsely refined hypotheses for one gallery object; rank is its place among the
        candidates (the first view_seeders of them also get view hypotheses, for sensor clouds)."""
        self.clock.lap("hypotheses")
        opts, upright = self.opts, None if self.up is None else self.upright
        seeds = hypotheses.ransac_seeds(self.query, gallery, opts, self.rng, self.clock) if gallery.features is not None else []
        if self.viewpoint is not None and rank < opts.view_seeders:
            seeds += hypotheses.view_seeds(self.query.points, self.viewpoint, gallery.points, gallery.tree,
                                           self.coarse_src, self.coarse_tree, opts.view_directions, opts.view_rolls,
                                           opts.view_keep, opts.view_prefilter, upright)
        if opts.pca_hypotheses or not seeds:
            seeds += hypotheses.pca_seeds(self.query.points, gallery.points, self.coarse_src, gallery.tree,
                                          opts.pca_seeds, opts.pca_prefilter, upright)
        Rs, ts, sources = zip(*seeds)
        hyps = self.refine_many(Rs, ts, gallery, self.opts.coarse_icp_iterations, sources)
        if self.opts.flips:
            best = min(self._keep_upright(hyps), key=lambda h: h.chamfer)
            Rs, ts = zip(*hypotheses.flips(best.R, best.t, gallery.points.mean(0)))
            hyps += self.refine_many(Rs, ts, gallery, self.opts.coarse_icp_iterations, [best.source + "+flip"] * len(Rs))
        if self.up is not None and not self.upright([h.R for h in hyps]).any():
            # nothing upright from features or principal axes (a one-sided view's axes need not be
            # the object's): stand the query up and try it turned every way about the vertical
            Rs = hypotheses.upright_turns(*self.up, self.opts.upright_turns)
            ts = gallery.points.mean(0) - Rs @ self.query.points.mean(0)
            hyps += self.refine_many(Rs, ts, gallery, self.opts.coarse_icp_iterations, ["upright"] * len(Rs))
        self.clock.lap("hypotheses")
        return self._keep_upright(hyps)

    def _final(self, hyp: Hypothesis, gallery: Prepared, vote: Hypothesis) -> Hypothesis:
        """hyp fully refined on gallery. The vote already ran the first ICP iterations of that
        very run when it used the same points, so the run resumes where the vote stopped."""
        opts = self.opts
        if opts.refine and self.coarse_src is self.src and 0 < self.vote_iterations <= opts.icp_iterations:
            if not vote.icp_moving:
                return _resumed(vote, hyp.source)
            return self.refine_many([vote.R], [vote.t], gallery, opts.icp_iterations - self.vote_iterations,
                                    [hyp.source], coarse=False, prev=[vote.icp_prev])[0]
        return self.refine(hyp.R, hyp.t, gallery, opts.icp_iterations, hyp.source, coarse=False)

    def _symmetric(self, hyp: Hypothesis, gallery: Prepared) -> tuple[np.ndarray, np.ndarray]:
        """(R, t) of hyp refined further by icp_symmetric, for a whole cloud: a one-sided view
        lacks the far side that the gallery-to-query matches would look for."""
        return icp_symmetric(self.src, gallery.points, gallery.tree, hyp.R, hyp.t,
                             self.opts.symmetric_iterations, self.opts.icp_trim,
                             reverse_trim=self.opts.symmetric_reverse_trim, dense_src=self.query.points,
                             dense_tree=self.query.tree)

    def best_pose(self, matched: list[Prepared], verifiers: list[Prepared], groups=None) -> tuple[int, Hypothesis]:
        """(index into verifiers of the best-fitting object, its refined hypothesis).

        matched: the first retrieved objects, with features, that seed hypotheses;
        verifiers: all top retrieved objects (matched first) that vote on them;
        groups: each verifier's category, when known: only those of the best-fitting object's
        category vote (a chair has no say on which way an airplane faces).
        """
        self.clock.lap("gallery_features")   # what the caller spent preparing the candidates
        pool = []
        n_seed = len(verifiers) if self.seeders <= 0 else max(len(matched), self.seeders)
        seeders = verifiers[:n_seed]
        for rank, g in enumerate(seeders):
            pool += _distinct(sorted(self.seeds(g, rank), key=lambda h: h.chamfer), 2)
        # a seeder with no upright hypothesis hands back all of its own: drop those if others have some
        pool = self._keep_upright(pool)
        # the best few distinct rotations go to the vote; the rest only cost time
        pool = _distinct(sorted(pool, key=lambda h: h.chamfer), self.pool_size)
        if not self.opts.consensus or len(verifiers) == 1:
            best = min(pool, key=lambda h: h.chamfer)
            final = self.refine(best.R, best.t, verifiers[0], self.opts.icp_iterations, best.source, coarse=False)
            final = self._finish(final, verifiers[0])
            self.clock.lap("refinement")
            return 0, final
        # chamfer of each hypothesis on each candidate, after a short refinement there
        Rs, ts = [h.R for h in pool], [h.t for h in pool]
        votes = [self.refine_many(Rs, ts, g, self.vote_iterations, [""] * len(pool)) for g in verifiers]
        ch = np.array([[h.chamfer for h in row] for row in votes]).T
        voters = np.ones(len(verifiers), bool)
        if groups is not None:
            voters = np.asarray(groups) == groups[int(np.argmin(ch.min(axis=0)))]
        # the candidates' vote decides (_vote)...
        k = _vote(ch, voters, self.opts.consensus_weight)
        # ...unless one candidate explains the cloud far better than every other: then it is the
        # very object (a gallery of known objects), and relatives turned otherwise must not outvote
        # it. Stricter for clouds from a sensor: a partial cloud fits some wrong pose of one
        # candidate closely often enough that only a wide margin, or else the consensus, decides.
        per_candidate = np.sort(ch.min(axis=0))
        exact = self.opts.exact_ratio if self.viewpoint is None else self.opts.exact_ratio_view
        if len(per_candidate) > 1 and per_candidate[0] < exact * per_candidate[1]:
            k = int(np.argmin(ch.min(axis=1)))
        best = pool[k]
        self.clock.lap("verification")
        # only candidates that already sit nearly as well as the best go on to the full refinement
        vote_ch = np.array([row[k].chamfer for row in votes])
        finalists = np.flatnonzero(vote_ch <= self.final_ratio * vote_ch.min())
        refined = [self._final(best, verifiers[n], votes[n][k]) for n in finalists]
        jj = int(np.argmin([h.chamfer for h in refined]))
        j = int(finalists[jj])
        near = _agreeing(refined, refined[jj], self.opts.average_within)
        if self.viewpoint is None and self.opts.refine and self.opts.symmetric_iterations > 0:
            poses = [self._symmetric(refined[n], verifiers[finalists[n]]) for n in near]
        else:
            poses = [(refined[n].R, refined[n].t) for n in near]
        # only the poses are averaged; the result is scored once, on the best candidate
        final = self._finish(_average(poses, refined[jj]), verifiers[j])
        self.clock.lap("refinement")
        return j, final

    def _finish(self, hyp: Hypothesis, gallery: Prepared) -> Hypothesis:
        """hyp with its mirror plane laid on the gallery object's where that applies (see
        PoseOptions.mirror_snap), scored on gallery."""
        R, t, source = hyp.R, hyp.t, hyp.source
        opts, q = self.opts, self.query
        target = None
        if self.viewpoint is None and opts.refine and opts.mirror_snap:
            # (a one-sided view has no mirror image of itself to find)
            target = gallery.memo(("mirror", opts.mirror_tolerance, opts.mirror_max_deg), lambda: gallery_mirror(
                gallery.points, gallery.tree, opts.mirror_tolerance, opts.mirror_max_deg))
        if target is not None:
            plane = mirror_plane(q.points, q.tree, R.T @ target.normal)
            tilt = np.degrees(np.arccos(np.clip((R @ plane.normal) @ target.normal, -1.0, 1.0)))
            # whichever fits the query more tightly places it more precisely: its own mirror image
            # or the gallery object. The very object (a known one) fits far better than any mirror
            # image (measured, noisy known objects: at most 0.73 of the mirror image's rms); other
            # instances of a category mostly fit worse (1.0-3.7 times).
            fit = trimmed_rms(gallery.tree.query(q.points @ R.T + t)[0])
            if plane.residual < opts.mirror_tolerance and tilt <= opts.mirror_max_deg and plane.rms < fit:
                R, t = snap(R, t, plane, target, q.points.mean(axis=0))
                source += "+mirror"
        return self.refine(R, t, gallery, 0, source, coarse=False)


def _vote(ch: np.ndarray, voters: np.ndarray, weight: float) -> int:
    """Index of the hypothesis the candidates choose; ch: (hypotheses, candidates) chamfers.

    The best fit decides when one candidate is the very object; the median over the voting
    candidates decides between near-symmetric flips that one instance happens to suit. Both as
    ratios: each candidate judges a hypothesis by how much worse it fits than its own best one,
    so relatives that differ from the query in size or proportions, whose chamfers are larger
    whatever the pose, weigh no more than close ones (measured on held-out sofas: 23 -> 17 half
    turns in 300 queries, other categories even).
    """
    own_best = np.maximum(ch[:, voters].min(axis=0), 1e-12)
    score = ch.min(axis=1) / own_best.min() + weight * np.median(ch[:, voters] / own_best, axis=1)
    return int(np.argmin(score))


def _resumed(vote: Hypothesis, source: str) -> Hypothesis:
    return Hypothesis(vote.R, vote.t, vote.fitness, vote.rmse, vote.chamfer, source, vote.icp_prev, vote.icp_moving)


def _agreeing(hyps: list[Hypothesis], anchor: Hypothesis, within: float) -> list[int]:
    """Indices of the candidates whose pose agrees with the best one's and that fit nearly as well."""
    cos_max = np.cos(np.radians(15.0))
    return [n for n, h in enumerate(hyps)
            if (np.trace(h.R @ anchor.R.T) - 1) / 2 > cos_max and h.chamfer <= within * anchor.chamfer]


def _average(poses: list[tuple[np.ndarray, np.ndarray]], anchor: Hypothesis) -> Hypothesis:
    """The (R, t) poses of candidates that agree (see _agreeing) averaged, carrying the anchor's scores.

    Each pre-aligned candidate gives its own estimate of the query's canonical pose, off by how
    that instance differs from the query; averaging cancels much of that. Equal weights: fit
    differences between instances that all sit well say little about whose frame is truer, and
    an exact gallery match stands alone anyway, since no relative fits within a factor of it.
    """
    U, _, Vt = np.linalg.svd(sum(R for R, _ in poses))
    R = U @ np.diag([1.0, 1.0, np.sign(np.linalg.det(U @ Vt))]) @ Vt
    t = np.mean([t for _, t in poses], axis=0)
    return Hypothesis(R, t, anchor.fitness, anchor.rmse, anchor.chamfer, anchor.source + f"+avg{len(poses)}")


def _distinct(hyps, n, min_angle_deg=10.0):
    """The n best hypotheses whose rotations differ by more than min_angle from each other."""
    kept = []
    cos_min = np.cos(np.radians(min_angle_deg))
    for h in hyps:
        if all((np.trace(h.R @ k.R.T) - 1) / 2 < cos_min for k in kept):
            kept.append(h)
        if len(kept) == n:
            break
    return kept
