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
Which way is up, when the caller knows it.

Hypotheses that tip the gallery's up axis away from it are dropped (the turns near-symmetric shapes
are most confused by are upside-down and lying-down ones).
"""

from __future__ import annotations

import numpy as np


class UpPrior:
    """
    Which way is up, when the caller knows it.

    up: (the up direction in the query's frame, the gallery's up axis), unit vectors, or None when
    unknown; tolerance_deg: how far an answer may tip the object.
    """

    def __init__(self, up, tolerance_deg: float):
        self.up = None if up is None else tuple(np.asarray(u, dtype=np.float64) for u in up)
        self.cos_min = np.cos(np.radians(tolerance_deg)) - 1e-9

    @property
    def known(self) -> bool:
        return self.up is not None

    def upright(self, Rs) -> np.ndarray:
        """
        Return (H,) whether each query-to-gallery rotation keeps the gallery's up axis upright.

        Upright: within the tolerance of the known up direction (all true when up is unknown).
        """
        Rs = np.asarray(Rs).reshape(-1, 3, 3)
        if self.up is None:
            return np.ones(len(Rs), bool)
        q_up, g_up = self.up
        return (Rs @ q_up) @ g_up >= self.cos_min

    def keep(self, hyps: list) -> list:
        """
        Return the upright hypotheses.

        All of them when none is (a prior nothing satisfies, say a wrong up parameter, is ignored
        rather than answered with nothing).
        """
        ok = self.upright([h.R for h in hyps]) if hyps else np.zeros(0, bool)
        return [h for h, k in zip(hyps, ok) if k] or hyps
