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
    mesh: Mesh | None = None   # the surface, when the source is a mesh: what a camera's views are rendered from
