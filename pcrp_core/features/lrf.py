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
Local reference frames: one rotation per point, from the shape around it alone.

Axes come from PCA of the neighbourhood. Eigenvectors have no sign of their own, so each sign is
fixed by a rule that rotates with the cloud: the normal points away from the object's centroid (the
same rule FPFH normals follow) and the main axis points to where most neighbours lie. The third
axis completes a right-handed frame, so the frame is a proper rotation and mirror images are told
apart.
"""
from __future__ import annotations

import numpy as np


def local_frames(points: np.ndarray, centres: np.ndarray, neighbours: np.ndarray,
                 object_centre: np.ndarray, viewpoint: np.ndarray | None = None) -> np.ndarray:
    """
    (M, 3, 3) frames; rows are the x, y, z axes of each centre's frame.

    The normal axis points away from object_centre, or towards the sensor at viewpoint when given.
    """
    nb = points[neighbours]                               # (M, k, 3)
    offsets = nb - nb.mean(axis=1, keepdims=True)
    cov = offsets.transpose(0, 2, 1) @ offsets
    _, vecs = np.linalg.eigh(cov)                          # ascending eigenvalues, columns
    x = vecs[:, :, 2]
    z = vecs[:, :, 0]
    if viewpoint is None:
        outward = np.einsum('mi,mi->m', z, centres - object_centre)
    else:
        outward = np.einsum('mi,mi->m', z, viewpoint - centres)
    z = z * np.where(outward < 0, -1.0, 1.0)[:, None]
    rel = ((nb - centres[:, None, :]) @ x[:, :, None])[..., 0]
    votes = np.sign(rel).sum(axis=1)
    # a tie in the vote falls back on the third moment, which ties only on exact symmetry
    votes = np.where(votes == 0, (rel ** 3).sum(axis=1), votes)
    x = x * np.where(votes < 0, -1.0, 1.0)[:, None]
    y = np.cross(z, x)
    return np.stack([x, y, z], axis=1)
