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
Seeded depth-camera views of known meshes: what a robot's camera measures of one object.

Each view is drawn from its own generator, seeded by (seed, object index, view index), so a view is
the same however many objects or views are drawn with it, and a subset run (a quick check, one
object) sees exactly the views of the full run. Three independent streams per view (pose, occluder,
range noise) make the occluded variant of a view the same pose as the unoccluded one whenever that
pose has pixels enough for both, so the two scenarios can be compared view by view.

Clouds are in the camera's optical frame (x right, y down, z forward, metres), perfectly segmented:
only the object's own pixels, as a mask from an ideal segmenter would give them. The table of
`table` scenes is never in the cloud and cannot hide the object (both lie above its plane, seen
from above it), so it is not rendered.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from pcrp_core.geometry import rotation_taking
from pcrp_core.instance.depth_image import DepthImage
from pcrp_core.sources.camera import depth_points, Mesh, PinholeCamera, RangeNoise, render_depth
from scipy.spatial.transform import Rotation

KINDS = ('free', 'table')
DISTANCE = (0.45, 0.9)  # metres from the camera to the object's centre: a tabletop arm's reach
ELEVATION_DEG = (25.0, 65.0)    # table scenes: how far the camera looks down
CENTRAL = 0.5  # the object's centre falls in the middle half of the image, both ways
OCCLUDED_SHARE = (0.2, 0.6)     # share of the object's pixels an occluder hides
MIN_PIXELS = 150  # fewer object pixels is not a view worth answering (a far golf ball)
POSE_TRIES = 200
OCCLUDER_TRIES = 60


@dataclass(frozen=True)
class Scene:
    """
    One view of one object.

    The pose maps the object's mesh frame into the optical frame, p_camera = R @ p_object + t, as a
    PoseResult does.
    """

    object_id: str
    R: np.ndarray               # (3, 3) object -> optical frame
    t: np.ndarray               # (3,) metres
    points: np.ndarray  # (N, 3) float32, the object's visible pixels as measured (range noise)
    up: np.ndarray | None       # the table's normal in the optical frame; None in free space
    distance: float  # metres from the camera to the object's centre (its bounding-box centre)
    kind: str                   # "free" or "table"
    occluded_share: float       # share of the object's pixels hidden by the occluder (0: none)
    seed: int
    view: int = 0
    object_index: int = 0
    # the occluder's pixels as measured (range noise), float32; None when nothing hides the object
    occluder: np.ndarray | None = None
    camera: PinholeCamera = PinholeCamera()     # the camera that measured them

    def depth_image(self) -> DepthImage:
        """
        Return what the camera measured, the object and any occluder, as a depth image.

        What a node given the camera's organized depth cloud answers with (pcrp_ros/scenes.py).
        """
        seen = self.points if self.occluder is None else np.vstack([self.points, self.occluder])
        cam = self.camera
        return DepthImage.from_points(seen, (cam.fx, cam.fy), (cam.cx, cam.cy),
                                      (cam.height, cam.width))

    @property
    def occluded(self) -> bool:
        return self.occluded_share > 0.0

    @property
    def scenario(self) -> str:
        return self.kind + ('_occluded' if self.occluded else '')


def view_rng(seed: int, object_index: int, view: int) -> tuple[np.random.Generator, ...]:
    """(pose, occluder, noise) generators of one view: independent streams of one SeedSequence."""
    ss = np.random.SeedSequence([int(seed), int(object_index), int(view)])
    return tuple(np.random.default_rng(s) for s in ss.spawn(3))


def _centre(mesh: Mesh) -> np.ndarray:
    return (mesh.vertices.min(0) + mesh.vertices.max(0)) / 2.0


def _central_ray(rng: np.random.Generator, camera: PinholeCamera) -> np.ndarray:
    """Return unit direction through a random pixel of the image's central part."""
    u = camera.cx + rng.uniform(-0.5, 0.5) * CENTRAL * camera.width
    v = camera.cy + rng.uniform(-0.5, 0.5) * CENTRAL * camera.height
    ray = np.array([(u - camera.cx) / camera.fx, (v - camera.cy) / camera.fy, 1.0])
    return ray / np.linalg.norm(ray)


