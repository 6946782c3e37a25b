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

"""Shared test data: real ModelNet40 objects when the shared folder is there."""
from pathlib import Path

import numpy as np
from pcrp_core.geometry import rotation_angle_deg
from scipy.spatial.transform import Rotation

REPO = Path(__file__).resolve().parents[1]
MODELNET = REPO.parent / 'shared' / 'data' / 'modelnet40'
# the model shipped until the household gallery replaced it: 80 procedural airplanes, chairs,
# sofas and cars (point clouds, up z), built with `pcrp build procedural:20 --views 12`; the tests
# of the category path and of the node's handling of clouds use it
PROCEDURAL_MODEL = REPO / 'test' / 'data' / 'procedural_model'


def modelnet(category: str, split: str = 'train', count: int = 10, start: int = 0):
    with np.load(MODELNET / f'{category}.npz', allow_pickle=False) as d:
        return (d[f'{split}_points'][start:start + count].astype(np.float64),
                [str(n) for n in d[f'{split}_names'][start:start + count]])


def random_pose(rng):
    return Rotation.random(random_state=rng).as_matrix(), rng.uniform(-0.5, 0.5, 3)


rotation_error_deg = rotation_angle_deg
