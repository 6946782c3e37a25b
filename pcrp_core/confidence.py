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


def calibration_from_arrays(arrays: dict, prefix: str) -> 'Calibration | SplitCalibration | None':
    """Return the Calibration or SplitCalibration stored under prefix (None when there is none)."""
    if prefix + 'split_key' not in arrays:
        return Calibration.from_arrays(arrays, prefix)
    parts = tuple(Calibration.from_arrays(arrays, f'{prefix}{value}_') for value in (0, 1))
    if None in parts:
        raise KeyError(f'{prefix}: a split calibration lacks a part')
    return SplitCalibration(str(arrays[prefix + 'split_key']), parts)


def fit_calibration(
    samples: list[dict], labels, names: tuple, regularisation: float = 1.0
) -> Calibration:
    """Logistic regression of labels (1: the answer was right) on the named features."""
    from sklearn.linear_model import LogisticRegression

    X = np.array([[s[n] for n in names] for s in samples], dtype=np.float64)
    y = np.asarray(labels, dtype=int)
    if len(set(y)) < 2:
        raise ValueError('calibration needs both right and wrong answers')
    mean, scale = X.mean(axis=0), X.std(axis=0)
    scale = np.where(scale > 1e-12, scale, 1.0)
    lr = LogisticRegression(C=regularisation, max_iter=1000).fit((X - mean) / scale, y)
    return Calibration(
        tuple(names), mean, scale, lr.coef_[0].astype(np.float64), float(lr.intercept_[0])
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
    parts = []
    for value in (False, True):
        mine = kind == value
        if 0 < y[mine].sum() < mine.sum():
            mine_samples = [s for s, m in zip(samples, mine) if m]
            parts.append(fit_calibration(mine_samples, y[mine], names, regularisation))
        else:   # nothing to tell apart within the kind: what all samples say
            parts.append(fit_calibration(samples, y, names, regularisation))
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
