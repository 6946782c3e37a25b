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

"""Errors a caller can act on, each with a short machine-readable reason."""


class InvalidCloud(ValueError):
    """
    The input cannot be answered (too few finite points, degenerate geometry...).

    ``reason`` is a short stable key that the node counts rejections under: ``"bad_shape"``
    (not an (N, 3) numeric array), ``"empty"``, ``"no_finite_points"``, ``"too_few_points"``,
    ``"degenerate"`` (all points equal or on a line).
    """

    def __init__(self, reason: str, message: str):
        super().__init__(message)
        self.reason = reason


class ModelError(RuntimeError):
    """A model file is missing, truncated, tampered with or from another format version."""
