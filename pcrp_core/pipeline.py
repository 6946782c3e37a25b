"""PCRP: wires the stages together; load/save, retrieve, estimate. Holds no maths of its own."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from pcrp_core.result import PoseResult

DEFAULT_MODEL = Path(__file__).parent / "data" / "default_model"


def default_model_path() -> Path:
    """The small model shipped with the package, built from the procedural generator."""
    return DEFAULT_MODEL


class PCRP:
    """A gallery of pre-aligned objects and the unsupervised models fitted on it.

    Interface (stable; the node, the evaluation and the benchmarks call it):
      PCRP.load(path) -> PCRP            raises ModelError with a clear message
      model.save(path)
      model.estimate(points) -> PoseResult   raises InvalidCloud(reason, msg) on unusable input
      model.retrieve(points, k=10) -> [(gallery_id, distance), ...]
      model.gallery_ids -> list[str]; model.category_of(gid) -> str
      model.gallery_cloud(gid) -> (M, 3) float array in the gallery object's own frame and units
      model.min_points (int), model.max_points (int): inputs above max are downsampled
      model.n_candidates, model.min_score, model.refine: runtime options (settable attributes)
    """

    min_points = 32

    def __init__(self, *args, **kwargs):
        raise NotImplementedError("being written")
