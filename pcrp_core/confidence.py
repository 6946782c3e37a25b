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
best other object, how many points it had) is turned into a probability by logistic regression,
or by boosted trees where there are answers enough to learn where the evidence turns (a view's:
instance/calibration.py), fitted on answers whose truth is known: views of the gallery's own
objects rendered when the model is built (never the views a benchmark reports), asked once with
the object in the gallery and once with it left out, since a robot also meets objects the
gallery does not hold. The calibration is stored in the model as plain arrays.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Calibration:
    """p(right | features) = sigmoid(coef . (x - mean) / scale + intercept)."""

    names: tuple
    mean: np.ndarray
    scale: np.ndarray
    coef: np.ndarray
    intercept: float

    def probability(self, features: dict) -> float:
        x = np.array([features[n] for n in self.names], dtype=np.float64)
        z = float(self.coef @ ((x - self.mean) / self.scale) + self.intercept)
        return float(1.0 / (1.0 + np.exp(-np.clip(z, -50.0, 50.0))))

    def to_arrays(self, prefix: str) -> dict:
        return {
            prefix + 'names': np.array(self.names),
            prefix + 'mean': self.mean,
            prefix + 'scale': self.scale,
            prefix + 'coef': self.coef,
            prefix + 'intercept': np.array(self.intercept),
        }

    @classmethod
    def from_arrays(cls, arrays: dict, prefix: str) -> 'Calibration | None':
        if prefix + 'coef' not in arrays:
            return None
        return cls(
            tuple(str(n) for n in arrays[prefix + 'names']),
            arrays[prefix + 'mean'].astype(np.float64),
            arrays[prefix + 'scale'].astype(np.float64),
            arrays[prefix + 'coef'].astype(np.float64),
            float(arrays[prefix + 'intercept']),
        )


@dataclass(frozen=True)
class SplitCalibration:
    """
    One Calibration for each of two kinds of answer, told apart by a 0/1 feature (key).

    A whole cloud and a one-sided view read the same evidence differently (a right view lacks most
    of its object, a right whole cloud does not), so each kind gets a regression of its own.
    """

    key: str
    parts: tuple  # (the Calibration where key is 0, where it is 1)

    @property
    def names(self) -> tuple:
        return self.parts[0].names

    def probability(self, features: dict) -> float:
        return self.parts[int(features[self.key] >= 0.5)].probability(features)

    def to_arrays(self, prefix: str) -> dict:
        out = {prefix + 'split_key': np.array(self.key)}
        for value, part in enumerate(self.parts):
            out.update(part.to_arrays(f'{prefix}{value}_'))
        return out


@dataclass(frozen=True)
class BoostedCalibration:
    """
    p(right | features) = sigmoid(base + rate * the sum of one leaf's value per tree).

    The trees of scikit-learn's GradientBoostingClassifier as plain arrays, all trees' nodes in
    one table: a node sends x left when x[feature] <= threshold; a leaf has left = -1.
    """

    names: tuple
    base: float
    rate: float
    roots: np.ndarray       # (n_trees,) each tree's first node
    feature: np.ndarray     # (n_nodes,)
    threshold: np.ndarray
    left: np.ndarray
    right: np.ndarray
    value: np.ndarray

    def probability(self, features: dict) -> float:
        # in single precision first, as scikit-learn's trees compare: the same side of every
        # threshold as the fitted classifier
        x = np.array([features[n] for n in self.names], dtype=np.float32).astype(np.float64)
        node = self.roots.copy()
        inner = self.left[node] >= 0
        while inner.any():     # every tree a level deeper at once: as many passes as levels
            at = node[inner]
            go_left = x[self.feature[at]] <= self.threshold[at]
            node[inner] = np.where(go_left, self.left[at], self.right[at])
            inner = self.left[node] >= 0
        z = self.base + self.rate * float(self.value[node].sum())
        return float(1.0 / (1.0 + np.exp(-np.clip(z, -50.0, 50.0))))

    def to_arrays(self, prefix: str) -> dict:
        out = {prefix + 'names': np.array(self.names),
               prefix + 'trees_base_rate': np.array([self.base, self.rate])}
        for key in ('roots', 'feature', 'threshold', 'left', 'right', 'value'):
            out[f'{prefix}trees_{key}'] = getattr(self, key)
        return out

    @classmethod
    def from_arrays(cls, arrays: dict, prefix: str) -> 'BoostedCalibration':
        base, rate = (float(v) for v in arrays[prefix + 'trees_base_rate'])
        names = tuple(str(v) for v in arrays[prefix + 'names'])
        t = {k: arrays[f'{prefix}trees_{k}'] for k in
             ('roots', 'feature', 'threshold', 'left', 'right', 'value')}
        roots, feature, left, right = (t[k].astype(np.int64) for k in
                                       ('roots', 'feature', 'left', 'right'))
        # checked here so that a damaged file fails to load, never a query: every walk from a
        # root must stay in the table, read named evidence and end
        n = len(left)
        if any(len(t[k]) != n for k in ('feature', 'threshold', 'right', 'value')):
            raise ValueError(f'{prefix}: tree arrays of different lengths')
        inner = np.flatnonzero(left >= 0)
        if (np.any((roots < 0) | (roots >= n)) or np.any(left[inner] >= n)
                or np.any((right[inner] < 0) | (right[inner] >= n))):
            raise ValueError(f'{prefix}: a tree node points outside the table')
        if np.any(left[inner] <= inner) or np.any(right[inner] <= inner):
            raise ValueError(f'{prefix}: a tree node points to a node before it')
        if np.any((feature[inner] < 0) | (feature[inner] >= len(names))):
            raise ValueError(f'{prefix}: a tree node reads evidence the calibration does not name')
        return cls(names, base, rate, roots, feature, t['threshold'].astype(np.float64), left,
                   right, t['value'].astype(np.float64))


