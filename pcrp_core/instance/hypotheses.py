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
Poses to try for one gallery object, before any is refined: from views, or upright turns.

Poses map the object's frame into the camera's: p_camera = R @ p_object + t.
"""
from __future__ import annotations

import numpy as np
from pcrp_core.geometry import rotation_taking
from pcrp_core.instance.signatures import ray_frame, shift_angle, shift_costs, signature
from scipy.spatial import cKDTree


def about(axis: np.ndarray, angles) -> np.ndarray:
    """(n, 3, 3) rotations by each angle (radians) about a unit axis."""
    K = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    angles = np.asarray(angles, dtype=np.float64)
    s, c = np.sin(angles)[:, None, None], np.cos(angles)[:, None, None]
    return np.eye(3)[None] + s * K[None] + (1.0 - c) * (K @ K)[None]


class QueryView:
    """The cloud as the view hypotheses see it: centroid, ray frame, silhouette signature."""

    def __init__(self, points: np.ndarray):
        self.points = points
        self.centre = points.mean(axis=0)
        # the optical frame's x axis gives the roll reference, as the rendering camera's did
        self.frame = ray_frame(self.centre, np.array([1.0, 0.0, 0.0]))
        self.signature = signature(points, self.frame, self.centre)


def from_views(
    query: QueryView, frames: np.ndarray, signatures: np.ndarray, view_centres: np.ndarray, n: int
):
    """
    Return poses from the n (view, roll) pairs whose silhouettes agree best with the query's.

    As poses (R (n, 3, 3), t (n, 3)): the view's ray frame laid on the query's, turned by the roll,
    its centroid on the query's. Returns R, t and each pose's view index.
    """
    cost = shift_costs(query.signature, signatures)
    best = np.argsort(cost.ravel())[:n]
    view, shift = np.divmod(best, cost.shape[1])
    roll = about(np.array([0.0, 0.0, 1.0]), shift_angle(shift))
    R = np.einsum('ji,hjk,hkl->hil', query.frame, roll, frames[view])
    t = query.centre - np.einsum('hij,hj->hi', R, view_centres[view])
    return R, t, view


def upright(query: QueryView, up_camera: np.ndarray, up_object: np.ndarray, cameras: np.ndarray,
            view_centres: np.ndarray, n: int):
    """
    Return poses keeping the object's up axis on the known up direction, turned about it.

    Turned every 360/n degrees about it (a yaw search: an object standing on a table is known but
    for its heading). Each pose's centroid is that of the stored view seen from nearest where the
    camera then stands.
    """
    R = about(up_camera, np.arange(n) * (2 * np.pi / n)) @ rotation_taking(up_object, up_camera)
    # where the camera stands, seen from the object: towards it from the query's centroid,
    # in the object's frame under each pose
    toward = np.einsum('hji,j->hi', R, -query.centre)
    view = np.argmax(toward @ (cameras - view_centres.mean(axis=0)).T, axis=1)
    t = query.centre - np.einsum('hij,hj->hi', R, view_centres[view])
    return R, t, view


def coarse_cost(
    R: np.ndarray,
    t: np.ndarray,
    view: np.ndarray,
    query_sample: np.ndarray,
    surface_tree: cKDTree,
    view_samples: np.ndarray,
    query_tree: cKDTree,
) -> np.ndarray:
    """
    Return a cheap cost per pose, (H,).

    The mean distance from a few query points to the object's surface, plus from a few points of
    the pose's view to the query. Both ways, because a part of the object that fits the query's
    points well can still show what the camera did not see.
    """
    back = np.einsum('hni,hij->hnj', query_sample[None] - t[:, None], R)
    to_surface = surface_tree.query(back.reshape(-1, 3))[0].reshape(len(R), -1).mean(axis=1)
    shown = np.einsum('hij,hnj->hni', R, view_samples[view]) + t[:, None]
    to_query = query_tree.query(shown.reshape(-1, 3))[0].reshape(len(R), -1).mean(axis=1)
    return to_surface + to_query
