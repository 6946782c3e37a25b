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

"""A pose hypothesis as registration carries it, with how well it fits; distinct ones."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass
class Hypothesis:
    """Query-to-gallery pose (g = R @ q + t, normalised units), its fit on one gallery object."""

    R: np.ndarray
    t: np.ndarray
    fitness: float
    rmse: float
    chamfer: float
    source: str
    # where ICP stopped: its last mean squared error and whether it was still improving
    icp_prev: float = np.inf
    icp_moving: bool = True

    def renamed(self, source: str) -> 'Hypothesis':
        return Hypothesis(
            self.R,
            self.t,
            self.fitness,
            self.rmse,
            self.chamfer,
            source,
            self.icp_prev,
            self.icp_moving,
        )


def rotation_cosine(A: np.ndarray, B: np.ndarray) -> float:
    """Cosine of the angle between two rotations."""
    return (np.trace(A @ B.T) - 1) / 2


def distinct(hyps, n: int, min_angle_deg: float = 10.0) -> list[Hypothesis]:
    """Return the first n of hyps (best first) whose rotations differ by more than min_angle."""
    kept = []
    cos_min = np.cos(np.radians(min_angle_deg))
    for h in hyps:
        if all(rotation_cosine(h.R, k.R) < cos_min for k in kept):
            kept.append(h)
        if len(kept) == n:
            break
    return kept