def free_pose(mesh: Mesh, rng: np.random.Generator, camera: PinholeCamera = PinholeCamera()):
    """
    (R, t, up=None, distance).

    Any orientation (uniform over rotations), centre 0.45-0.9 m away along a ray through the
    central part of the image.
    """
    R = Rotation.random(random_state=rng).as_matrix()
    distance = rng.uniform(*DISTANCE)
    centre = distance * _central_ray(rng, camera)
    return R, centre - R @ _centre(mesh), None, float(distance)


def table_pose(mesh: Mesh, rng: np.random.Generator, camera: PinholeCamera = PinholeCamera()):
    """
    (R, t, up, distance).

    The mesh standing as it is modelled (z up) on its lowest point on a table, turned about the
    vertical at random, seen from 0.45-0.9 m by a level camera (no roll) looking down at 25-65
    degrees; the camera is then panned and tilted so the object's centre falls in the central part
    of the image, as when an arm points a wrist camera roughly at it. up is the table's normal in
    the optical frame.
    """
    lo, hi = mesh.vertices.min(0), mesh.vertices.max(0)
    yaw = rng.uniform(0.0, 2.0 * np.pi)
    Rz = Rotation.from_euler('z', yaw).as_matrix()
    # world frame: the table is z = 0, the object's bounding-box centre above the origin
    rest = np.array([(lo[0] + hi[0]) / 2, (lo[1] + hi[1]) / 2, lo[2]])
    target = np.array([0.0, 0.0, (hi[2] - lo[2]) / 2])
    elevation = np.radians(rng.uniform(*ELEVATION_DEG))
    distance = rng.uniform(*DISTANCE)
    eye = target + distance * np.array([0.0, -np.cos(elevation), np.sin(elevation)])
    forward = (target - eye) / distance
    right = np.cross(forward, [0.0, 0.0, 1.0])
    right /= np.linalg.norm(right)
    down = np.cross(forward, right)
    world_to_cam = np.stack([right, down, forward])
    # the least turn that brings the optical axis's point (the object's centre) to a central pixel
    aim = rotation_taking([0.0, 0.0, 1.0], _central_ray(rng, camera))
    Rc = aim @ world_to_cam
    R = Rc @ Rz
    t = Rc @ (-Rz @ rest - eye)
    return R, t, Rc @ np.array([0.0, 0.0, 1.0]), float(distance)


def _occluder(rng: np.random.Generator, depth: np.ndarray, mask: np.ndarray,
              camera: PinholeCamera, diameter: float) -> Mesh:
    """
    Return a box or cylinder between the camera and the object.

    Over a random one of its pixels, its apparent size drawn between a third of the object's and
    the object's own. It stays in front of the object's nearest point, so it hides without cutting
    into it.
    """
    import open3d as o3d

    v, u = np.nonzero(mask)
    i = rng.integers(len(v))
    z_near = float(depth[mask].min())
    z = z_near * rng.uniform(0.5, 0.85)
    size = rng.uniform(0.35, 1.0) * diameter * z / z_near
    if rng.random() < 0.5:
        w, h, d = size * rng.uniform(0.3, 1.0, 3)
        shape = o3d.geometry.TriangleMesh.create_box(w, h, d)
        shape.translate([-w / 2, -h / 2, -d / 2])
    else:
        shape = o3d.geometry.TriangleMesh.create_cylinder(
            radius=size * rng.uniform(0.15, 0.5),
            height=size * rng.uniform(0.5, 1.0),
            resolution=32,
        )
    verts = np.asarray(shape.vertices) @ Rotation.random(random_state=rng).as_matrix().T
    radius = float(np.linalg.norm(verts, axis=1).max())
    z = min(z, z_near - radius - 0.005)   # its far side before the object's near side
    if z - radius < 0.05:                 # too big to fit between: shrink it into the gap
        verts *= max(z_near - 0.06, 0.01) / 2 / radius
        radius = float(np.linalg.norm(verts, axis=1).max())
        z = z_near - radius - 0.005
    ray = np.array([(u[i] - camera.cx) / camera.fx, (v[i] - camera.cy) / camera.fy, 1.0])
    return Mesh(verts + ray * z, np.asarray(shape.triangles, dtype=np.int64))


