"""pcrp_core: PCRP object retrieval and pose estimation on plain numpy arrays. No ROS here.

The names below are imported on first use, so `import pcrp_core` (and `pcrp --help`) does not
pay for Open3D and scikit-learn until a model is built or loaded.
"""
from __future__ import annotations

import importlib

_EXPORTS = {
    "PCRP": "pcrp_core.pipeline",
    "default_model_path": "pcrp_core.pipeline",
    "PoseResult": "pcrp_core.result",
    "InvalidCloud": "pcrp_core.errors",
    "ModelError": "pcrp_core.errors",
}
__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'pcrp_core' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value
    return value
