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
How good pcrp is on the user's own meshes, as a robot's depth camera would see them.

`scenes` renders seeded, perfectly segmented depth-camera views of known meshes (free in space,
standing on a table, with or without an occluder); `metrics` holds the pose-error measures of the
YCB-Video and BOP benchmarks (ADD, ADD-S, its AUC); `run` answers every view with a model and
summarises the answers. `pcrp eval` is the command over these. Nothing here is imported by the rest
of the package, so the node does not pay for it.
"""
