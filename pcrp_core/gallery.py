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

"""The gallery: pre-aligned objects, their clouds and their global vectors, and the search."""
from __future__ import annotations

import numpy as np


class Gallery:

    def __init__(
        self,
        ids,
        categories,
        clouds,
        vectors: np.ndarray,
        owners: np.ndarray | None = None,
        mirrors: np.ndarray | None = None,
    ):
        """
        Hold the gallery's vectors.

        vectors: one per object, then optionally more per object (descriptors of one-sided views),
        owners[i] naming the object of vectors[i]. mirrors: each object's mirror plane in
        normalised units as registration/mirror.plane_row gives it, when worked out at build.
        """
        owners = np.arange(len(ids)) if owners is None else np.asarray(owners, dtype=np.int64)
        if not (len(ids) == len(categories) == len(clouds)) or len(owners) != len(vectors):
            raise ValueError('gallery ids, categories, clouds and vectors differ in length')
        if len(owners) and (owners.min() < 0 or owners.max() >= len(ids)):
            raise ValueError('gallery vector owners out of range')
        self.owners = owners
        if len(set(ids)) != len(ids):
            raise ValueError('gallery IDs must be unique')
        self.ids = list(ids)
        self.categories = list(categories)
        self.clouds = [np.asarray(c, dtype=np.float32) for c in clouds]
        self.vectors = np.asarray(vectors, dtype=np.float32)
        self.index = {g: i for i, g in enumerate(self.ids)}
        self._sq = (self.vectors ** 2).sum(1)
        self.mirrors = (
            None if mirrors is None else np.asarray(mirrors, dtype=np.float64).reshape(-1, 4)
        )
        if self.mirrors is not None and len(self.mirrors) != len(self.ids):
            raise ValueError('gallery mirror planes differ in number from the objects')

    def __len__(self) -> int:
        return len(self.ids)

    def search(self, vector: np.ndarray, k: int, exclude=None) -> tuple[np.ndarray, np.ndarray]:
        """
        Return indices and Euclidean distances of the k nearest objects, nearest first.

        Objects are ranked by their nearest stored vector. exclude: indices of objects not to
        return (as if the gallery lacked them, which is how a confidence is calibrated).

        Brute force: a matrix-vector product over even 10,000 objects costs well under a
        millisecond-scale budget, and is exact.
        """
        n = len(self) - (0 if exclude is None else len(set(exclude)))
        k = max(1, min(k, n))
        d2 = np.maximum(self._sq - 2.0 * self.vectors @ vector + float(vector @ vector), 0.0)
        per_object = np.full(len(self), np.inf)
        np.minimum.at(per_object, self.owners, d2)
        if exclude is not None:
            per_object[list(exclude)] = np.inf
        idx = np.argpartition(per_object, k - 1)[:k]
        # exact distances for the few kept: the expanded form above cancels badly near zero
        dist = np.array(
            [np.linalg.norm(self.vectors[self.owners == i] - vector, axis=1).min() for i in idx]
        )
        order = np.argsort(dist, kind='stable')
        return idx[order], dist[order]

    def to_arrays(self) -> dict:
        lengths = np.array([len(c) for c in self.clouds], dtype=np.int64)
        arrays = {
            'gallery_vectors': self.vectors,
            'gallery_vector_owners': self.owners,
            'gallery_points': (
                np.concatenate(self.clouds) if self.clouds else np.zeros((0, 3), np.float32)
            ),
            'gallery_lengths': lengths,
        }
        if self.mirrors is not None:
            arrays['gallery_mirrors'] = self.mirrors
        return arrays

    @classmethod
    def from_arrays(cls, ids, categories, arrays: dict) -> 'Gallery':
        ends = np.cumsum(arrays['gallery_lengths'])
        if len(ends) != len(ids) or (len(ends) and ends[-1] != len(arrays['gallery_points'])):
            raise ValueError('gallery clouds do not match the gallery IDs')
        clouds = np.split(arrays['gallery_points'], ends[:-1]) if len(ends) else []
        # models built before mirror planes were stored work them out as queries need them
        return cls(
            ids,
            categories,
            clouds,
            arrays['gallery_vectors'],
            arrays['gallery_vector_owners'],
            arrays.get('gallery_mirrors'),
        )
