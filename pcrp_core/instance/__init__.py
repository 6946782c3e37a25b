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
Known objects seen by a depth camera: a gallery of meshes, one-sided views in metres.

When a model is built from meshes, what a camera can see of each object is worked out once
(templates.py): views rendered from all around, their silhouettes (signatures.py) and which
surface points each direction sees. A cloud from the camera is then matched by view: the
views whose silhouettes it resembles give poses to try (hypotheses.py), ICP refines the best
of them, and each refined pose is judged by how well the posed mesh explains the cloud and
the cloud covers what the mesh would show (verification.py). matcher.py wires the steps.
"""
