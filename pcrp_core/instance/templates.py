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
What a depth camera can see of each gallery mesh, worked out once when the model is built.

Per object: surface points with outward normals (Poisson disk, so spacing is even), and from
directions all around the object, two things. Views: what a camera there measures (ray cast,
thinned as a query is), each kept as its line of sight, centroid, silhouette signature, shape
(the spread along its principal axes, in metres) and a few points. Visibility: which surface
points a camera in each of many directions sees, so a pose's expected view is looked up
instead of rendered. Arrays of all objects are stacked, so a model file stores them as is.
"""
from __future__ import annotations

from dataclasses import dataclass, fields

import numpy as np
from pcrp_core.instance.signatures import ray_frame, signature
from pcrp_core.preprocess import downsample
from pcrp_core.sources.camera import look_at, Mesh, MeshCamera, PinholeCamera
from pcrp_core.visibility import sphere_directions


def spread(points: np.ndarray) -> np.ndarray:
    """
    Return (3,) standard deviations along the principal axes, largest first.

    The size and shape of a cloud, whatever its pose.
    """
    centred = points - points.mean(axis=0)
    eig = np.linalg.eigvalsh(centred.T @ centred / max(len(points), 1))
    return np.sqrt(np.maximum(eig, 0.0))[::-1]


def extent(points: np.ndarray, share: float = 0.99) -> float:
    """
    Return the longest extent along the principal axes of the middle share of the points.

    A lower bound of the diameter of whatever the points lie on: no view shows more of an object
    than all of it. Percentiles rather than the ends, so that a few stray points at the edge of a
    segment do not stretch it.
    """
    centred = points - points.mean(axis=0)
    along = centred @ np.linalg.eigh(centred.T @ centred)[1]
    q = 50.0 * (1.0 - share)
    low, high = np.percentile(along, [q, 100.0 - q], axis=0)
    return float(np.max(high - low))


def shape_code(points: np.ndarray) -> np.ndarray:
    """
    Return the spread in log metres.

    Sizes are compared by ratio, so a 1 cm difference means more on a die than on a skillet.
    """
    return np.log(spread(points) + 1e-4)


@dataclass(frozen=True)
class TemplateSettings:
    """How templates are made; recorded in the model so queries are described alike."""

    views: int = 64                  # directions views are rendered from
    visibility_directions: int = 256  # directions visibility is worked out for
    surface_points: int = 2048       # surface points per object (Poisson disk)
    view_points: int = 1024          # a view is thinned to this many points, as a query is
    view_samples: int = 32           # points of each view kept for scoring hypotheses
    min_distance: float = 0.65       # metres from the object's centre; at least 2 diameters


@dataclass
class Templates:
    """Stacked per-object arrays (first axis: gallery object)."""

    points: np.ndarray          # (O, n, 3) surface points, object frame
    normals: np.ndarray         # (O, n, 3) outward unit normals
    spacing: np.ndarray         # (O,) typical distance between neighbouring surface points
    diameter: np.ndarray        # (O,)
    centre: np.ndarray          # (O, 3) centroid of the surface points
    visible: np.ndarray         # (O, D, n) bool: seen from visibility direction d
    cameras: np.ndarray         # (O, V, 3) where each view's camera stood, object frame
    view_centres: np.ndarray    # (O, V, 3) centroid of what it saw
    frames: np.ndarray          # (O, V, 3, 3) ray frame of each view
    signatures: np.ndarray      # (O, V, SECTORS, 2)
    shapes: np.ndarray          # (O, V, 3) shape_code of each view
    samples: np.ndarray         # (O, V, k, 3) a few points of each view

    def __len__(self) -> int:
        return len(self.points)

    @property
    def directions(self) -> np.ndarray:
        """(D, 3): the visibility directions, the same for every object."""
        return sphere_directions(self.visible.shape[1])

    def to_arrays(self, prefix: str = 'templates_') -> dict:
        out = {}
        for f in fields(self):
            value = getattr(self, f.name)
            if f.name == 'visible':
                out[prefix + 'visible_bits'] = np.packbits(value, axis=-1)
                out[prefix + 'visible_count'] = np.array(value.shape[-1])
            else:
                out[prefix + f.name] = value.astype(np.float32)
        return out

    @classmethod
    def from_arrays(cls, arrays: dict, prefix: str = 'templates_') -> 'Templates | None':
        """
        Return the templates stored in a model's arrays.

        None when the model has none (built from point clouds).
        """
        if prefix + 'points' not in arrays:
            return None
        n = int(arrays[prefix + 'visible_count'])
        values = {
            f.name: arrays[prefix + f.name].astype(np.float64)
            for f in fields(cls)
            if f.name != 'visible'
        }
        visible = np.unpackbits(arrays[prefix + 'visible_bits'], axis=-1, count=n).astype(bool)
        return cls(visible=visible, **values)

    def subset(self, keep) -> 'Templates':
        return Templates(**{f.name: getattr(self, f.name)[keep] for f in fields(self)})


def _surface(mesh: Mesh, n: int, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """
    Return n points spread evenly over the mesh (Poisson disk) and the normals of their faces.

    The normals of the faces they lie on, since interpolated vertex normals bend across the edges
    of a low-poly mesh, a box's.
    """
    import open3d as o3d

    m = o3d.geometry.TriangleMesh(o3d.utility.Vector3dVector(mesh.vertices),
                                  o3d.utility.Vector3iVector(mesh.triangles.astype(np.int32)))
    o3d.utility.random.seed(seed)
    points = np.asarray(m.sample_points_poisson_disk(n, init_factor=5).points)
    scene = o3d.t.geometry.RaycastingScene()
    scene.add_triangles(o3d.t.geometry.TriangleMesh.from_legacy(m))
    normals = scene.compute_closest_points(o3d.core.Tensor(points.astype(np.float32)))[
        'primitive_normals'
    ]
    return points, normals.numpy().astype(np.float64)


def object_templates(mesh: Mesh, settings: TemplateSettings = TemplateSettings(),
                     camera: PinholeCamera = PinholeCamera(), seed: int = 0) -> dict:
    """Return the templates of one mesh (in metres) as a dict of Templates' fields."""
    points, normals = _surface(mesh, settings.surface_points, seed)
    centre = points.mean(axis=0)
    diameter = mesh.diameter
    area = float(np.sum(np.linalg.norm(np.cross(
        mesh.vertices[mesh.triangles[:, 1]] - mesh.vertices[mesh.triangles[:, 0]],
        mesh.vertices[mesh.triangles[:, 2]] - mesh.vertices[mesh.triangles[:, 0]]), axis=1)) / 2)
    distance = max(settings.min_distance, 2.0 * diameter)
    renderer = MeshCamera(mesh, camera)
    visible = np.array([renderer.sees(centre + distance * d, points)
                        for d in sphere_directions(settings.visibility_directions)])
    rng = np.random.default_rng(seed)
    cams, centres, frames, sigs, shapes, samples = [], [], [], [], [], []
    for d in sphere_directions(settings.views):
        position = centre + distance * d
        R, t = look_at(position, centre)
        seen = renderer.view(R, t)
        if len(seen) < 3:   # nothing seen from there (cannot happen for a closed surface)
            seen = (
                points[visible[np.argmax(sphere_directions(settings.visibility_directions) @ d)]]
                @ R.T
                + t
            )
        # back into the object's frame
        seen = (downsample(seen, settings.view_points, seed) - t) @ R
        c = seen.mean(axis=0)
        frame = ray_frame(c - position, R[0])
        cams.append(position)
        centres.append(c)
        frames.append(frame)
        sigs.append(signature(seen, frame, c))
        shapes.append(shape_code(seen))
        samples.append(
            seen[
                rng.choice(
                    len(seen), settings.view_samples, replace=len(seen) < settings.view_samples
                )
            ]
        )
    return {'points': points, 'normals': normals, 'spacing': np.sqrt(area / len(points)),
            'diameter': diameter, 'centre': centre, 'visible': visible, 'cameras': np.array(cams),
            'view_centres': np.array(centres), 'frames': np.array(frames),
            'signatures': np.array(sigs), 'shapes': np.array(shapes), 'samples': np.array(samples)}


def stack(per_object: list[dict]) -> Templates:
    return Templates(
        **{
            f.name: np.stack([np.asarray(o[f.name]) for o in per_object])
            for f in fields(Templates)
        }
    )
