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

"""Shared test data: real ModelNet40 objects when the shared folder is there, a hidden cone."""
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
# what seeing the occluder adds to hidden_cone()'s confidence at least, in log-odds (a rise from
# 0.8 is worth more than the same rise from 0.5), with the shipped model: 0.80 -> 0.92 (+1.05;
# with the regression it had before trees, 0.51 -> 0.70, +0.81). Its hidden quarter is excused;
# being partly hidden, it is also looked for again by local shape, which sets it against other
# objects that fit too, where before it had no rival.
SURER = 0.5


def surer(confidence: float, without: float) -> bool:
    """Tell whether confidence is SURER in log-odds than the same answer's without a scene."""
    def log_odds(p):
        p = min(max(p, 1e-6), 1.0 - 1e-6)
        return np.log(p / (1.0 - p))
    return log_odds(confidence) > log_odds(without) + SURER


def modelnet(category: str, split: str = 'train', count: int = 10, start: int = 0):
    with np.load(MODELNET / f'{category}.npz', allow_pickle=False) as d:
        return (d[f'{split}_points'][start:start + count].astype(np.float64),
                [str(n) for n in d[f'{split}_names'][start:start + count]])


def hidden_cone():
    """Show the shipped gallery's cone to a camera, about a quarter hidden by an occluder."""
    from pcrp_core.evaluation.scenes import sample_scene
    from pcrp_core.sources import load_source

    cone = next(o for o in load_source('household', split='train') if o.gallery_id == 'cone')
    return sample_scene(cone.mesh, 'cone', 14, 1, 'free', occlusion=True, seed=1)


def random_pose(rng):
    return Rotation.random(random_state=rng).as_matrix(), rng.uniform(-0.5, 0.5, 3)


rotation_error_deg = rotation_angle_deg
