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
Which known object a camera's cloud shows, and its pose: the steps of the instance pipeline.

1. Shortlist: objects some view of which has the query's shape (spread along its principal
   axes, in metres): size alone rules out most of a household gallery.
2. Hypotheses: per shortlisted object, the (view, roll) pairs whose silhouettes agree with the
   query's, or with gravity known, turns about the vertical; each ranked by a cheap cost.
3. Refinement: the best poses of the objects that ranked best, by point-to-plane ICP.
4. Verification: each refined pose judged both ways against the cloud (verification.py); the
   lowest cost wins. What the runner-up scored is kept: how much better the answer is than the
   best other object is much of how sure it can be (confidence.py).
5. Half turns: the answer turned half about each of its object's axes, refined and judged too,
   since a nearly symmetric object is often answered turned (best_half_turn).
6. More poses: an answer that fits poorly (looks_again) has the next few poses of the best
   objects refined and judged: the coarse cost ranks a right pose past the first few when it
   cannot tell an object from itself turned, or part of it is hidden.
7. Local shape: an answer that still fits poorly (an object partly hidden: its visible centroid
   and silhouette misled step 2), or, given the scene, is partly hidden and fits less than well
   (looks_again), has the objects nearest the cloud's shape placed again from FPFH matches in
   RANSAC (local_shape.py), refined and judged alike (from_local_shape).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from pcrp_core.instance import hypotheses, local_shape
from pcrp_core.instance.occlusion import occluders
from pcrp_core.instance.shape_index import ShapeIndex
from pcrp_core.instance.templates import extent, shape_code, Templates
from pcrp_core.instance.verification import Fit, judge, query_surface, Surface, visible_points
from pcrp_core.registration.icp import icp_point_to_plane
from pcrp_core.timing import Clock
from scipy.spatial import cKDTree


# an answer whose expected surface the scene shows hidden this much is partly hidden: its view
# hypotheses came from a cut silhouette and a shifted centroid
PARTLY_HIDDEN = 0.1
# objects, best-ranked first, whose further poses a poor fit refines (step 6): the answer's and
# its nearest rivals', as on the validation views poses_refined_again was chosen on
AGAIN_OBJECTS = 3


def looks_again(fit: Fit, opts) -> bool:
    """
    Whether an answer fits poorly enough to be looked for again (steps 6 and 7).

    Its cost over local_shape_cost, or, partly hidden behind what the scene shows, over
    local_shape_cost_hidden: its hidden surface costs it nothing, so the same misfit costs less.
    """
    if fit.cost > opts.local_shape_cost:
        return True
    return fit.hidden_share >= PARTLY_HIDDEN and fit.cost > opts.local_shape_cost_hidden


@dataclass
class Candidate:
    index: int          # gallery object
    R: np.ndarray       # object to camera
    t: np.ndarray
    fit: Fit


@dataclass
class Match:
    """
    The answer and what it beat.

    best, and the best candidate of each other refined object (best first); the distance beyond
    which a point counted as unexplained and the noise it was set from; and how the hypotheses
    ranked the shortlisted objects.
    """

    best: Candidate
    others: list[Candidate]
    tau: float
    noise: float
    # how far the cloud's shape is from the answer's nearest view (ShapeIndex.gaps): an object the
    # gallery lacks is often answered by one of another size
    shape_gap: float
    coarse: list = field(default_factory=list)   # (coarse cost, object index), best first
    # log of how many times better local shape made the answer fit (0: not run, or no better): a
    # poor fit gets a dozen more objects to try, and what a fit found so is worth, the
    # calibration learns
    searched: float = 0.0


