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

"""The eight octants of a local frame: where R-PointHop gathers a point's neighbourhood."""
from __future__ import annotations

import numpy as np


def _local(points, centres, neighbours, frames) -> np.ndarray:
    """(M, k, 3) neighbour offsets expressed in each centre's frame."""
    return (points[neighbours] - centres[:, None, :]) @ frames.transpose(0, 2, 1)


def _octant_mean(local: np.ndarray, values: np.ndarray) -> np.ndarray:
    """
    (M, 8, C) mean of values (M, k, C) per octant.

    An empty octant gives zeros, its emptiness being shape information in itself.
    """
    code = (local[..., 0] > 0) * 4 + (local[..., 1] > 0) * 2 + (local[..., 2] > 0)
    onehot = (code[..., None] == np.arange(8)).astype(values.dtype)   # (M, k, 8)
    sums = onehot.transpose(0, 2, 1) @ values
    return sums / np.maximum(onehot.sum(axis=1)[..., None], 1)


def octant_means(points, centres, neighbours, frames, attributes) -> np.ndarray:
    """(M, 8, C): mean attribute of the neighbours in each octant of each centre's frame."""
    return _octant_mean(_local(points, centres, neighbours, frames), attributes[neighbours])


def octant_coordinates(points, centres, neighbours, frames) -> np.ndarray:
    """(M, 24): R-PointHop's original first-hop attribute, mean local coordinates per octant."""
    local = _local(points, centres, neighbours, frames)
    return _octant_mean(local, local).reshape(len(centres), 24)
