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
Building a model: fit the unsupervised features on the gallery, then describe every object.

FR-PointHop's Saab kernels and the VLAD codebook are fitted on the gallery's own objects (no
labels), every object is described for retrieval, and when the objects come with meshes, what a
camera sees of each is worked out (instance/templates.py) and the confidence of view-by-view
answers is learnt on rendered views of them (instance/calibration.py).
"""
from __future__ import annotations

import dataclasses
import time

import numpy as np
from pcrp_core.config import PoseOptions
from pcrp_core.features import PointHop
from pcrp_core.gallery import Gallery
from pcrp_core.geometry import normalised, unit_axis
from pcrp_core.instance.templates import object_templates as render_templates
from pcrp_core.instance.templates import stack as stack_templates
from pcrp_core.instance.templates import Templates, TemplateSettings
from pcrp_core.parallel import parallel_map
from pcrp_core.preprocess import downsample, finite_points
from pcrp_core.visibility import sphere_directions, visible_from
from pcrp_core.vlad import VLAD


# -- one object each, in a worker process (parallel.py): module-level so that they pickle ---------
def object_features(state: dict, cloud: np.ndarray) -> np.ndarray:
    return state['pointhop'].transform(cloud)[1]


def object_mirror(state: dict, cloud: np.ndarray) -> np.ndarray:
    """Return the mirror plane of one normalised gallery cloud as 4 numbers (see mirror.py)."""
    from pcrp_core.registration.mirror import gallery_mirror, plane_row
    from scipy.spatial import cKDTree
    return plane_row(gallery_mirror(cloud, cKDTree(cloud), state['tolerance'], state['max_deg']))


def view_vectors(state: dict, cloud_and_cameras) -> list[np.ndarray]:
    """VLAD vectors of what a sensor at each camera position sees of the cloud."""
    cloud, cameras = cloud_and_cameras
    out = []
    for cam in cameras:
        seen = cloud[visible_from(cloud, cam)]
        if len(seen) >= 64:
            out.append(state['vlad'].transform(state['pointhop'].transform(seen, cam)[1]))
    return out


def object_templates(state: dict, mesh) -> dict:
    """Return what a camera sees of one gallery mesh (instance/templates.py)."""
    return render_templates(mesh, state['settings'], seed=state['seed'])


# -- the model's parts ----------------------------------------------------------------------------
@dataclasses.dataclass
class LearntParts:
    """What building learns from the gallery: PCRP's constructor arguments, and the meshes."""

    pointhop: PointHop
    vlad: VLAD
    gallery: Gallery
    unit: float
    meta: dict
    n_points: int
    templates: Templates | None
    meshes: list

    def model_arguments(self) -> dict:
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)
                if f.name != 'meshes'}


def common_up(objects) -> np.ndarray | None:
    """
    Return the up axis all objects' sources state.

    None when any is silent or they disagree (a mixed gallery has no one up axis to hold answers
    to).
    """
    ups = {
        tuple(np.round(unit_axis(o.up), 6)) if getattr(o, 'up', None) is not None else None
        for o in objects
    }
    return np.array(ups.pop()) if len(ups) == 1 and None not in ups else None


def mirror_planes(clouds, unit: float, n_jobs: int | None = None, progress=None) -> np.ndarray:
    """
    (n, 4) the mirror plane of each gallery cloud (as stored) in normalised units.

    NaN where none, with PoseOptions' default tolerances: worked out here once rather than by the
    first query that retrieves each object (a whole object's pose is finished on that plane).
    """
    pose = PoseOptions()
    rows = parallel_map(
        object_mirror,
        [normalised(c, unit) for c in clouds],
        {'tolerance': pose.mirror_tolerance, 'max_deg': pose.mirror_max_deg},
        n_jobs,
        progress,
        'mirror planes',
    )
    return np.stack(rows) if rows else np.zeros((0, 4))


