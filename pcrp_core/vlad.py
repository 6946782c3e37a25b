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
One global vector per cloud from its point features: VLAD over a k-means codebook.

Normalisation, in this order (Arandjelovic & Zisserman, "All about VLAD"): signed square root
of each entry (tames codewords that collect many points), L2 per codeword block
(intra-normalisation, so no single codeword dominates), then L2 of the whole vector, so
Euclidean distance between two vectors is a monotone function of their cosine similarity.
Max pooling is kept as the paper's ablation.
"""
from __future__ import annotations

import numpy as np
from sklearn.cluster import KMeans
from threadpoolctl import threadpool_limits   # scikit-learn's own dependency

AGGREGATIONS = ('vlad', 'max')


def _l2(x: np.ndarray, axis: int = -1) -> np.ndarray:
    return x / np.maximum(np.linalg.norm(x, axis=axis, keepdims=True), 1e-12)


class VLAD:
    def __init__(self, n_clusters: int = 10, aggregation: str = 'vlad', fit_points: int = 100_000,
                 random_state: int = 0):
        if aggregation not in AGGREGATIONS:
            raise ValueError(f'aggregation must be one of {AGGREGATIONS}, got {aggregation!r}')
        self.n_clusters = n_clusters
        self.aggregation = aggregation
        self.fit_points = fit_points
        self.random_state = random_state

    def fit(self, features: np.ndarray) -> 'VLAD':
        """features: (n, D) point features pooled over the gallery."""
        rng = np.random.default_rng(self.random_state)
        if len(features) > self.fit_points:
            features = features[rng.choice(len(features), self.fit_points, replace=False)]
        # one thread: k-means' threads add their partial sums in the order they finish, so the
        # codebook (and every vector after it) changed from build to build
        with threadpool_limits(1, user_api='openmp'):
            km = KMeans(self.n_clusters, n_init=3, random_state=self.random_state).fit(features)
        self.codebook_ = km.cluster_centers_.astype(np.float32)
        return self

    def transform(self, features: np.ndarray) -> np.ndarray:
        """(k * D,) VLAD vector, or (D,) max-pooled vector, of one cloud's point features."""
        if self.aggregation == 'max':
            return _l2(features.max(axis=0))
        d2 = (
            (features**2).sum(1)[:, None]
            - 2 * features @ self.codebook_.T
            + (self.codebook_**2).sum(1)[None]
        )
        nearest = np.argmin(d2, axis=1)
        # sum of residuals per codeword = (sum of its features) - (its count) * codeword, the
        # sums as one product with the assignment matrix (np.add.at is ~50x slower)
        assign = np.zeros((len(features), len(self.codebook_)))
        assign[np.arange(len(features)), nearest] = 1.0
        residual_sums = (
            assign.T @ features.astype(np.float64) - assign.sum(0)[:, None] * self.codebook_
        )
        v = np.sign(residual_sums) * np.sqrt(np.abs(residual_sums))
        return _l2(_l2(v, axis=1).ravel()).astype(np.float32)
