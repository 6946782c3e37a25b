"""The user's own objects: a folder with one sub-folder per category of meshes or clouds.

Meshes (OBJ, PLY with faces, STL, OFF) are sampled to points, area-uniformly; clouds (PLY
without faces, PCD, XYZ, NPY of shape (N, 3)) are used as they are. Objects are taken as
pre-aligned, in their own frame and units. Gallery IDs are `<category>/<file stem>`.
"""
from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
import open3d as o3d

MESH_SUFFIXES = {".obj", ".stl", ".off", ".ply", ".gltf", ".glb"}
CLOUD_SUFFIXES = {".ply", ".pcd", ".xyz", ".xyzn", ".pts", ".npy"}
log = logging.getLogger("pcrp.sources")


def read_points(path, n_points: int | None = None, seed: int = 0) -> np.ndarray:
    """(N, 3) float64 points of a cloud or mesh file; meshes are sampled to n_points (default 2048)."""
    path = Path(path)
    suffix = path.suffix.lower()
    if not path.is_file():
        raise ValueError("no such file")
    if suffix not in MESH_SUFFIXES | CLOUD_SUFFIXES:
        raise ValueError(f"unsupported file type {suffix!r}")
    if suffix == ".npy":
        arr = np.load(path, allow_pickle=False)
        if arr.ndim != 2 or arr.shape[1] < 3:
            raise ValueError(f"expected an (N, 3) array, got shape {arr.shape}")
        return arr[:, :3].astype(np.float64)
    if suffix in MESH_SUFFIXES:
        mesh = o3d.io.read_triangle_mesh(str(path))
        if len(mesh.triangles) > 0:
            o3d.utility.random.seed(seed)
            return np.asarray(mesh.sample_points_uniformly(n_points or 2048).points)
        if suffix not in CLOUD_SUFFIXES:
            raise ValueError("mesh has no triangles")
    pcd = o3d.io.read_point_cloud(str(path))
    pts = np.asarray(pcd.points)
    if len(pts) == 0:
        raise ValueError("no points could be read")
    return pts


def load_folder(root, n_points: int = 1024, seed: int = 0, limit: int | None = None):
    from pcrp_core.sources import GalleryObject

    root = Path(root)
    objects = []
    for cat_dir in sorted(p for p in root.iterdir() if p.is_dir()):
        files = sorted(p for p in cat_dir.iterdir() if p.is_file() and p.suffix.lower() in MESH_SUFFIXES | CLOUD_SUFFIXES)
        for f in files[:limit]:
            try:
                pts = read_points(f, n_points, seed)
            except (ValueError, OSError, RuntimeError) as e:
                log.warning("skipping %s: %s", f, e)
                continue
            if len(pts) > n_points:
                pts = pts[np.random.default_rng(seed).choice(len(pts), n_points, replace=False)]
            objects.append(GalleryObject(f"{cat_dir.name}/{f.stem}", cat_dir.name, pts.astype(np.float32)))
    if not objects:
        raise ValueError(f"{root}: nothing usable found (expected one sub-folder per category of meshes or clouds)")
    return objects