def learn_parts(objects, *, hop1: str = 'fpfh', n_clusters: int = 10, aggregation: str = 'vlad',
                n_points: int = 1024, fit_clouds: int = 400, energy_threshold1: float = 1e-3,
                energy_threshold2: float = 5e-4, views: int = 0, seed: int = 0, sources=(),
                progress=None, n_jobs: int | None = None, up_axis=None) -> LearntParts:
    """
    Learn a model's parts from the pre-aligned gallery objects (PCRP.build assembles them).

    The objects are GalleryObject-like: gallery_id, category, points and optionally up and mesh.

    fit_clouds bounds how many objects the Saab kernels are fitted on (PCA needs far fewer
    samples than a large gallery has); views adds, per object, the descriptors of that many
    one-sided views seen from evenly spread directions (for galleries of clouds); progress wraps
    iterables (e.g. tqdm); n_jobs processes describe the objects (default: one per core; the
    result does not depend on it). up_axis: the objects' up axis in their own frame; by default
    the one their sources state when they all agree. When every object comes with its mesh (in
    metres), camera templates are made.
    """
    objects = list(objects)
    if not objects:
        raise ValueError('cannot build a model from an empty gallery')
    up_axis = common_up(objects) if up_axis is None else unit_axis(up_axis)
    clouds = [downsample(finite_points(o.points), n_points, seed) for o in objects]
    unit = float(np.median([np.linalg.norm(c - c.mean(0), axis=1).max() for c in clouds]))
    normed = [normalised(c, unit) for c in clouds]
    rng = np.random.default_rng(seed)
    fit_idx = rng.choice(len(normed), min(fit_clouds, len(normed)), replace=False)
    pointhop = PointHop(hop1=hop1, energy_threshold1=energy_threshold1,
                        energy_threshold2=energy_threshold2, random_state=seed)
    pointhop.fit([normed[i] for i in fit_idx])
    feats = parallel_map(
        object_features, normed, {'pointhop': pointhop}, n_jobs, progress, 'features'
    )
    vlad = VLAD(n_clusters=n_clusters, aggregation=aggregation, random_state=seed)
    if aggregation == 'vlad':
        vlad.fit(np.concatenate(feats))
    vectors = [vlad.transform(f) for f in feats]
    owners = list(range(len(objects)))
    if views:
        cameras = sphere_directions(views) * 3.0
        per_object = parallel_map(view_vectors, [(c, cameras) for c in normed],
                                  {'pointhop': pointhop, 'vlad': vlad}, n_jobs, progress, 'views')
        for i, vs in enumerate(per_object):
            vectors += vs
            owners += [i] * len(vs)
    stored = [c.astype(np.float32) for c in clouds]
    gallery = Gallery(
        [o.gallery_id for o in objects],
        [o.category for o in objects],
        stored,
        np.stack(vectors),
        np.array(owners),
        mirror_planes(stored, unit, n_jobs, progress),
    )
    templates, settings = None, TemplateSettings(view_points=n_points)
    meshes = [getattr(o, 'mesh', None) for o in objects]
    if all(m is not None for m in meshes):
        templates = stack_templates(
            parallel_map(
                object_templates,
                meshes,
                {'settings': settings, 'seed': seed},
                n_jobs,
                progress,
                'camera views',
            )
        )
    meta = {
        'sources': list(sources),
        'n_objects': len(objects),
        'n_points': n_points,
        'views': views,
        'up_axis': None if up_axis is None else [float(v) for v in up_axis],
        'feature_dim': int(pointhop.n_features_),
        'built': time.strftime('%Y-%m-%dT%H:%M:%S'),
        'templates': None if templates is None else dataclasses.asdict(settings),
    }
    return LearntParts(pointhop, vlad, gallery, unit, meta, n_points, templates, meshes)


def calibrate(model, meshes: list, n_jobs: int | None = None, progress=None) -> None:
    """
    Learn the confidence of the model's answers on views of its own gallery.

    Both paths: category/calibration.py, and instance/calibration.py when the model has camera
    templates (made when every gallery object came with its mesh: meshes, in gallery order).
    """
    if model.templates is not None:
        from pcrp_core.instance.calibration import calibrate as calibrate_views
        model.view_calibration, model.meta['twins'] = calibrate_views(
            model, meshes, n_jobs, progress
        )
    from pcrp_core.category.calibration import calibrate as calibrate_category
    model.category_calibration = calibrate_category(model, n_jobs, progress)
