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
Where pose hypotheses come from, before any is refined or voted on.

Each generator returns (R, t, source) triples of query-to-gallery poses in normalised coordinates
(g ≈ R @ q + t): the paper's feature matches in RANSAC, principal axes, the half turns
near-symmetric shapes are confused by, upright turns when gravity is known, and, for clouds from a
sensor, the directions the object could have been seen from.
"""
from __future__ import annotations

import itertools

import numpy as np
from pcrp_core.geometry import rotation_taking
from pcrp_core.registration import ransac
from pcrp_core.registration.correspondences import matches_within_halves
from pcrp_core.registration.scoring import distances_back, mean_distance_batch
from pcrp_core.symmetry import principal_axes
from pcrp_core.visibility import sphere_directions
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

FLIPS = np.array(
    [np.diag([1.0, -1.0, -1.0]), np.diag([-1.0, 1.0, -1.0]), np.diag([-1.0, -1.0, 1.0])]
)


def _proper_signed_permutations() -> np.ndarray:
    """Return the 24 rotations that map coordinate axes onto coordinate axes."""
    mats = []
    for perm in itertools.permutations(range(3)):
        for signs in itertools.product((1.0, -1.0), repeat=3):
            M = np.zeros((3, 3))
            M[range(3), perm] = signs
            if np.linalg.det(M) > 0:
                mats.append(M)
    return np.array(mats)


AXIS_ROTATIONS = _proper_signed_permutations()


def ransac_seeds(query, gallery, opts, rng, clock):
    """
    Return the paper's hypotheses.

    Feature matches within symmetry halves (both pairings of the halves, since which half is which
    is not known), Procrustes in RANSAC.
    """
    if opts.symmetry_split:
        settings = [(query.halves, gallery.halves, True), (query.halves, gallery.halves, False)]
    else:
        settings = [(np.ones(len(query.sampled), bool), np.ones(len(gallery.sampled), bool), True)]
    seeds = []
    for qh, gh, same in settings:
        qi, gi, _ = matches_within_halves(query.features, gallery.features, qh, gh, same)
        clock.lap('correspondences')
        if len(qi) >= 3:
            R, t, _ = ransac(query.sampled[qi], gallery.sampled[gi], opts.ransac_threshold,
                             opts.ransac_iterations, rng)
            seeds.append((R, t, 'ransac'))
        clock.lap('ransac')
    return seeds


def pca_seeds(
    q: np.ndarray,
    g: np.ndarray,
    src: np.ndarray,
    tree: cKDTree,
    keep: int,
    prefilter: int = 0,
    upright=None,
):
    """
    Return rotations taking the query's principal axes onto the gallery's.

    One under each of the 24 axis-to-axis maps (two instances of a category need not order their
    axes alike), the `keep` that fit best before any refinement: right for complete objects, a
    cheap extra guess for partial ones.

    prefilter > 0: rank all 24 on that many of the points first and score only the best
    2 * keep on all of them; most axis maps are grossly wrong, and a few points say so.
    upright: a mask function over rotations; the maps it refuses are not considered.
    """
    Rs, ts = pca_rotations(q, g)
    short = np.arange(len(Rs))
    keep_map = None if upright is None else upright(Rs)
    if keep_map is not None and keep_map.any():
        short = short[keep_map]
    if 0 < prefilter < len(src) and 2 * keep < len(short):
        rough = mean_distance_batch(
            src[:: max(1, len(src) // prefilter)], Rs[short], ts[short], tree
        )
        short = np.sort(short[np.argsort(rough)[: 2 * keep]])
    cost = mean_distance_batch(src, Rs[short], ts[short], tree)
    return [(Rs[n], ts[n], 'pca') for n in short[np.argsort(cost)[:keep]]]


def pca_rotations(q, g):
    aq, ag = principal_axes(q), principal_axes(g)
    Rs = np.einsum('ji,njk,kl->nil', ag, AXIS_ROTATIONS, aq)    # ag.T @ M @ aq
    return Rs, g.mean(0) - Rs @ q.mean(0)


def view_seeds(
    q: np.ndarray,
    viewpoint: np.ndarray,
    g: np.ndarray,
    g_tree: cKDTree,
    src: np.ndarray,
    src_tree: cKDTree,
    directions: int,
    rolls: int,
    keep: int,
    prefilter: int,
    upright=None,
):
    """
    For a cloud from a sensor.

    The `keep` best of the poses that put the sensor in each of `directions` directions spread
    around the gallery object, turned `rolls` ways about the line of sight.

    A one-sided view's feature matches and principal axes are often not the object's (the
    local frames at its borders are not repeatable, and half an object has other axes), but the
    viewing direction is known: only where the sensor stood relative to the object and its roll
    are open, few enough to try exhaustively and cheaply. Each pose is placed so the query's
    centroid sits on that of the gallery's half facing the sensor (a stand-in for what it would
    see, without hidden point removal for every pose), and scored both ways on `prefilter`
    points: the query near the gallery object, and that facing half near the query.
    """
    v = viewpoint - q.mean(0)
    v = v / np.linalg.norm(v)
    D = sphere_directions(directions)
    turns = np.arange(rolls) * 2 * np.pi / rolls
    Rs = np.concatenate(
        [
            (
                Rotation.from_rotvec(np.outer(turns, d))
                * Rotation.from_matrix(rotation_taking(v, d))
            ).as_matrix()
            for d in D
        ]
    )
    ahead = (g - g.mean(0)) @ D.T
    fronts = [g[ahead[:, k] > np.median(ahead[:, k])] for k in range(len(D))]
    ts = np.repeat([f.mean(0) for f in fronts], rolls, axis=0) - Rs @ q.mean(0)
    idx = np.arange(len(Rs))
    ok = None if upright is None else upright(Rs)
    if ok is not None and ok.any():
        idx = idx[ok]
    cost = mean_distance_batch(src[:: max(1, len(src) // prefilter)], Rs[idx], ts[idx], g_tree)
    direction = idx // rolls
    for k in np.unique(direction):
        sel = np.flatnonzero(direction == k)
        face = fronts[k][:: max(1, len(fronts[k]) // prefilter)]
        cost[sel] += distances_back(src_tree, face, Rs[idx[sel]], ts[idx[sel]]).mean(axis=1)
    return [(Rs[n], ts[n], 'view') for n in idx[np.argsort(cost)[:keep]]]


def upright_turns(q_up, g_up, n: int) -> np.ndarray:
    """(n, 3, 3) rotations taking q_up onto g_up, turned by n even steps about g_up."""
    stand = Rotation.from_matrix(rotation_taking(q_up, g_up))
    turns = Rotation.from_rotvec(np.outer(np.arange(n) * 2 * np.pi / n, g_up))
    return (turns * stand).as_matrix()


def flips(R, t, centre):
    """Return the three half turns about canonical axes through the gallery centroid."""
    return [(F @ R, F @ (t - centre) + centre) for F in FLIPS]
