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
A confidence that means what it says: the learnt probability that an answer is right.

What an answer reports about itself (how well the posed object fits, how much better than the
best other object, how many points it had) is turned into a probability by logistic regression
fitted on answers whose truth is known: views of the gallery's own objects rendered when the
model is built (never the views a benchmark reports), asked once with the object in the gallery
and once with it left out, since a robot also meets objects the gallery does not hold. The
calibration is stored in the model as plain arrays.

A linear boundary weighs each piece of evidence alike whatever the others say, but much of the
object missing from the view means little when the view itself is poorly explained (an
occluder, a ragged segment) and much when every point of it lies on the object (a bigger object
posed over a smaller one's view). With enough answers to learn them from, the regression also
sees every pairwise product and square of the standardised features (`interactions`; measured
in docs/method.md).
"""
from __future__ import annotations

from dataclasses import dataclass, field
from itertools import combinations_with_replacement

import numpy as np


@dataclass(frozen=True)
class Calibration:
    """
    p(right | features) = sigmoid(coef . z + intercept), z the standardised features.

    z = (x - mean) / scale, followed by the standardised products z_i z_j of the index pairs
    (none for a linear calibration, and in models built before products were learnt).
    """

    names: tuple
    mean: np.ndarray
    scale: np.ndarray
    coef: np.ndarray
    intercept: float
    pairs: np.ndarray = field(default_factory=lambda: np.zeros((0, 2), dtype=np.int64))
    pair_mean: np.ndarray = field(default_factory=lambda: np.zeros(0))
    pair_scale: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def probability(self, features: dict) -> float:
        x = np.array([features[n] for n in self.names], dtype=np.float64)
        z = float(self.coef @ _expanded(self, x[None])[0] + self.intercept)
        return float(1.0 / (1.0 + np.exp(-np.clip(z, -50.0, 50.0))))

    def to_arrays(self, prefix: str) -> dict:
        arrays = {
            prefix + 'names': np.array(self.names),
            prefix + 'mean': self.mean,
            prefix + 'scale': self.scale,
            prefix + 'coef': self.coef,
            prefix + 'intercept': np.array(self.intercept),
        }
        if len(self.pairs):
            arrays.update({prefix + 'pairs': self.pairs, prefix + 'pair_mean': self.pair_mean,
                           prefix + 'pair_scale': self.pair_scale})
        return arrays

    @classmethod
    def from_arrays(cls, arrays: dict, prefix: str) -> 'Calibration | None':
        if prefix + 'coef' not in arrays:
            return None
        linear = cls(
            tuple(str(n) for n in arrays[prefix + 'names']),
            arrays[prefix + 'mean'].astype(np.float64),
            arrays[prefix + 'scale'].astype(np.float64),
            arrays[prefix + 'coef'].astype(np.float64),
            float(arrays[prefix + 'intercept']),
        )
        if prefix + 'pairs' not in arrays:
            return linear
        return cls(
            linear.names, linear.mean, linear.scale, linear.coef, linear.intercept,
            arrays[prefix + 'pairs'].astype(np.int64),
            arrays[prefix + 'pair_mean'].astype(np.float64),
            arrays[prefix + 'pair_scale'].astype(np.float64),
        )


def _standardised_products(z: np.ndarray, pairs: np.ndarray) -> np.ndarray:
    return z[:, pairs[:, 0]] * z[:, pairs[:, 1]]


def _expanded(cal: Calibration, X: np.ndarray) -> np.ndarray:
    """Return the regression's inputs for rows X of raw features."""
    z = (X - cal.mean) / cal.scale
    if not len(cal.pairs):
        return z
    products = (_standardised_products(z, cal.pairs) - cal.pair_mean) / cal.pair_scale
    return np.hstack([z, products])


def _centred(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Return column means and spreads; a constant column keeps spread 1 (it carries nothing)."""
    scale = values.std(axis=0)
    return values.mean(axis=0), np.where(scale > 1e-12, scale, 1.0)


def fit_calibration(
    samples: list[dict], labels, names: tuple, regularisation: float = 1.0,
    interactions: bool = False,
) -> Calibration:
    """
    Logistic regression of labels (1: the answer was right) on the named features.

    With interactions, also on every pairwise product and square of the standardised features
    (each standardised in turn, so that one regularisation suits them all).
    """
    from sklearn.linear_model import LogisticRegression

    X = np.array([[s[n] for n in names] for s in samples], dtype=np.float64)
    y = np.asarray(labels, dtype=int)
    if len(set(y)) < 2:
        raise ValueError('calibration needs both right and wrong answers')
    mean, scale = _centred(X)
    cal = Calibration(tuple(names), mean, scale, np.zeros(0), 0.0)
    if interactions:
        pairs = np.array(list(combinations_with_replacement(range(len(names)), 2)),
                         dtype=np.int64)
        pair_mean, pair_scale = _centred(_standardised_products((X - mean) / scale, pairs))
        cal = Calibration(cal.names, mean, scale, cal.coef, 0.0, pairs, pair_mean, pair_scale)
    lr = LogisticRegression(C=regularisation, max_iter=5000).fit(_expanded(cal, X), y)
    return Calibration(cal.names, mean, scale, lr.coef_[0].astype(np.float64),
                       float(lr.intercept_[0]), cal.pairs, cal.pair_mean, cal.pair_scale)


def reliability(confidence, right, bins: int = 10) -> list[tuple[float, float, int]]:
    """(mean confidence, share right, count) per confidence bin: a reliability diagram."""
    c, r = np.asarray(confidence, dtype=np.float64), np.asarray(right, dtype=np.float64)
    edges = np.linspace(0.0, 1.0, bins + 1)
    which = np.clip(np.digitize(c, edges) - 1, 0, bins - 1)
    return [(float(c[which == b].mean()), float(r[which == b].mean()), int((which == b).sum()))
            for b in range(bins) if (which == b).any()]


def expected_calibration_error(confidence, right, bins: int = 10) -> float:
    """Mean gap between confidence and share right over the bins, weighted by their counts."""
    rows = reliability(confidence, right, bins)
    n = sum(k for _, _, k in rows)
    return float(sum(k * abs(c - r) for c, r, k in rows) / max(n, 1))