class InstanceMatcher:
    """Matches clouds from a camera against a gallery's templates (see templates.py)."""

    def __init__(self, templates: Templates):
        self.templates = templates
        self.directions = templates.directions
        self.shapes = ShapeIndex(templates.shapes)
        # each object's tree and Open3D cloud, made when it is first shortlisted: a large gallery
        # loads at once, and only the objects a stream meets take memory
        self._surfaces: dict[int, tuple[Surface, object]] = {}
        self._local_shapes: dict[tuple, local_shape.LocalShape] = {}

    def __getstate__(self):
        # the caches hold Open3D objects, which do not pickle (a build hands the model to worker
        # processes): a worker makes its own as it goes
        return {**self.__dict__, '_surfaces': {}, '_local_shapes': {}}

    def surface(self, i: int) -> tuple[Surface, object]:
        """Object i's Surface (tree, normals, spacing) and Open3D cloud with normals, for ICP."""
        if i not in self._surfaces:
            import open3d as o3d

            tpl = self.templates
            points, normals = tpl.points[i], tpl.normals[i]
            # copies: Open3D refuses read-only arrays (a worker process's memory-mapped model).
            # Centred on the object: Open3D's ICP turns the target about its origin, and a mesh
            # whose origin lies metres away couples each small turn with a large shift
            cloud = o3d.geometry.PointCloud(
                o3d.utility.Vector3dVector(np.array(points, dtype=np.float64) - tpl.centre[i])
            )
            cloud.normals = o3d.utility.Vector3dVector(np.array(normals, dtype=np.float64))
            self._surfaces[i] = (
                Surface(points, normals, cKDTree(points), float(tpl.spacing[i])),
                cloud,
            )
        return self._surfaces[i]

    def local_shape(self, i: int, voxel: float, radius: float) -> local_shape.LocalShape:
        """Object i's FPFH on its surface points, made when first asked for (like surface())."""
        key = (i, voxel, radius)
        if key not in self._local_shapes:
            tpl = self.templates
            self._local_shapes[key] = local_shape.of_object(
                tpl.points[i], tpl.normals[i], voxel, radius
            )
        return self._local_shapes[key]

    def warm(self, opts) -> None:
        """Make every object's surface() and local_shape() (with opts' grid and radius) now."""
        for i in range(len(self.templates)):
            self.surface(i)
            self.local_shape(i, opts.local_shape_voxel, opts.local_shape_radius)

    def shortlist(self, shape: np.ndarray, opts, exclude=(), n=None) -> np.ndarray:
        """Return the n (opts.shortlist) objects of smallest gap (ShapeIndex), nearest first."""
        n = opts.shortlist if n is None else n
        return self.shapes.nearest(shape, n, opts.smaller_weight, exclude)[0]

    def refine(self, i: int, R: np.ndarray, t: np.ndarray, source, stages):
        """
        Return object i's pose (R, t) refined by ICP of the Open3D cloud source onto it.

        About the object's centre: its Open3D cloud is centred (surface()).
        """
        c = self.templates.centre[i]
        R, t = icp_point_to_plane(source, self.surface(i)[1], R, t + R @ c, stages)
        return R, t - R @ c

    def stages(self, i: int, tau: float) -> tuple:
        """ICP stages for a hypothesis of object i: from a reach set by its size, down to tau."""
        reach = float(np.clip(0.15 * self.templates.diameter[i], 2 * tau, 0.03))
        return ((reach, reach / 2, 30), (2 * tau, tau, 20))

    def verify(self, i: int, R: np.ndarray, t: np.ndarray, query: Surface, tau: float,
               opts) -> Candidate:
        """Return object i at pose (R, t) judged against the query (verification.py)."""
        tpl = self.templates
        expected = visible_points(tpl.visible[i], self.directions, tpl.centre[i], R, t)
        return Candidate(i, R, t, judge(query, self.surface(i)[0], expected, R, t, tau,
                                        opts.unshown_weight))

    def from_local_shape(self, order: list[Candidate], objects, points: np.ndarray,
                         query: Surface, source, tau: float, opts, up=None,
                         up_object=None) -> list[Candidate]:
        """
        Return order with each of objects placed from matched local shape, where that fits better.

        objects: gallery indices. A new answer gets its half turns.
        """
        if not len(objects):
            return order
        voxel, radius = opts.local_shape_voxel, opts.local_shape_radius
        cloud = local_shape.of_cloud(points, voxel, radius)
        best_of = {c.index: c for c in order}
        first = order[0]
        for i in objects:
            R, t = local_shape.pose(cloud, self.local_shape(i, voxel, radius), 1.5 * voxel,
                                    opts.local_shape_iterations, seed=int(i))
            R, t = self.refine(i, R, t, source, self.stages(i, tau))
            candidate = self.verify(i, R, t, query, tau, opts)
            if i not in best_of or candidate.fit.cost < best_of[i].fit.cost:
                best_of[i] = candidate
        order = sorted(best_of.values(), key=lambda c: c.fit.cost)
        if opts.half_turns and order[0] is not first:
            order[0] = self.best_half_turn(order[0], query, source, tau, opts,
                                           up_object if up is not None else None)
        return order

    def best_half_turn(self, best: Candidate, query: Surface, source, tau: float, opts,
                       up_object=None) -> Candidate:
        """
        Return best, or the same object turned half about one of its axes if that fits better.

        Many objects are nearly symmetric under a half turn (boxes, blocks, bottles): the turned
        pose lies a few millimetres off the true one, too little for the coarse cost to tell apart
        and too far for ICP to cross, and fits the cloud markedly worse. The turns are about the
        object's principal axes, or with gravity given about its up axis alone (any other would
        stand it on its head). source: the Open3D cloud ICP refined with.
        """
        i = best.index
        c = self.templates.centre[i]
        if up_object is not None:
            axes = [np.asarray(up_object, dtype=np.float64) / np.linalg.norm(up_object)]
        else:
            axes = np.linalg.eigh(np.cov((self.templates.points[i] - c).T))[1].T
        for a in axes:
            R = best.R @ (2.0 * np.outer(a, a) - np.eye(3))    # the half turn about a
            t = best.t + (best.R - R) @ c                       # about the object's centre
            R, t = self.refine(i, R, t, source, ((2 * tau, tau, 20),))
            turned = self.verify(i, R, t, query, tau, opts)
            if turned.fit.cost < best.fit.cost:
                best = turned
        return best

    def _refine_poses(self, best_of: dict, i: int, Rs, ts, query: Surface, source, tau: float,
                      opts, clock) -> None:
        """Refine and judge object i at each pose (Rs, ts); keep its best in best_of[i]."""
        for R, t in zip(Rs, ts):
            R, t = self.refine(i, R, t, source, self.stages(i, tau))
            clock.lap('refinement')
            candidate = self.verify(i, R, t, query, tau, opts)
            if i not in best_of or candidate.fit.cost < best_of[i].fit.cost:
                best_of[i] = candidate
            clock.lap('verification')

    def match(self, points: np.ndarray, opts, up=None, up_object=None, rng=None, timings=None,
              exclude=(), scene=None, floor=None) -> Match:
        """
        Match a cloud against the gallery: which object it shows, in which pose, and what it beat.

        points: (N, 3) in the camera's frame (camera at the origin), cleaned and thinned;
        opts: InstanceOptions.
        up: the up direction in that frame when known, with up_object the objects' up axis.
        exclude: gallery indices not to consider (how a calibration asks what the answer would
        be if the object were not in the gallery).
        scene: (M, 3) what else the camera measured, in the same frame, or its DepthImage:
        surface an answer expects behind it is not counted missing (occlusion.py).
        floor: with up, the height along it under which the cloud's points were set aside as the
        table's layer (support.py): surface an answer expects that low is not counted missing.
        """
        import open3d as o3d

        tpl = self.templates
        rng = np.random.default_rng(0) if rng is None else rng
        clock = Clock(timings)
        query, noise = query_surface(points)
        if scene is not None:
            query.occluders = occluders(scene, points, query.spacing, float(tpl.diameter.max()))
        if floor is not None and up is not None:
            query.floor = (np.asarray(up, dtype=np.float64), float(floor))
        tau = max(opts.fit_tolerance, opts.noise_tolerance * noise)
        view = hypotheses.QueryView(points)
        sample = points[
            rng.choice(len(points), min(opts.score_points, len(points)), replace=False)
        ]
        clock.lap('description')
        ranked = []
        shape = shape_code(points)
        for i in self.shortlist(shape, opts, exclude):
            if up is not None and up_object is not None:
                R, t, v = hypotheses.upright(
                    view, up, up_object, tpl.cameras[i], tpl.view_centres[i], opts.yaw_steps
                )
            else:
                R, t, v = hypotheses.from_views(
                    view,
                    tpl.frames[i],
                    tpl.signatures[i],
                    tpl.view_centres[i],
                    opts.silhouette_poses,
                )
            cost = hypotheses.coarse_cost(
                R, t, v, sample, self.surface(i)[0].tree, tpl.samples[i], query.tree
            )
            best = np.argsort(cost)[: opts.poses_refined + opts.poses_refined_again]
            ranked.append((float(cost[best[0]]), int(i), R[best], t[best]))
        ranked.sort(key=lambda r: r[0])
        clock.lap('hypotheses')
        source = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(
            points[rng.choice(len(points), min(opts.refine_points, len(points)), replace=False)]))
        best_of: dict[int, Candidate] = {}
        # objects whose best hypothesis costs far more than the best object's are not refined:
        # on validation views the right object's coarse cost was within 1.6 times the best's, and
        # refining up to 2 times cost a fifth more time for 2 partly hidden views in 312
        within = [
            r for r in ranked[: opts.objects_refined] if r[0] <= opts.coarse_ratio * ranked[0][0]
        ]
        first = opts.poses_refined
        for _, i, Rs, ts in within:
            self._refine_poses(best_of, i, Rs[:first], ts[:first], query, source, tau, opts, clock)
        order = sorted(best_of.values(), key=lambda c: c.fit.cost)
        turn_up = up_object if up is not None else None   # half turns about it alone
        if opts.half_turns:
            order[0] = self.best_half_turn(order[0], query, source, tau, opts, turn_up)
            clock.lap('verification')
        if opts.poses_refined_again and looks_again(order[0].fit, opts):
            answer = best_of[order[0].index] = order[0]   # with its half turn
            for _, i, Rs, ts in within[:AGAIN_OBJECTS]:
                self._refine_poses(best_of, i, Rs[first:], ts[first:], query, source, tau, opts,
                                   clock)
            order = sorted(best_of.values(), key=lambda c: c.fit.cost)
            if opts.half_turns and order[0] is not answer:
                order[0] = self.best_half_turn(order[0], query, source, tau, opts, turn_up)
                clock.lap('verification')
        before = order[0].fit.cost
        if looks_again(order[0].fit, opts):
            # by shape again, further down than the shortlist: a hidden part shrinks the view,
            # and the right object then ranks a little lower than when seen whole
            objects = self.shortlist(shape, opts, exclude, opts.local_shape_objects)
            # an object smaller than the view cannot be it, and its FPFH is as dear as any
            floor = opts.local_shape_min_diameter * extent(points)
            objects = [i for i in objects if tpl.diameter[i] >= floor]
            order = self.from_local_shape(order, objects, points, query, source, tau, opts, up,
                                          up_object)
            clock.lap('local_shape')
        gap = self.shapes.gaps(shape, opts.smaller_weight, [order[0].index])[0]
        return Match(order[0], order[1:], tau, noise, float(gap),
                     [(c, i) for c, i, _, _ in ranked],
                     float(np.log(max(before, 1e-9) / max(order[0].fit.cost, 1e-9))))
