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

"""The one object a query returns, shaped after Open3D's RegistrationResult."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np


@dataclass(frozen=True)
class PoseResult:
    """
    Which gallery object a cloud is, and where it is.

    The pose maps the gallery object's canonical frame into the query's frame:
    ``p_query = scale * rotation @ p_gallery + translation``.
    """

    gallery_id: str
    category: str
    rotation: np.ndarray          # (3, 3), proper rotation
    translation: np.ndarray       # (3,), in the query's units
    scale: float = 1.0            # query size / gallery object size
    score: float = 0.0            # fit after alignment in [0, 1], higher is better
    confidence: float = 0.0       # how likely the answer is right, in [0, 1]
    fitness: float = 0.0          # share of query points near the aligned gallery object
    inlier_rmse: float = float('inf')  # RMS distance of those points, query units
    # symmetric-free one-way chamfer, query -> gallery, normalised units
    chamfer: float = float('inf')
    rejected: bool = False
    reason: str = ''              # why it was rejected; empty when accepted
    candidates: tuple = ()        # retrieval top-k as ((gallery_id, distance), ...)
    # gallery objects of the same shape as the answer: no depth camera tells them apart
    twins: tuple = ()
    timings: dict = field(default_factory=dict)  # seconds per stage, plus "total"
    n_points: int = 0             # points used after cleaning and downsampling
    # share of a camera view's points set aside as lying apart from the object (strays.py)
    stray_share: float = 0.0
    # and, with up known, as the table's layer under it (support.py)
    table_share: float = 0.0

    @property
    def transform(self) -> np.ndarray:
        """4x4 homogeneous matrix of the pose (scale folded into the 3x3 block)."""
        T = np.eye(4)
        T[:3, :3] = self.scale * np.asarray(self.rotation)
        T[:3, 3] = self.translation
        return T

    @property
    def quaternion(self) -> np.ndarray:
        """(x, y, z, w), the order geometry_msgs/Quaternion uses."""
        from scipy.spatial.transform import Rotation

        return Rotation.from_matrix(np.asarray(self.rotation)).as_quat()

    def to_dict(self) -> dict:
        """Plain JSON-ready form."""
        return {
            'gallery_id': self.gallery_id,
            'category': self.category,
            'rotation': np.asarray(self.rotation).tolist(),
            'translation': np.asarray(self.translation).tolist(),
            'quaternion_xyzw': self.quaternion.tolist(),
            'scale': float(self.scale),
            'transform': self.transform.tolist(),
            'score': float(self.score),
            'confidence': float(self.confidence),
            'fitness': float(self.fitness),
            'inlier_rmse': float(self.inlier_rmse),
            'chamfer': float(self.chamfer),
            'rejected': bool(self.rejected),
            'reason': self.reason,
            'candidates': [[g, float(d)] for g, d in self.candidates],
            'twins': list(self.twins),
            'timings': {k: float(v) for k, v in self.timings.items()},
            'n_points': int(self.n_points),
            'stray_share': float(self.stray_share),
            'table_share': float(self.table_share),
        }
