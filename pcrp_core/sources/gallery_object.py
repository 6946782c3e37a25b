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

"""One object of a gallery as every source hands it over."""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from pcrp_core.sources.camera import Mesh


@dataclass(frozen=True)
class GalleryObject:
    gallery_id: str
    category: str
    points: np.ndarray   # (N, 3) float32, the object's own canonical frame and units
    up: str | None = None   # which canonical axis is up ("z", "-y", ...), when the source says
    # the surface, when the source is a mesh: what a camera's views are rendered from
    mesh: Mesh | None = None
