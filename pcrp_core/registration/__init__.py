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
Registration.

Feature matches within symmetry halves, Procrustes in RANSAC, ICP, mirror planes, scoring.
"""

from pcrp_core.registration.icp import icp, icp_batch, icp_symmetric
from pcrp_core.registration.procrustes import procrustes, procrustes_batch
from pcrp_core.registration.ransac import ransac
from pcrp_core.registration.scoring import fit_quality, fit_quality_batch

__all__ = [
    'icp',
    'icp_batch',
    'icp_symmetric',
    'procrustes',
    'procrustes_batch',
    'ransac',
    'fit_quality',
    'fit_quality_batch',
]
