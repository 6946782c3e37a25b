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
The category-level path.

Answering a cloud by retrieval and registration against a gallery of pre-aligned point clouds
(PCRP, with this package's extensions).

answer.py      the cloud described, the nearest gallery objects retrieved, the pose reported
registrar.py   the stages in order, and how much work each gets for whole clouds and views
prepared.py    a cloud ready to register (points, tree, features, symmetry halves)
hypothesis.py  a pose with its fit; distinct rotations
fitting.py     refine a pose on one gallery object by ICP and score it
seeding.py     the hypotheses each retrieved candidate contributes (generators: ../hypotheses.py)
upright.py     dropping hypotheses that tip the object when which way is up is known
vote.py        the candidates' vote on the rotation
refinement.py  the final ICP, averaging over agreeing candidates, the mirror-plane finish
evidence.py    what an answer says about itself; calibration.py the confidence learnt from it
frames.py      which way one gallery object is turned against another (for the calibration)
"""

from pcrp_core.category.prepared import prepare, Prepared
from pcrp_core.category.registrar import Registrar

__all__ = ['Prepared', 'prepare', 'Registrar']
