"""What a robot's depth camera sees of an object: one side, with noise along the rays."""
from __future__ import annotations

import numpy as np
import open3d as o3d
from scipy.spatial.transform import Rotation


def random_rotation(rng: np.random.Generator) -> np.ndarray:
    """Uniform over all rotations."""
    return Rotation.random(random_state=rng).as_matrix()


def visible_from(points: np.ndarray, camera: np.ndarray) -> np.ndarray:
    """Indices of the points a camera at `camera` sees (Open3D's hidden point removal)."""
    pcd = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(points))
    diameter = np.linalg.norm(points.max(0) - points.min(0))
    _, idx = pcd.hidden_point_removal(camera, diameter * 100)
    return np.asarray(idx)


def partial_view(points: np.ndarray, rng: np.random.Generator, noise_sigma: float = 0.005,
                 min_keep: float = 0.25, distance: float = 3.0, tries: int = 10) -> np.ndarray:
    """The side of the object seen from a random direction at `distance` object radii, with
    Gaussian noise of noise_sigma (in object radii) along each viewing ray. Retries another
    direction when less than min_keep of the points would be seen."""
    centre = points.mean(0)
    radius = np.linalg.norm(points - centre, axis=1).max()
    for _ in range(tries):
        d = rng.normal(size=3)
        camera = centre + distance * radius * d / np.linalg.norm(d)
        idx = visible_from(points, camera)
        if len(idx) >= min_keep * len(points):
            break
    seen = points[idx]
    rays = seen - camera
    rays /= np.linalg.norm(rays, axis=1, keepdims=True)
    return (seen + rays * rng.normal(scale=noise_sigma * radius, size=(len(seen), 1))).astype(np.float32)


def crop_half_plane(points: np.ndarray, rng: np.random.Generator, keep: float = 0.7) -> np.ndarray:
    """The share `keep` of the points on one side of a plane of random direction (the paper's
    partial protocol)."""
    d = rng.normal(size=3)
    proj = (points - points.mean(0)) @ (d / np.linalg.norm(d))
    return points[proj <= np.quantile(proj, keep)]
