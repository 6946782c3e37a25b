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
PCRP, the model a user holds: its parts, its settings, and which way a cloud is answered.

A cloud is cleaned (preprocess.py), then answered one of two ways: view by view against camera
templates when the gallery was built from meshes and the cloud comes from a camera at a known
viewpoint, in metres (instance/answer.py), else by PCRP's retrieval and registration
(category/). Building is build.py; the file format model_io.py.
"""
from __future__ import annotations

import copy
import dataclasses
from pathlib import Path
import time
import warnings

import numpy as np
from pcrp_core import model_io
from pcrp_core.confidence import (
    BoostedCalibration,
    Calibration,
    calibration_from_arrays,
    SplitCalibration,
)
from pcrp_core.config import (InstanceOptions, PoseOptions, QueryOptions, USER_INSTANCE_SETTINGS,
                              USER_POSE_SETTINGS)
from pcrp_core.errors import ModelError
from pcrp_core.features import PointHop
from pcrp_core.gallery import Gallery
from pcrp_core.geometry import normalised, rms_radius, unit_axis, unit_vector
from pcrp_core.instance.depth_image import DepthImage
from pcrp_core.instance.templates import Templates
from pcrp_core.preprocess import check_geometry, clean, screen, Screened, spread
from pcrp_core.result import PoseResult
from pcrp_core.retrieval import describe, PreparedCache
from pcrp_core.strays import strays
from pcrp_core.support import support
from pcrp_core.threads import threads_from_environment
from pcrp_core.vlad import VLAD

DEFAULT_MODEL = Path(__file__).parent / 'data' / 'default_model'
VIEW_CALIBRATION = 'confidence_views_'
CATEGORY_CALIBRATION = 'confidence_category_'
# galleries warm() prepares whole: a few seconds at most; a larger one prepares each object as a
# stream first meets it
WARM_OBJECTS = 100


def default_model_path() -> Path:
    """Return the small model shipped with the package, built from the procedural generator."""
    return DEFAULT_MODEL


class PCRP:
    """
    A gallery of pre-aligned objects and the unsupervised models fitted on it.

    Settings (pcrp_core.config): `options` (QueryOptions: what is done with each cloud),
    `pose_options` (PoseOptions: how PCRP registers) and `instance_options` (InstanceOptions:
    how known objects are matched view by view), all immutable; change them with `set_params`
    (this model) or `with_options` (a variant sharing this model's gallery and caches).
    """

    def __init__(
        self,
        pointhop: PointHop,
        vlad: VLAD,
        gallery: Gallery,
        unit: float,
        meta: dict | None = None,
        n_points: int = 1024,
        templates: Templates | None = None,
        view_calibration: Calibration | BoostedCalibration | None = None,
        category_calibration: Calibration | SplitCalibration | None = None,
    ):
        # a process told OMP_NUM_THREADS=1 (a worker, a benchmark) means Open3D too (threads.py)
        threads_from_environment()
        self.pointhop, self.vlad, self.gallery = pointhop, vlad, gallery
        self.templates, self.view_calibration = templates, view_calibration
        # the confidence of answers by retrieval and registration (category/calibration.py)
        self.category_calibration = category_calibration
        self.unit = float(unit)
        self.meta = dict(meta or {})
        self.n_points = int(n_points)
        self.options = QueryOptions(max_points=self.n_points)
        self.pose_options = PoseOptions()
        self.instance_options = InstanceOptions()
        self.prepared = PreparedCache(pointhop, gallery, self.unit)
        self._matcher = None
        self.radii = (
            np.array([rms_radius(c) for c in gallery.clouds]) if len(gallery) else np.zeros(0)
        )

    @classmethod
    def build(cls, objects, *, calibrate: bool = True, n_jobs: int | None = None, progress=None,
              **kwargs) -> 'PCRP':
        """
        Return a model of the gallery objects: see build.learn_parts for the arguments.

        With calibrate, the confidence of its answers is learnt on views of its own gallery.
        """
        from pcrp_core import build
        parts = build.learn_parts(objects, n_jobs=n_jobs, progress=progress, **kwargs)
        model = cls(**parts.model_arguments())
        if calibrate:
            build.calibrate(model, parts.meshes, n_jobs, progress)
        return model

    # -- settings -------------------------------------------------------------------------------
    def get_params(self) -> dict:
        """Return the user's settings (config.user_settings()) and their values."""
        return {**{k: getattr(self.options, k) for k in self.options.__dataclass_fields__},
                **{k: getattr(self.pose_options, k) for k in USER_POSE_SETTINGS},
                **{k: getattr(self.instance_options, k) for k in USER_INSTANCE_SETTINGS}}

    def _options_with(self, changes: dict) -> tuple[QueryOptions, PoseOptions, InstanceOptions]:
        changes = dict(changes)
        if 'min_score' in changes:
            warnings.warn(
                'min_score is now min_confidence (a calibrated probability that the answer is '
                'right); min_score is taken as min_confidence',
                DeprecationWarning,
                stacklevel=3,
            )
            changes.setdefault('min_confidence', changes.pop('min_score'))
            changes.pop('min_score', None)
        # every name a user may set, so that a mistyped one is told all of them
        known = {*QueryOptions.__dataclass_fields__, *USER_POSE_SETTINGS,
                 *InstanceOptions.__dataclass_fields__}
        unknown = sorted(set(changes) - known)
        if unknown:
            raise ValueError(f"unknown setting {', '.join(unknown)}; known: "
                             f"{', '.join(sorted(known))}")
        pose = {k: changes.pop(k) for k in list(changes) if k in USER_POSE_SETTINGS}
        instance = {
            k: changes.pop(k) for k in list(changes) if k in InstanceOptions.__dataclass_fields__
        }
        return (self.options.replace(**changes), self.pose_options.replace(**pose),
                self.instance_options.replace(**instance))

    def set_params(self, **changes) -> 'PCRP':
        """
        Change settings by name.

        Raise ValueError saying why for an unknown name or a bad value, and then nothing changes. A
        cloud being answered meanwhile keeps the settings it started with.
        """
        self.options, self.pose_options, self.instance_options = self._options_with(changes)
        return self

    def with_options(self, pose: PoseOptions | None = None, **changes) -> 'PCRP':
        """
        Return a variant of this model with other settings.

        Sharing its gallery, kernels and caches: pose replaces the pose settings wholesale (e.g.
        config.PAPER_POSE), changes set others (any setting of QueryOptions, PoseOptions or
        InstanceOptions, by name).
        """
        variant = copy.copy(self)
        if pose is not None:
            variant.pose_options = pose
        pose_changes = {k: changes.pop(k) for k in list(changes)
                        if k in PoseOptions.__dataclass_fields__ and k not in USER_POSE_SETTINGS}
        variant.pose_options = variant.pose_options.replace(**pose_changes)
        variant.options, variant.pose_options, variant.instance_options = variant._options_with(
            changes
        )
        return variant

    # -- gallery --------------------------------------------------------------------------------
    @property
    def gallery_ids(self) -> list[str]:
        return list(self.gallery.ids)

    @property
    def categories(self) -> list[str]:
        return sorted(set(self.gallery.categories))

    def category_of(self, gallery_id: str) -> str:
        return self.gallery.categories[self.gallery.index[gallery_id]]

    def gallery_cloud(self, gallery_id: str) -> np.ndarray:
        """Return the gallery object's points in its own canonical frame and units."""
        return self.gallery.clouds[self.gallery.index[gallery_id]]

    def subset(self, gallery_ids) -> 'PCRP':
        """
        Return the same kernels, codebook and calibration over part of the gallery.

        Part: one category, the objects a task can meet; answers then consider only those objects.
        """
        keep = sorted({self.gallery.index[g] for g in gallery_ids})
        if not keep:
            raise ValueError('a gallery subset needs at least one object')
        remap = np.full(len(self.gallery), -1)
        remap[keep] = np.arange(len(keep))
        rows = np.isin(self.gallery.owners, keep)
        g = self.gallery
        gallery = Gallery(
            [g.ids[i] for i in keep],
            [g.categories[i] for i in keep],
            [g.clouds[i] for i in keep],
            g.vectors[rows],
            remap[g.owners[rows]],
            None if g.mirrors is None else g.mirrors[keep],
        )
        templates = None if self.templates is None else self.templates.subset(keep)
        model = PCRP(
            self.pointhop,
            self.vlad,
            gallery,
            self.unit,
            self.meta,
            self.n_points,
            templates,
            self.view_calibration,
            self.category_calibration,
        )
        model.options, model.pose_options, model.instance_options = (
            self.options,
            self.pose_options,
            self.instance_options,
        )
        return model

    @property
    def up_axis(self) -> np.ndarray | None:
        """
        Return the gallery objects' up axis in their canonical frame (unit vector).

        None when the model does not say (models built before it was recorded, or from sources that
        disagree).
        """
        up = self.meta.get('up_axis')
        return None if up is None else np.asarray(up, dtype=np.float64)

    def check_up(self, up) -> np.ndarray:
        """
        Return up as estimate() uses it (a unit vector).

        Raise ValueError saying why it cannot be used: not a finite non-zero 3-vector, or a model
        that does not record its objects' up axis.
        """
        u = unit_vector(up)
        if u is None:
            raise ValueError(f'up must be a finite, non-zero 3-vector, not {up!r}')
        if self.up_axis is None:
            raise ValueError("this model does not record its objects' up axis; rebuild it with "
                             '`pcrp build --up-axis` to use an up direction')
        return u

    def size_report(self) -> str:
        """Bytes of each part as stored (uncompressed float32), for comparing with the paper."""
        kernels = sum(v.nbytes for v in self.pointhop.get_state().values())
        codebook = self.vlad.codebook_.nbytes if self.vlad.aggregation == 'vlad' else 0
        clouds = sum(c.nbytes for c in self.gallery.clouds)
        text = (
            f'kernels {kernels / 1e3:.0f} kB, codebook + VLAD vectors '
            f'{(codebook + self.gallery.vectors.nbytes) / 1e6:.2f} MB, gallery clouds '
            f'{clouds / 1e6:.1f} MB'
        )
        if self.templates is not None:
            size = sum(v.nbytes for v in self.templates.to_arrays().values())
            text += f', camera templates {size / 1e6:.1f} MB'
        return text

    # -- files ----------------------------------------------------------------------------------
    def save(self, path) -> Path:
        arrays = {**self.pointhop.get_state(), **self.gallery.to_arrays()}
        if self.templates is not None:
            arrays.update(self.templates.to_arrays())
        if self.view_calibration is not None:
            arrays.update(self.view_calibration.to_arrays(VIEW_CALIBRATION))
        if self.category_calibration is not None:
            arrays.update(self.category_calibration.to_arrays(CATEGORY_CALIBRATION))
        if self.vlad.aggregation == 'vlad':
            arrays['vlad_codebook'] = self.vlad.codebook_
        meta = {**self.meta, 'unit': self.unit, 'n_points': self.n_points,
                'pointhop': self.pointhop.get_params(),
                'vlad': {'n_clusters': self.vlad.n_clusters, 'aggregation': self.vlad.aggregation},
                'gallery_ids': self.gallery.ids, 'gallery_categories': self.gallery.categories}
        meta.pop('path', None)
        return model_io.write_model(path, meta, arrays)

    @classmethod
    def load(cls, path=None) -> 'PCRP':
        path = Path(path) if path else DEFAULT_MODEL
        meta, arrays = model_io.read_model(path)
        try:
            pointhop = PointHop.from_state(meta['pointhop'], arrays)
            vlad = VLAD(
                n_clusters=meta['vlad']['n_clusters'], aggregation=meta['vlad']['aggregation']
            )
            if vlad.aggregation == 'vlad':
                vlad.codebook_ = arrays['vlad_codebook']
            gallery = Gallery.from_arrays(meta['gallery_ids'], meta['gallery_categories'], arrays)
            if meta.get('up_axis') is not None:
                meta['up_axis'] = [float(v) for v in unit_axis(meta['up_axis'])]
            templates = Templates.from_arrays(arrays)
            if templates is not None and len(templates) != len(gallery):
                raise ValueError('camera templates do not match the gallery')
            model = cls(pointhop, vlad, gallery, meta['unit'], meta, meta['n_points'], templates,
                        calibration_from_arrays(arrays, VIEW_CALIBRATION),
                        calibration_from_arrays(arrays, CATEGORY_CALIBRATION))
        except (KeyError, TypeError, ValueError) as e:
            raise ModelError(
                f'{path}: model contents are incomplete or inconsistent ({type(e).__name__}: {e})'
            ) from None
        model.meta['path'] = str(path)
        return model

    # -- querying -------------------------------------------------------------------------------
    def prepare(self, points, viewpoint=None, up=None) -> np.ndarray:
        """
        Return the cloud as estimate(points, viewpoint, up) will use it.

        Finite, at most max_points, checked for geometry a pose can be read from (raises
        InvalidCloud otherwise); a cloud matched view by view has its strays set aside first
        (the setting drop_strays, pcrp_core/strays.py), and with up known the table under it
        (drop_support, pcrp_core/support.py).
        """
        up = None if up is None else self.check_up(up)
        return self._prepared(points, _checked_viewpoint(viewpoint), self.options, up)[0]

    def _prepared(
        self, points, viewpoint, opts: QueryOptions, up=None
    ) -> tuple[np.ndarray, float, float, float | None]:
        """
        Return prepare()'s cloud, the shares of the screened points set aside, and the floor.

        The shares: as strays, and as the table's layer; the floor: the height along up under which
        the table's layer was set aside (None if it was not).
        """
        n = min(opts.max_points, self.n_points)
        settings = self.instance_options
        by_views = self.uses_views(viewpoint, opts)
        cut_support = by_views and settings.drop_support and up is not None
        if not (cut_support or by_views and settings.drop_strays):
            return clean(points, n, opts.min_points, opts.seed), 0.0, 0.0, None
        if not isinstance(points, Screened):
            points = screen(points, n, opts.min_points, opts.seed)
        cloud = points.points
        # the table first: what is left of it beyond the object's outline then lies apart
        table, floor = support(cloud, up) if cut_support else (np.zeros(len(cloud), bool), None)
        apart = np.zeros(len(cloud), dtype=bool)
        if settings.drop_strays:
            apart[~table] = strays(cloud[~table], float(self.templates.diameter.max()))
        if apart.any() or table.any():
            cloud = cloud[~(apart | table)]
            check_geometry(cloud, opts.min_points)
        return spread(cloud, n), float(apart.mean()), float(table.mean()), floor

    def screen(self, points) -> Screened:
        """
        Refuse a cloud prepare() would refuse, for a fraction of its cost; else thin and mark it.

        For a stream to call on every cloud as it arrives: bad clouds are refused at once and
        only usable ones queued, and the farthest-point sampling (most of prepare's cost) is
        left to estimate(), paid only for the clouds answered; estimate() does not check a
        Screened cloud again. estimate() of what this returns is estimate() of the cloud.
        """
        opts = self.options
        return screen(points, min(opts.max_points, self.n_points), opts.min_points, opts.seed)

    def retrieve(self, points, k: int = 10, viewpoint=None) -> list[tuple[str, float]]:
        """
        Return the k gallery objects whose VLAD vectors are nearest the query's.

        With their distances.
        """
        pts = self.prepare(points)
        vp = None if viewpoint is None else normalised(viewpoint, self.unit, pts.mean(0))
        _, _, vec = describe(self.pointhop, self.vlad, normalised(pts, self.unit), vp)
        idx, dist = self.gallery.search(vec, k)
        return [(self.gallery.ids[i], float(d)) for i, d in zip(idx, dist)]

    def uses_views(self, viewpoint, opts: QueryOptions | None = None) -> bool:
        """
        Whether a cloud is matched view by view (instance/).

        The model has templates (built from meshes), the cloud comes from a sensor at a known
        viewpoint, sizes are metric, and the method setting allows it.
        """
        opts = self.options if opts is None else opts
        return (self.templates is not None and viewpoint is not None and opts.method != 'pcrp'
                and opts.scale_mode == 'metric')

    def scene_in_reach(self, points, scene, viewpoint):
        """
        Return the part of scene that estimate(points, viewpoint, scene=...) can use.

        scene: (M, 3) points, returned as (K, 3) floats, or a DepthImage, returned cropped. None
        when it uses none (the cloud is not answered view by view). A caller that queues or ships
        clouds (the node) keeps this instead of a whole depth cloud.
        """
        if not self.uses_views(viewpoint):
            return None
        from pcrp_core.instance.occlusion import in_reach, seen_from

        vp = np.asarray(viewpoint, dtype=np.float64)
        pts = np.asarray(points, dtype=np.float64).reshape(-1, 3)
        pts = pts[np.isfinite(pts).all(axis=1)] - vp
        if not len(pts) or pts[:, 2].min() <= 0:
            return None
        cut = in_reach(seen_from(scene, vp), pts, float(self.templates.diameter.max()))
        return cut if isinstance(cut, DepthImage) else cut + vp

    def warm(self) -> 'PCRP':
        """
        Make now what the first clouds would otherwise wait for, in a gallery of camera templates.

        Each object's ICP surface and local-shape features, when the gallery has at most
        WARM_OBJECTS objects: made on first use, they would cost the first poorly fitting cloud
        about 30 ms an object, which a node at sensor rate cannot give. Nothing when the
        settings never match view by view (method pcrp, or scale_mode normalize).
        """
        if self.uses_views(np.zeros(3)) and len(self.templates) <= WARM_OBJECTS:
            self.matcher.warm(self.instance_options)
        return self

    @property
    def matcher(self):
        """Return the view-by-view matcher of this model's templates, made on first use."""
        if self._matcher is None:
            from pcrp_core.instance.matcher import InstanceMatcher
            self._matcher = InstanceMatcher(self.templates)
        return self._matcher

    def estimate(self, points, viewpoint=None, up=None, scene=None) -> PoseResult:
        """
        Which gallery object the cloud is, and its pose.

        Raises InvalidCloud for a cloud no pose can be read from, and ValueError, saying what is
        expected, for a viewpoint, up or scene that cannot be one.

        viewpoint: the sensor's position in the cloud's frame when the cloud is what one sensor saw
        (np.zeros(3) for a cloud in the camera's own frame); None for complete objects. up: which
        way is up in the cloud's frame (against gravity), when the caller knows it; the search
        for a pose then keeps the gallery's up axis (`up_axis`) on it, and refinement follows the
        cloud (docs/method.md). None: any orientation. scene: (M, 3) the rest
        of what the sensor measured, in the cloud's frame (its whole depth cloud will do: NaNs, the
        object's own points and the background are fine), or its DepthImage (faster: an organized
        depth cloud read with DepthImage.from_organized), so that surface something in front of
        the object hid is not taken for missing; used when the cloud is answered view by view.
        A cloud answered view by view first has the points lying apart from the object set aside
        (instance setting drop_strays; the result's stray_share says how many), and with up known
        the table's layer under it (drop_support; table_share).
        """
        from pcrp_core.category import answer as category
        from pcrp_core.instance import answer as views

        t0 = time.perf_counter()
        # one snapshot of the settings, so a change made meanwhile (a node's parameter) never
        # mixes into a cloud already being answered
        opts, pose_opts = self.options, self.pose_options
        up_pair = None if up is None else (self.check_up(up), self.up_axis)
        viewpoint, scene = _checked_viewpoint(viewpoint), _checked_scene(scene)
        pts, stray_share, table_share, floor = self._prepared(
            points, viewpoint, opts, None if up_pair is None else up_pair[0]
        )
        timings = {'preprocess': time.perf_counter() - t0}
        if self.uses_views(viewpoint, opts):
            return dataclasses.replace(views.answer(
                self, pts, np.asarray(viewpoint, dtype=np.float64), up_pair, opts, timings, t0,
                scene, floor,
            ), stray_share=stray_share, table_share=table_share)
        return category.answer(self, pts, viewpoint, up_pair, opts, pose_opts, timings, t0)


def _checked_viewpoint(viewpoint) -> np.ndarray | None:
    """Return viewpoint as three floats; ValueError, saying what is expected, if it is not."""
    if viewpoint is None:
        return None
    try:
        v = np.asarray(viewpoint, dtype=np.float64)
    except (TypeError, ValueError):
        v = np.empty(0)
    if v.shape != (3,) or not np.isfinite(v).all():
        raise ValueError(f"viewpoint {viewpoint!r}: expected three finite numbers, the sensor's "
                         "position in the cloud's frame ([0, 0, 0] in the camera's own frame)")
    return v


def _checked_scene(scene):
    """Return scene unchanged if it is a DepthImage or numeric points; ValueError if not."""
    if scene is None or isinstance(scene, DepthImage):
        return scene
    arr = np.asarray(scene)
    if not np.issubdtype(arr.dtype, np.number) or arr.ndim < 2 or arr.shape[-1] != 3:
        raise ValueError(f"scene: expected a DepthImage or (M, 3) points in the cloud's frame, "
                         f'got {type(scene).__name__} of shape {arr.shape}')
    return scene
