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
FR-PointHop: rotation-invariant point features in two hops, fitted without labels.

Hop 1 describes each point by FPFH (or, as in R-PointHop, by the mean local coordinates of its
neighbours in the eight octants of its local frame) and compresses it with Saab. Hop 2 keeps half
the points by farthest-point sampling, gathers each one's hop-1 responses per octant of its own
local frame and compresses each channel with its own Saab. A point's feature is its hop-1 response
beside its hop-2 responses.

Clouds are expected in normalised units (object radius about 1): radii and neighbourhood sizes are
hyperparameters of that scale.
"""
from __future__ import annotations

import numpy as np
from pcrp_core.features.fpfh import fpfh, oriented_normals
from pcrp_core.features.lrf import local_frames
from pcrp_core.features.neighbours import knn
from pcrp_core.features.octants import octant_coordinates, octant_means
from pcrp_core.features.saab import ChannelwiseSaab, Saab
from pcrp_core.preprocess import farthest_point_sampling
from pcrp_core.timing import Clock
from scipy.spatial import cKDTree

HOP1_ATTRIBUTES = ('fpfh', 'octant')


class PointHop:
    def __init__(self, hop1: str = 'fpfh', fpfh_radius: float = 0.3, normal_k: int = 20,
                 k1: int = 32, k2: int = 64, sample_ratio: float = 0.5,
                 energy_threshold1: float = 1e-3, energy_threshold2: float = 5e-4,
                 fit_points: int = 200_000, random_state: int = 0):
        if hop1 not in HOP1_ATTRIBUTES:
            raise ValueError(f'hop1 must be one of {HOP1_ATTRIBUTES}, got {hop1!r}')
        self.hop1 = hop1
        self.fpfh_radius = fpfh_radius
        self.normal_k = normal_k
        self.k1 = k1
        self.k2 = k2
        self.sample_ratio = sample_ratio
        self.energy_threshold1 = energy_threshold1
        self.energy_threshold2 = energy_threshold2
        self.fit_points = fit_points
        self.random_state = random_state

    # -- the two hops, shared by fit and transform ------------------------------------
    def _hop1_attributes(self, points: np.ndarray, tree: cKDTree, viewpoint=None) -> np.ndarray:
        if self.hop1 == 'fpfh':
            return fpfh(
                points, oriented_normals(points, self.normal_k, viewpoint), self.fpfh_radius
            )
        nb = knn(points, points, self.k1, tree)
        frames = local_frames(points, points, nb, points.mean(axis=0), viewpoint)
        return octant_coordinates(points, points, nb, frames)

    def _hop2_octants(self, points, tree, hop1_responses, viewpoint=None):
        sampled = farthest_point_sampling(
            points, max(1, int(round(len(points) * self.sample_ratio)))
        )
        return sampled, self._octants_at(points, tree, sampled, hop1_responses, viewpoint)

    def _octants_at(self, points, tree, sampled, hop1_responses, viewpoint=None):
        centres = points[sampled]
        nb = knn(points, centres, self.k2, tree)
        frames = local_frames(points, centres, nb, points.mean(axis=0), viewpoint)
        return octant_means(points, centres, nb, frames, hop1_responses)

    # -- estimator ----------------------------------------------------------------------
    def fit(self, clouds) -> 'PointHop':
        rng = np.random.default_rng(self.random_state)
        per_cloud = max(1, self.fit_points // max(1, len(clouds)))
        trees = [cKDTree(c) for c in clouds]
        attrs = [self._hop1_attributes(c, t) for c, t in zip(clouds, trees)]
        stacked = np.concatenate(
            [a[rng.choice(len(a), min(per_cloud, len(a)), replace=False)] for a in attrs]
        )
        self.saab1_ = Saab(self.energy_threshold1).fit(stacked)
        octs = []
        for c, t, a in zip(clouds, trees, attrs):
            sampled, o = self._hop2_octants(c, t, self.saab1_.transform(a))
            octs.append(o[rng.choice(len(o), min(per_cloud, len(o)), replace=False)])
        parent = self.saab1_.energy_ratio_[: self.saab1_.n_components_]
        self.saab2_ = ChannelwiseSaab(self.energy_threshold2).fit(np.concatenate(octs), parent)
        self.n_features_ = self.saab1_.n_components_ + self.saab2_.n_components_
        return self

    def transform(self, points: np.ndarray, viewpoint: np.ndarray | None = None,
                  timings: dict | None = None) -> tuple[np.ndarray, np.ndarray]:
        """
        Return (sampled indices (M,), features (M, D)) of one normalised cloud.

        viewpoint: the sensor's position in the same coordinates, for one-sided views (see
        fpfh.oriented_normals). timings, when given, gets the seconds of each step added under fpfh
        (or octant), hop1, sampling and hop2.
        """
        clock = Clock(timings)
        tree = cKDTree(points)
        attrs = self._hop1_attributes(points, tree, viewpoint)
        clock.lap(self.hop1)
        h1 = self.saab1_.transform(attrs)
        clock.lap('hop1')
        sampled = farthest_point_sampling(
            points, max(1, int(round(len(points) * self.sample_ratio)))
        )
        clock.lap('sampling')
        octs = self._octants_at(points, tree, sampled, h1, viewpoint)
        h2 = self.saab2_.transform(octs)
        clock.lap('hop2')
        return sampled, np.concatenate([h1[sampled], h2], axis=1).astype(np.float32)

    # -- model files ------------------------------------------------------------------------
    def get_params(self) -> dict:
        return {
            k: getattr(self, k)
            for k in (
                'hop1',
                'fpfh_radius',
                'normal_k',
                'k1',
                'k2',
                'sample_ratio',
                'energy_threshold1',
                'energy_threshold2',
                'fit_points',
                'random_state',
            )
        }

    def get_state(self) -> dict:
        return {**self.saab1_.get_state('hop1_'), **self.saab2_.get_state('hop2_')}

    @classmethod
    def from_state(cls, params: dict, state: dict) -> 'PointHop':
        ph = cls(**params)
        ph.saab1_ = Saab.from_state(state, 'hop1_')
        ph.saab2_ = ChannelwiseSaab.from_state(state, 'hop2_', ph.saab1_.n_components_)
        ph.n_features_ = ph.saab1_.n_components_ + ph.saab2_.n_components_
        return ph
