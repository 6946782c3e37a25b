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
The units of a gallery's meshes.

A camera measures in metres, and the instance path compares sizes, so a gallery of meshes must be
in metres too. CAD tools often export millimetres: read as metres, a 10 cm can is 100 m across,
every view rendered from it is wrong and every real cloud is rejected, with nothing to say why.
So a mesh gallery whose largest object is larger than any a robot grasps is refused until its
scale is stated, and a stated scale is applied to every object and kept in the model.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from pcrp_core.sources.camera import Mesh
from pcrp_core.sources.gallery_object import GalleryObject

# metres across: furniture fits, and a gallery in centimetres or millimetres does not, since
# nearly every gallery holds something over 5 cm
MAX_OBJECT_METRES = 5.0
# and below this nothing a depth camera resolves (a few pixels at half a metre): an object in
# metres scaled as millimetres, in a folder of mixed units (the smallest YCB object, a die: 3 cm)
MIN_OBJECT_METRES = 0.005


def scaled(objects: list[GalleryObject], factor: float) -> list[GalleryObject]:
    """Return the objects with points and meshes multiplied by factor (0.001: mm to metres)."""
    return [
        replace(o, points=(o.points * factor).astype(np.float32),
                mesh=None if o.mesh is None else Mesh(o.mesh.vertices * factor, o.mesh.triangles))
        for o in objects
    ]


def _mesh_sizes(objects: list[GalleryObject]) -> list[tuple[float, str]]:
    """(diagonal of its bounding box, gallery ID) of each object with a mesh, smallest first."""
    return sorted((float(np.linalg.norm(np.ptp(o.points, axis=0))), o.gallery_id)
                  for o in objects if o.mesh is not None and len(o.points))


# what `pcrp build` can be told
BUILD_ADVICE = ('for meshes in millimetres give --scale 0.001 (centimetres: 0.01); if they really '
                'are that large, --scale 1')


def unit_problem(objects: list[GalleryObject], scale: float | None = None,
                 advice: str = BUILD_ADVICE) -> str:
    """
    Say why a mesh gallery does not look like metres ('' when it does), ending with advice.

    scale: the factor the objects were multiplied by (--scale), if one was given; then only a
    gallery of mixed units is a problem.
    """
    sizes = _mesh_sizes(objects)
    if not sizes:
        return ''
    (smallest, small_id), (largest, large_id) = sizes[0], sizes[-1]
    mixed = (f'{small_id} is {smallest:.3g} across and {large_id} {largest:.4g}: are the meshes '
             'in more than one unit? Every mesh is scaled alike')
    if scale is None and largest > MAX_OBJECT_METRES:
        if smallest * 0.001 < MIN_OBJECT_METRES:   # no one factor makes both of them metres
            return mixed
        return (f'the largest object, {large_id}, is {largest:.4g} across, and meshes are read as '
                f'metres: {advice}')
    if smallest < MIN_OBJECT_METRES:
        after = f' after a scale of {scale:g}' if scale is not None else ''
        return f'too small for a depth camera to see{after}: {mixed}'
    return ''
