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
PCRP's retrieval: FR-PointHop point features, one VLAD vector per cloud, nearest gallery objects.

Registration needs the retrieved objects' own point features; they are computed on demand and kept
in a bounded cache, since a stream sees the same few objects again and again.
"""
from __future__ import annotations

from collections import OrderedDict

import numpy as np
from pcrp_core.category.prepared import prepare, Prepared
from pcrp_core.config import PoseOptions
from pcrp_core.geometry import normalised
from pcrp_core.registration.mirror import plane_from_row
from pcrp_core.timing import Clock


def describe(pointhop, vlad, normed: np.ndarray, viewpoint=None, timings: dict | None = None):
    """Return (sampled indices, point features, VLAD vector) of a cloud in normalised units."""
    sampled, feats = pointhop.transform(normed, viewpoint, timings)
    clock = Clock(timings)
    vec = vlad.transform(feats)
    clock.lap('vlad')
    return sampled, feats, vec


class PreparedCache:
    """
    Registration-ready gallery objects, made on first use and kept, least recently used first out.

    Point features only for the objects that seed hypotheses; verifiers need just the cloud and its
    tree.
    """

    def __init__(self, pointhop, gallery, unit: float):
        self.pointhop, self.gallery, self.unit = pointhop, gallery, unit
        self._items: OrderedDict[tuple, Prepared] = OrderedDict()

    def get(self, i: int, features: bool, size: int) -> Prepared:
        key = (i, features)
        if key in self._items:
            self._items.move_to_end(key)
            return self._items[key]
        normed = normalised(self.gallery.clouds[i], self.unit)
        prep = prepare(normed, *self.pointhop.transform(normed)) if features else prepare(normed)
        if self.gallery.mirrors is not None:
            # worked out at build with the default settings: the key says which
            defaults = PoseOptions()
            prep.memo(('mirror', defaults.mirror_tolerance, defaults.mirror_max_deg),
                      lambda: plane_from_row(self.gallery.mirrors[i]))
        self._items[key] = prep
        while len(self._items) > size:
            self._items.popitem(last=False)
        return prep
