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
A camera's depth frame as the image it is.

An organized depth cloud from a pinhole camera (what a driver's depth_image_proc publishes) holds
on pixel (u, v) the point z * ((u - cx) / fx, (v - cy) / fy, 1): its x and y say nothing its
depth and four numbers do not. Kept as depth and intrinsics, the part in reach of an object is a
slice and the nearest depth per cell a block minimum, where a list of points costs a pass over
every one of them (a 640 x 480 frame: 307,200) for each object.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

# pixels the intrinsics are fitted on; a pinhole fits them all to a small fraction of a pixel
FIT_SAMPLES = 4096
# the most a pixel may sit off the fitted pinhole, in pixels, for the cloud to be read as an image
MAX_RESIDUAL_PX = 0.05


@dataclass
class DepthImage:
    """Depth per pixel of a pinhole camera at the origin looking along +z."""

    z: np.ndarray          # (rows, columns) float32 metres; inf where nothing was measured
    focal: np.ndarray      # (2,) fx, fy in pixels
    centre: np.ndarray     # (2,) cx, cy: where the optical axis meets the image, in pixels

    def __post_init__(self):
        # drivers and users mark "no depth" with 0 or NaN as often as with inf; all of them
        # must hide nothing, where a 0 taken as a depth would hide everything behind it
        z = np.asarray(self.z)
        if z.ndim != 2 or not np.issubdtype(z.dtype, np.number):
            raise ValueError(f'DepthImage: expected (rows, columns) depths in metres, got '
                             f'{z.dtype} of shape {z.shape}')
        if np.issubdtype(z.dtype, np.integer):
            # a driver's 16UC1 image is millimetres: read as metres it is a wall 700 m away
            raise ValueError(f'DepthImage: depths are metres, got {z.dtype} (a 16UC1 depth '
                             'image is millimetres: give depth * 0.001)')
        z = z.astype(np.float32, copy=False)
        with np.errstate(invalid='ignore'):
            self.z = np.where(z > 0, z, np.float32(np.inf))
        self.focal = np.asarray(self.focal, dtype=np.float64).reshape(2)
        self.centre = np.asarray(self.centre, dtype=np.float64).reshape(2)
        if not (np.isfinite(self.focal).all() and (self.focal > 0).all()
                and np.isfinite(self.centre).all()):
            raise ValueError(f'DepthImage: focal lengths {self.focal.tolist()} must be positive '
                             f'and the centre {self.centre.tolist()} finite (pixels)')

    @classmethod
    def from_organized(cls, points: np.ndarray) -> DepthImage | None:
        """
        Return the image an organized cloud (rows, columns, 3) is, or None when it is not one.

        None unless every fitted pixel lies on one pinhole camera's ray through its centre (a
        cloud organized otherwise, as some lidars' rings are, stays a list of points).
        """
        z = points[..., 2]
        with np.errstate(invalid='ignore'):
            ok = np.isfinite(z) & (z > 1e-6)
        # the fit needs a few thousand pixels spread over the image, not all of them
        step = max(1, int(np.sqrt(z.size / (4 * FIT_SAMPLES))))
        rows, cols = np.nonzero(ok[::step, ::step])
        rows, cols = rows * step, cols * step
        if len(rows) < 16:
            return None
        pick = np.linspace(0, len(rows) - 1, min(FIT_SAMPLES, len(rows))).astype(np.int64)
        rows, cols = rows[pick], cols[pick]
        if np.ptp(rows) < 1 or np.ptp(cols) < 1:
            return None
        seen = points[rows, cols].astype(np.float64)
        if not np.isfinite(seen).all():
            return None
        rays = seen[:, :2] / seen[:, 2:3]
        focal, centre = np.zeros(2), np.zeros(2)
        for axis, pixel in enumerate((cols, rows)):
            A = np.column_stack([rays[:, axis], np.ones(len(pixel))])
            (f, c), *_ = np.linalg.lstsq(A, pixel.astype(np.float64), rcond=None)
            if not f > 0 or np.abs(A @ (f, c) - pixel).max() > MAX_RESIDUAL_PX:
                return None
            focal[axis], centre[axis] = f, c
        return cls(np.where(ok, z, np.inf).astype(np.float32), focal, centre)

    @classmethod
    def from_points(cls, points: np.ndarray, focal, centre, shape: tuple[int, int]) -> DepthImage:
        """
        Return the image of points a pinhole camera measured, the nearest on each pixel.

        Each point is taken to the pixel whose ray it is nearest (points a camera measured lie
        on them); those off the image of shape (rows, columns) are left out.
        """
        focal, centre = np.asarray(focal, dtype=np.float64), np.asarray(centre, dtype=np.float64)
        points = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        with np.errstate(invalid='ignore'):
            points = points[np.isfinite(points).all(axis=1) & (points[:, 2] > 1e-6)]
        pixel = np.rint(points[:, :2] / points[:, 2:3] * focal + centre).astype(np.int64)
        inside = ((pixel >= 0) & (pixel < (shape[1], shape[0]))).all(axis=1)
        z = np.full(shape, np.inf, dtype=np.float32)
        np.minimum.at(z, (pixel[inside, 1], pixel[inside, 0]), points[inside, 2])
        return cls(z, focal, centre)

    def crop(self, lo: np.ndarray, hi: np.ndarray, far: float) -> DepthImage:
        """
        Return the part on rays (x / z, y / z) from lo to hi, nearer than far; the rest inf.

        Pixels whose rays the window touches are kept (a window narrower than a pixel keeps it).
        """
        first = np.floor(lo * self.focal + self.centre + 0.5).astype(np.int64)
        last = np.floor(hi * self.focal + self.centre + 0.5).astype(np.int64)
        (c0, r0), (c1, r1) = np.maximum(first, 0), np.minimum(last + 1, self.z.shape[::-1])
        z = self.z[r0:max(r0, r1), c0:max(c0, c1)]
        return DepthImage(np.where(z < far, z, np.inf).astype(np.float32), self.focal,
                          self.centre - (c0, r0))

    def points(self) -> np.ndarray:
        """Return the measured points, (M, 3) float64, row by row."""
        rows, cols = np.nonzero(np.isfinite(self.z))
        z = self.z[rows, cols].astype(np.float64)
        pixels = np.column_stack([cols, rows])
        return np.column_stack([(pixels - self.centre) / self.focal * z[:, None], z])