def calibration_from_arrays(arrays: dict, prefix: str):
    """
    Return the calibration stored under prefix (None when there is none).

    A Calibration, a SplitCalibration or a BoostedCalibration, told apart by their arrays' names.
    """
    if prefix + 'trees_base_rate' in arrays:
        return BoostedCalibration.from_arrays(arrays, prefix)
    if prefix + 'split_key' not in arrays:
        return Calibration.from_arrays(arrays, prefix)
    parts = tuple(Calibration.from_arrays(arrays, f'{prefix}{value}_') for value in (0, 1))
    if None in parts:
        raise KeyError(f'{prefix}: a split calibration lacks a part')
    return SplitCalibration(str(arrays[prefix + 'split_key']), parts)


def _answers(samples: list[dict], labels, names: tuple) -> tuple[np.ndarray, np.ndarray]:
    """Return (a row of the named features per sample, labels as 0 / 1), both kinds present."""
    X = np.array([[s[n] for n in names] for s in samples], dtype=np.float64)
    y = np.asarray(labels, dtype=int)
    if len(set(y)) < 2:
        raise ValueError('calibration needs both right and wrong answers')
    return X, y


def fit_calibration(
    samples: list[dict], labels, names: tuple, regularisation: float = 1.0
) -> Calibration:
    """Logistic regression of labels (1: the answer was right) on the named features."""
    from sklearn.linear_model import LogisticRegression

    X, y = _answers(samples, labels, names)
    mean, scale = X.mean(axis=0), X.std(axis=0)
    scale = np.where(scale > 1e-12, scale, 1.0)
    lr = LogisticRegression(C=regularisation, max_iter=1000).fit((X - mean) / scale, y)
    return Calibration(
        tuple(names), mean, scale, lr.coef_[0].astype(np.float64), float(lr.intercept_[0])
    )


def fit_boosted_calibration(
    samples: list[dict], labels, names: tuple, trees: int = 200, depth: int = 3,
    rate: float = 0.05, least_leaf: int = 10, subsample: float = 0.8
) -> BoostedCalibration:
    """
    Gradient-boosted trees of labels (1: the answer was right) on the named features.

    Trees learn where a piece of evidence turns from telling right to telling wrong, which one
    weight per feature cannot; they need answers enough (a few hundred) not to learn the noise.
    The defaults were chosen on the robot report's validation views (docs/method.md).
    """
    from sklearn.ensemble import GradientBoostingClassifier

    X, y = _answers(samples, labels, names)
    gb = GradientBoostingClassifier(
        n_estimators=trees, max_depth=depth, learning_rate=rate, min_samples_leaf=least_leaf,
        subsample=subsample, random_state=0,
    ).fit(X, y)
    tables = [e.tree_ for e in gb.estimators_[:, 0]]
    sizes = np.array([t.node_count for t in tables])
    roots = np.concatenate([[0], np.cumsum(sizes)[:-1]])
    # children renumbered into the one table; a leaf keeps -1 on both sides
    shift = lambda a, r: np.where(a >= 0, a + r, -1)   # noqa: E731
    left = np.concatenate([shift(t.children_left, r) for t, r in zip(tables, roots)])
    right = np.concatenate([shift(t.children_right, r) for t, r in zip(tables, roots)])
    value = np.concatenate([t.value[:, 0, 0] for t in tables])
    # what the trees add to the prior's log-odds is the rest of the decision function
    tree_sum = sum(e.predict(X[:1])[0] for e in gb.estimators_[:, 0])
    base = float(gb.decision_function(X[:1])[0] - rate * tree_sum)
    return BoostedCalibration(
        tuple(names), base, float(rate), roots.astype(np.int64),
        np.concatenate([t.feature for t in tables]).astype(np.int64),
        np.concatenate([t.threshold for t in tables]).astype(np.float64),
        left.astype(np.int64), right.astype(np.int64), value.astype(np.float64),
    )


def fit_split_calibration(
    samples: list[dict], labels, names: tuple, key: str, regularisation: float = 1.0
) -> SplitCalibration:
    """
    fit_calibration() for each kind of sample (key 0 or 1) apart.

    A kind whose samples are all right or all wrong gets the regression of all samples instead.
    """
    y = np.asarray(labels, dtype=bool)
    kind = np.array([s[key] >= 0.5 for s in samples], dtype=bool)
    parts, pooled = [], None
    for value in (False, True):
        mine = kind == value
        if 0 < y[mine].sum() < mine.sum():
            mine_samples = [s for s, m in zip(samples, mine) if m]
            parts.append(fit_calibration(mine_samples, y[mine], names, regularisation))
            continue
        # nothing to tell apart within the kind: what all samples say, fitted once for both
        if pooled is None:
            pooled = fit_calibration(samples, y, names, regularisation)
        parts.append(pooled)
    return SplitCalibration(key, tuple(parts))


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
