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
The user's own objects: a folder of meshes or clouds.

One object per file, or a folder of sub-folders, one per category.

Meshes (OBJ, PLY with faces, STL, OFF) are sampled to points, area-uniformly; clouds (PLY
without faces, PCD, XYZ, NPY of shape (N, 3)) are used as they are. Objects are taken as
pre-aligned, in their own frame and units (metres, for a robot).
"""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import open3d as o3d

from pcrp_core.sources.camera import Mesh
from pcrp_core.sources.gallery_object import GalleryObject

MESH_SUFFIXES = {'.obj', '.stl', '.off', '.ply', '.gltf', '.glb'}
CLOUD_SUFFIXES = {'.ply', '.pcd', '.xyz', '.xyzn', '.pts', '.npy'}
log = logging.getLogger('pcrp.sources')


def read_points(path, n_points: int | None = None, seed: int = 0) -> np.ndarray:
    """
    Read (N, 3) float64 points of a cloud or mesh file.

    Meshes are sampled to n_points (default 2048).
    """
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise ValueError('no such file')
    if suffix not in MESH_SUFFIXES | CLOUD_SUFFIXES:
        raise ValueError(f'unsupported file type {suffix!r}')
    if suffix == '.npy':
        arr = np.load(path, allow_pickle=False)
        if arr.ndim != 2 or arr.shape[1] < 3:
            raise ValueError(f'expected an (N, 3) array, got shape {arr.shape}')
        if arr.shape[0] == 3 < arr.shape[1]:   # read as it is, three points of N coordinates
            raise ValueError(f'expected an (N, 3) array, got shape {arr.shape}: one point a row '
                             '(the transpose of this)')
        return arr[:, :3].astype(np.float64)
    if suffix in MESH_SUFFIXES:
        mesh = o3d.io.read_triangle_mesh(str(path))
        if len(mesh.triangles) > 0:
            o3d.utility.random.seed(seed)
            return np.asarray(mesh.sample_points_uniformly(n_points or 2048).points)
        if suffix not in CLOUD_SUFFIXES:
            raise ValueError('mesh has no triangles')
    pcd = o3d.io.read_point_cloud(str(path))
    pts = np.asarray(pcd.points)
    if len(pts) == 0:
        raise ValueError('no points could be read')
    return pts


def read_object(path, n_points: int, seed: int = 0) -> tuple[np.ndarray, Mesh | None]:
    """
    Read (points, mesh) of one file.

    A mesh is kept (a gallery renders what a camera sees of it) and sampled area-uniformly to 4 x
    n_points, which the build thins evenly; a cloud has no mesh.
    """
    path = Path(path)
    if path.suffix.lower() in MESH_SUFFIXES:
        mesh = o3d.io.read_triangle_mesh(str(path))
        if len(mesh.triangles) > 0:
            o3d.utility.random.seed(seed)
            points = np.asarray(mesh.sample_points_uniformly(4 * n_points).points)
            return points, Mesh(
                np.asarray(mesh.vertices, dtype=np.float64),
                np.asarray(mesh.triangles, dtype=np.int64),
            )
    return read_points(path, n_points, seed), None


def _usable(folder: Path) -> list[Path]:
    return sorted(
        p
        for p in folder.iterdir()
        if p.is_file() and p.suffix.lower() in MESH_SUFFIXES | CLOUD_SUFFIXES
    )


def load_folder(root, n_points: int = 1024, seed: int = 0, limit: int | None = None):
    """
    Load the objects of a folder.

    Every mesh or cloud directly in root is an object of its own (ID and category: the file's stem,
    `025_mug`); each sub-folder is a category of objects (ID `<category>/<file stem>`).
    """
    root = Path(root)
    groups = [(None, _usable(root))]
    groups += [(d.name, _usable(d)) for d in sorted(p for p in root.iterdir() if p.is_dir())]
    objects = []
    for category, files in groups:
        for f in files if category is None else files[:limit]:
            try:
                pts, mesh = read_object(f, n_points, seed)
            except (ValueError, OSError, RuntimeError) as e:
                log.warning('skipping %s: %s', f, e)
                continue
            if mesh is None and len(pts) > n_points:
                pts = pts[np.random.default_rng(seed).choice(len(pts), n_points, replace=False)]
            gallery_id = f.stem if category is None else f'{category}/{f.stem}'
            objects.append(
                GalleryObject(gallery_id, category or f.stem, pts.astype(np.float32), mesh=mesh)
            )
    if not objects:
        raise ValueError(
            f'{root}: nothing usable found (expected mesh or cloud files, one object each, or '
            f'sub-folders of them, one per category)'
        )
    return objects
