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
Saab transform (subspace approximation with adjusted bias), as an unsupervised estimator.

One DC kernel (the constant direction) plus AC kernels from PCA of what the DC kernel leaves; an AC
kernel is kept while the share of the total energy it carries exceeds a threshold. Together they
are orthonormal, so keeping every kernel reconstructs the input exactly.
"""
from __future__ import annotations

import numpy as np


class Saab:
    def __init__(self, energy_threshold: float = 1e-3, n_components: int | None = None):
        self.energy_threshold = energy_threshold
        self.n_components = n_components

    def fit(self, X: np.ndarray) -> 'Saab':
        X = np.asarray(X, dtype=np.float64)
        d = X.shape[1]
        dc = np.full(d, 1.0 / np.sqrt(d))
        self.mean_ = X.mean(axis=0)
        centred = X - self.mean_
        # an orthonormal basis of everything orthogonal to DC, where the AC kernels live
        q, _ = np.linalg.qr(np.column_stack([dc, np.eye(d)[:, : d - 1]]))
        complement = q[:, 1:].T
        ac = centred @ complement.T
        var_ac, vecs = np.linalg.eigh(np.cov(ac, rowvar=False).reshape(d - 1, d - 1))
        order = np.argsort(var_ac)[::-1]
        ac_kernels = (vecs[:, order].T @ complement)
        var_ac = np.clip(var_ac[order], 0, None)
        var_dc = float(np.var(centred @ dc))
        energy = np.concatenate([[var_dc], var_ac])
        self.energy_ratio_ = energy / max(energy.sum(), 1e-300)
        keep = 1 + int(np.sum(self.energy_ratio_[1:] > self.energy_threshold))
        if self.n_components is not None:
            keep = min(keep, self.n_components)
        self.kernels_ = np.vstack([dc, ac_kernels])[:keep]
        self.all_kernels_ = np.vstack([dc, ac_kernels])
        self.n_components_ = keep
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        return (np.asarray(X, dtype=np.float64) - self.mean_) @ self.kernels_.T

    def inverse_transform(self, Y: np.ndarray) -> np.ndarray:
        return Y @ self.kernels_ + self.mean_

    # model files store arrays, never objects
    def get_state(self, prefix: str) -> dict:
        return {f'{prefix}mean': self.mean_, f'{prefix}kernels': self.kernels_,
                f'{prefix}energy_ratio': self.energy_ratio_}

    @classmethod
    def from_state(cls, state: dict, prefix: str) -> 'Saab':
        s = cls()
        s.mean_ = state[f'{prefix}mean']
        s.kernels_ = state[f'{prefix}kernels']
        s.energy_ratio_ = state[f'{prefix}energy_ratio']
        s.n_components_ = len(s.kernels_)
        return s


class ChannelwiseSaab:
    """
    One Saab per input channel (PointHop++).

    a channel's octant vector is transformed on its own, and a child kernel is kept while parent
    energy x child share exceeds the threshold, which is what makes the feature dimension follow
    the data rather than a fixed size.
    """

    def __init__(self, energy_threshold: float = 1e-3):
        self.energy_threshold = energy_threshold

    def fit(self, X: np.ndarray, parent_energy: np.ndarray) -> 'ChannelwiseSaab':
        """X: (n, octants, channels); parent_energy: (channels,) shares of the previous hop."""
        self.saabs_ = []
        for c in range(X.shape[2]):
            saab = Saab(energy_threshold=0.0).fit(X[:, :, c])
            keep = max(
                1, int(np.sum(parent_energy[c] * saab.energy_ratio_ > self.energy_threshold))
            )
            saab.kernels_ = saab.kernels_[:keep]
            saab.n_components_ = keep
            self.saabs_.append(saab)
        self.n_components_ = sum(s.n_components_ for s in self.saabs_)
        return self

    def transform(self, X: np.ndarray) -> np.ndarray:
        return np.concatenate([s.transform(X[:, :, c]) for c, s in enumerate(self.saabs_)], axis=1)

    def get_state(self, prefix: str) -> dict:
        state = {}
        for c, s in enumerate(self.saabs_):
            state.update(s.get_state(f'{prefix}{c}_'))
        return state

    @classmethod
    def from_state(cls, state: dict, prefix: str, n_channels: int) -> 'ChannelwiseSaab':
        cw = cls()
        cw.saabs_ = [Saab.from_state(state, f'{prefix}{c}_') for c in range(n_channels)]
        cw.n_components_ = sum(s.n_components_ for s in cw.saabs_)
        return cw
