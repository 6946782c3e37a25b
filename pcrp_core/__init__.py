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
pcrp_core: PCRP object retrieval and pose estimation on plain numpy arrays.

No ROS here.

The names below are imported on first use, so `import pcrp_core` (and `pcrp --help`) does not
pay for Open3D and scikit-learn until a model is built or loaded.
"""
from __future__ import annotations

import importlib

_EXPORTS = {
    'PCRP': 'pcrp_core.pipeline',
    'default_model_path': 'pcrp_core.pipeline',
    'DepthImage': 'pcrp_core.instance.depth_image',
    'PoseResult': 'pcrp_core.result',
    'InvalidCloud': 'pcrp_core.errors',
    'ModelError': 'pcrp_core.errors',
}
__all__ = sorted(_EXPORTS)


def __getattr__(name):
    if name not in _EXPORTS:
        raise AttributeError(f"module 'pcrp_core' has no attribute {name!r}")
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    globals()[name] = value
    return value