def sample_scene(mesh: Mesh, object_id: str, object_index: int, view: int, kind: str = 'free',
                 occlusion: bool = False, seed: int = 0, camera: PinholeCamera = PinholeCamera(),
                 noise: RangeNoise | None = RangeNoise(), min_pixels: int = MIN_PIXELS) -> Scene:
    """
    One view of mesh (metres): posed by `kind`, optionally occluded, with range noise.

    Poses are redrawn until the object shows min_pixels pixels (after occlusion), occluders until
    they hide 20-60 % of them.
    """
    if kind not in KINDS:
        raise ValueError(f"kind {kind!r}: expected one of {', '.join(KINDS)}")
    pose_rng, occ_rng, noise_rng = view_rng(seed, object_index, view)
    draw = free_pose if kind == 'free' else table_pose
    diameter = mesh.diameter
    # an occluder hides at least the smallest share, so only a pose with that many more pixels can
    # keep min_pixels
    needed = min_pixels / (1.0 - OCCLUDED_SHARE[0]) if occlusion else min_pixels
    for _ in range(POSE_TRIES):
        R, t, up, distance = draw(mesh, pose_rng, camera)
        placed = mesh.moved(R, t)
        depth, owner = render_depth([placed], camera)
        mask = owner == 0
        n_all = int(mask.sum())
        if n_all < needed:
            continue
        share, occluder = 0.0, None
        if occlusion:
            for _ in range(OCCLUDER_TRIES):
                occ = _occluder(occ_rng, depth, mask, camera, diameter)
                d2, o2 = render_depth([placed, occ], camera)
                seen = o2 == 0
                share = 1.0 - seen.sum() / n_all
                if OCCLUDED_SHARE[0] <= share <= OCCLUDED_SHARE[1] and seen.sum() >= min_pixels:
                    occluder = depth_points(d2, camera, o2 == 1)
                    depth, mask = d2, seen
                    break
            else:
                continue
        points = depth_points(depth, camera, mask)
        if noise is not None:
            points = noise.apply(points, noise_rng)
            # after the object's, so its points are drawn as they were before occluders were kept
            if occluder is not None:
                occluder = noise.apply(occluder, noise_rng)
        return Scene(
            object_id,
            R,
            t,
            points.astype(np.float32),
            up,
            distance,
            kind,
            float(share),
            int(seed),
            int(view),
            int(object_index),
            None if occluder is None else occluder.astype(np.float32),
            camera,
        )
    raise RuntimeError(
        f'{object_id}: no {kind} view with {min_pixels} pixels in {POSE_TRIES} tries '
        f'(is the mesh in metres?)'
    )


def sample_scenes(
    meshes: dict[str, Mesh],
    views_per_object: int,
    kind: str = 'free',
    occlusion: bool = False,
    seed: int = 0,
    indices: dict[str, int] | None = None,
    progress=None,
    **kw,
) -> list[Scene]:
    """
    views_per_object views of every mesh.

    An object's index (its seed's second part) is its position in `meshes`, or indices[object_id]
    when a caller draws a subset of a larger gallery and wants the views the whole gallery would
    get.
    """
    jobs = [
        (oid, (indices or {}).get(oid, i), v)
        for i, oid in enumerate(meshes)
        for v in range(views_per_object)
    ]
    if progress is not None:
        jobs = progress(jobs, desc='views')
    return [
        sample_scene(meshes[oid], oid, i, v, kind, occlusion, seed, **kw) for oid, i, v in jobs
    ]
