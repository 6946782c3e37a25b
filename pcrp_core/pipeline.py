"""PCRP: wires the stages together; build, load/save, retrieve, estimate. Holds no maths of its own.

Units. Gallery objects keep their own frame and units. Internally every cloud is centred on
its centroid and divided by one model-wide unit (the gallery's median object radius), so the
features' radii mean the same for every object. A query is taken to be in the gallery's units
(scale_mode="metric", the robot case: meshes and depth camera both in metres) and reported with
scale 1; with scale_mode="normalize" its size is unknown, it is rescaled to each candidate's
size and the reported scale is query size / gallery object size (complete objects only: a
one-sided view looks smaller than the object).
"""
from __future__ import annotations

import copy
import time
import warnings
from collections import OrderedDict
from pathlib import Path

import numpy as np

from pcrp_core import model_io
from pcrp_core.errors import InvalidCloud, ModelError
from pcrp_core.parallel import object_features, parallel_map, view_vectors
from pcrp_core.timing import Clock
from pcrp_core.features import PointHop
from pcrp_core.gallery import Gallery
from pcrp_core.config import USER_POSE_SETTINGS, PoseOptions, QueryOptions
from pcrp_core.pose import Prepared, Registrar, prepare
from pcrp_core.preprocess import check_geometry, downsample, finite_points
from pcrp_core.result import PoseResult
from pcrp_core.visibility import sphere_directions
from pcrp_core.vlad import VLAD

DEFAULT_MODEL = Path(__file__).parent / "data" / "default_model"


def default_model_path() -> Path:
    """The small model shipped with the package, built from the procedural generator."""
    return DEFAULT_MODEL


AXES = {"x": (1.0, 0.0, 0.0), "y": (0.0, 1.0, 0.0), "z": (0.0, 0.0, 1.0)}


def _unit_vector(v) -> np.ndarray | None:
    """v scaled to length 1, None unless it is a finite, non-zero 3-vector."""
    v = np.asarray(v, dtype=np.float64).reshape(-1)
    n = float(np.linalg.norm(v)) if v.shape == (3,) and np.all(np.isfinite(v)) else 0.0
    return v / n if n >= 1e-9 else None


def _unit_axis(axis) -> np.ndarray:
    """A unit vector from "x", "-z", ... or three numbers; ValueError otherwise."""
    if isinstance(axis, str):
        name = axis.strip().lower()
        sign = -1.0 if name.startswith("-") else 1.0
        if name.lstrip("+-") not in AXES:
            raise ValueError(f"up axis {axis!r}: expected x, y, z, -x, -y or -z")
        return sign * np.array(AXES[name.lstrip("+-")])
    v = _unit_vector(axis)
    if v is None:
        raise ValueError(f"up axis {axis!r}: expected a finite, non-zero 3-vector")
    return v


def _common_up(objects) -> np.ndarray | None:
    """The up axis all objects' sources state, None when any is silent or they disagree (a
    mixed gallery has no one up axis to hold answers to)."""
    ups = {tuple(np.round(_unit_axis(o.up), 6)) if getattr(o, "up", None) is not None else None for o in objects}
    return np.array(ups.pop()) if len(ups) == 1 and None not in ups else None


def _rms_radius(points: np.ndarray) -> float:
    return float(np.sqrt(((points - points.mean(0)) ** 2).sum(1).mean()))


class PCRP:
    """A gallery of pre-aligned objects and the unsupervised models fitted on it.

    Settings (pcrp_core.config): `options` (QueryOptions: what is done with each cloud) and
    `pose_options` (PoseOptions: how poses are found), both immutable; change them with
    `set_params` (this model) or `with_options` (a variant sharing this model's gallery).
    """

    def __init__(self, pointhop: PointHop, vlad: VLAD, gallery: Gallery, unit: float, meta: dict | None = None,
                 n_points: int = 1024):
        self.pointhop = pointhop
        self.vlad = vlad
        self.gallery = gallery
        self.unit = float(unit)
        self.meta = dict(meta or {})
        self.n_points = int(n_points)
        self.options = QueryOptions(max_points=self.n_points)
        self.pose_options = PoseOptions()
        self._cache: OrderedDict[tuple, Prepared] = OrderedDict()
        self._radii = np.array([_rms_radius(c) for c in gallery.clouds]) if len(gallery) else np.zeros(0)

    # -- settings -------------------------------------------------------------------------------
    def get_params(self) -> dict:
        """The user's settings (QueryOptions and USER_POSE_SETTINGS) and their values."""
        return {**{k: getattr(self.options, k) for k in self.options.__dataclass_fields__},
                **{k: getattr(self.pose_options, k) for k in USER_POSE_SETTINGS}}

    def _options_with(self, changes: dict) -> tuple[QueryOptions, PoseOptions]:
        changes = dict(changes)
        if "min_score" in changes:
            warnings.warn("min_score is now min_confidence (a calibrated probability that the answer is right); "
                          "min_score is taken as min_confidence", DeprecationWarning, stacklevel=3)
            changes.setdefault("min_confidence", changes.pop("min_score"))
            changes.pop("min_score", None)
        pose = {k: changes.pop(k) for k in list(changes) if k in USER_POSE_SETTINGS}
        return self.options.replace(**changes), self.pose_options.replace(**pose)

    def set_params(self, **changes) -> "PCRP":
        """Change settings by name (ValueError saying why for an unknown name or a bad value, and
        then nothing changes). A cloud being answered meanwhile keeps the settings it started with."""
        self.options, self.pose_options = self._options_with(changes)
        return self

    def with_options(self, pose: PoseOptions | None = None, **changes) -> "PCRP":
        """A variant of this model with other settings, sharing its gallery, kernels and cache:
        pose replaces the pose settings wholesale (e.g. config.PAPER_POSE), changes set others."""
        variant = copy.copy(self)
        if pose is not None:
            variant.pose_options = pose
        variant.options, variant.pose_options = variant._options_with(changes)
        return variant

    # -- gallery access -------------------------------------------------------------------------
    @property
    def gallery_ids(self) -> list[str]:
        return list(self.gallery.ids)

    @property
    def categories(self) -> list[str]:
        return sorted(set(self.gallery.categories))

    def category_of(self, gallery_id: str) -> str:
        return self.gallery.categories[self.gallery.index[gallery_id]]

    def gallery_cloud(self, gallery_id: str) -> np.ndarray:
        """The gallery object's points in its own canonical frame and units."""
        return self.gallery.clouds[self.gallery.index[gallery_id]]

    def subset(self, gallery_ids) -> "PCRP":
        """The same kernels and codebook over part of the gallery (one category, the objects a
        task can meet): retrieval and verification then consider only those objects."""
        keep = sorted({self.gallery.index[g] for g in gallery_ids})
        if not keep:
            raise ValueError("a gallery subset needs at least one object")
        remap = np.full(len(self.gallery), -1)
        remap[keep] = np.arange(len(keep))
        rows = np.isin(self.gallery.owners, keep)
        g = self.gallery
        gallery = Gallery([g.ids[i] for i in keep], [g.categories[i] for i in keep], [g.clouds[i] for i in keep],
                          g.vectors[rows], remap[g.owners[rows]])
        model = PCRP(self.pointhop, self.vlad, gallery, self.unit, self.meta, self.n_points)
        model.options, model.pose_options = self.options, self.pose_options
        return model

    # -- building -------------------------------------------------------------------------------
    @classmethod
    def build(cls, objects, *, hop1: str = "fpfh", n_clusters: int = 10, aggregation: str = "vlad",
              n_points: int = 1024, fit_clouds: int = 400, energy_threshold1: float = 1e-3,
              energy_threshold2: float = 5e-4, views: int = 0, seed: int = 0, sources=(),
              progress=None, n_jobs: int | None = None, up_axis=None) -> "PCRP":
        """Fit FR-PointHop and the VLAD codebook on the gallery, then describe every object.

        objects: GalleryObject-like items (gallery_id, category, points), pre-aligned.
        fit_clouds bounds how many objects the Saab kernels are fitted on (PCA needs far
        fewer samples than a large gallery has); views adds, per object, the descriptors of that
        many one-sided views (what a depth camera sees from evenly spread directions), so that
        one-sided queries find their object; progress wraps iterables (e.g. tqdm); n_jobs
        processes describe the objects (default: one per core; the result does not depend on it).
        up_axis: the objects' up axis in their canonical frame; by default the one their sources
        state (GalleryObject.up) when they all agree, else none recorded.
        """
        objects = list(objects)
        if not objects:
            raise ValueError("cannot build a model from an empty gallery")
        up_axis = _common_up(objects) if up_axis is None else _unit_axis(up_axis)
        clouds = [downsample(finite_points(o.points), n_points, seed) for o in objects]
        unit = float(np.median([np.linalg.norm(c - c.mean(0), axis=1).max() for c in clouds]))
        normed = [(c - c.mean(0)) / unit for c in clouds]
        rng = np.random.default_rng(seed)
        fit_idx = rng.choice(len(normed), min(fit_clouds, len(normed)), replace=False)
        pointhop = PointHop(hop1=hop1, energy_threshold1=energy_threshold1,
                            energy_threshold2=energy_threshold2, random_state=seed)
        pointhop.fit([normed[i] for i in fit_idx])
        feats = parallel_map(object_features, normed, {"pointhop": pointhop}, n_jobs, progress, "features")
        vlad = VLAD(n_clusters=n_clusters, aggregation=aggregation, random_state=seed)
        if aggregation == "vlad":
            vlad.fit(np.concatenate(feats))
        vectors = [vlad.transform(f) for f in feats]
        owners = list(range(len(objects)))
        if views:
            cameras = sphere_directions(views) * 3.0
            per_object = parallel_map(view_vectors, [(c, cameras) for c in normed],
                                      {"pointhop": pointhop, "vlad": vlad}, n_jobs, progress, "views")
            for i, vs in enumerate(per_object):
                vectors += vs
                owners += [i] * len(vs)
        gallery = Gallery([o.gallery_id for o in objects], [o.category for o in objects],
                          [c.astype(np.float32) for c in clouds], np.stack(vectors), np.array(owners))
        meta = {"sources": list(sources), "n_objects": len(objects), "n_points": n_points, "views": views,
                "up_axis": None if up_axis is None else [float(v) for v in up_axis],
                "feature_dim": int(pointhop.n_features_), "built": time.strftime("%Y-%m-%dT%H:%M:%S")}
        return cls(pointhop, vlad, gallery, unit, meta, n_points)

    def size_report(self) -> str:
        """Bytes of each part as stored (uncompressed float32), for comparing with the paper."""
        kernels = sum(v.nbytes for v in self.pointhop.get_state().values())
        codebook = self.vlad.codebook_.nbytes if self.vlad.aggregation == "vlad" else 0
        clouds = sum(c.nbytes for c in self.gallery.clouds)
        return (f"kernels {kernels / 1e3:.0f} kB, codebook + VLAD vectors "
                f"{(codebook + self.gallery.vectors.nbytes) / 1e6:.2f} MB, gallery clouds {clouds / 1e6:.1f} MB")

    # -- files ----------------------------------------------------------------------------------
    def save(self, path) -> Path:
        arrays = {**self.pointhop.get_state(), **self.gallery.to_arrays()}
        if self.vlad.aggregation == "vlad":
            arrays["vlad_codebook"] = self.vlad.codebook_
        meta = {**self.meta, "unit": self.unit, "n_points": self.n_points,
                "pointhop": self.pointhop.get_params(),
                "vlad": {"n_clusters": self.vlad.n_clusters, "aggregation": self.vlad.aggregation},
                "gallery_ids": self.gallery.ids, "gallery_categories": self.gallery.categories}
        return model_io.write_model(path, meta, arrays)

    @classmethod
    def load(cls, path=None) -> "PCRP":
        path = Path(path) if path else DEFAULT_MODEL
        meta, arrays = model_io.read_model(path)
        try:
            pointhop = PointHop.from_state(meta["pointhop"], arrays)
            vlad = VLAD(n_clusters=meta["vlad"]["n_clusters"], aggregation=meta["vlad"]["aggregation"])
            if vlad.aggregation == "vlad":
                vlad.codebook_ = arrays["vlad_codebook"]
            gallery = Gallery.from_arrays(meta["gallery_ids"], meta["gallery_categories"], arrays)
            if meta.get("up_axis") is not None:
                meta["up_axis"] = [float(v) for v in _unit_axis(meta["up_axis"])]
            model = cls(pointhop, vlad, gallery, meta["unit"], meta, meta["n_points"])
        except (KeyError, TypeError, ValueError) as e:
            raise ModelError(f"{path}: model contents are incomplete or inconsistent ({type(e).__name__}: {e})") from None
        model.meta["path"] = str(path)
        return model

    # -- querying -------------------------------------------------------------------------------
    def prepare(self, points) -> np.ndarray:
        """The cloud as estimate() will use it: finite, at most max_points, checked for geometry a
        pose can be read from (raises InvalidCloud otherwise). Cheap; a stream can call it on
        arrival, to refuse bad clouds at once and queue only usable ones."""
        return self._clean(points, self.options)

    def _clean(self, points, opts: QueryOptions) -> np.ndarray:
        pts = finite_points(points)
        if len(np.asarray(points).reshape(-1, 3)) == 0:
            raise InvalidCloud("empty", "the cloud has no points")
        if len(pts) == 0:
            raise InvalidCloud("no_finite_points", "the cloud has no finite points")
        n_finite = len(pts)
        pts = downsample(pts, min(opts.max_points, self.n_points), opts.seed)
        if len(pts) < opts.min_points <= n_finite:
            raise InvalidCloud("too_few_points", f"only {len(pts)} distinct points among {n_finite}, "
                                                 f"at least {opts.min_points} needed")
        check_geometry(pts, opts.min_points)
        return pts

    def _describe(self, normed: np.ndarray, viewpoint=None, timings: dict | None = None):
        sampled, feats = self.pointhop.transform(normed, viewpoint, timings)
        clock = Clock(timings)
        vec = self.vlad.transform(feats)
        clock.lap("vlad")
        return sampled, feats, vec

    def _prepared(self, i: int, features: bool) -> Prepared:
        """Registration-ready gallery object, recomputed on demand and kept in a bounded LRU cache
        (a stream sees the same few objects again and again). Point features are computed only
        for objects that seed hypotheses; verifiers need just the cloud and its tree."""
        key = (i, features)
        if key in self._cache:
            self._cache.move_to_end(key)
            return self._cache[key]
        cloud = self.gallery.clouds[i].astype(np.float64)
        normed = (cloud - cloud.mean(0)) / self.unit
        prep = prepare(normed, *self.pointhop.transform(normed)) if features else prepare(normed)
        self._cache[key] = prep
        while len(self._cache) > self.options.cache_size:
            self._cache.popitem(last=False)
        return prep

    @property
    def up_axis(self) -> np.ndarray | None:
        """The gallery objects' up axis in their canonical frame (unit vector), None when the
        model does not say (models built before it was recorded, or from sources that disagree)."""
        up = self.meta.get("up_axis")
        return None if up is None else np.asarray(up, dtype=np.float64)

    def check_up(self, up) -> np.ndarray:
        """up as estimate() uses it (a unit vector); ValueError saying why it cannot be used: not
        a finite non-zero 3-vector, or a model that does not record its objects' up axis."""
        u = _unit_vector(up)
        if u is None:
            raise ValueError(f"up must be a finite, non-zero 3-vector, not {up!r}")
        if self.up_axis is None:
            raise ValueError("this model does not record its objects' up axis; rebuild it with "
                             "`pcrp build --up-axis` to use an up direction")
        return u

    def _viewpoint(self, viewpoint, centre):
        return None if viewpoint is None else (np.asarray(viewpoint, dtype=np.float64) - centre) / self.unit

    def retrieve(self, points, k: int = 10, viewpoint=None) -> list[tuple[str, float]]:
        """The k gallery objects whose VLAD vectors are nearest the query's, with distances."""
        pts = self._clean(points, self.options)
        _, _, vec = self._describe((pts - pts.mean(0)) / self.unit, self._viewpoint(viewpoint, pts.mean(0)))
        idx, dist = self.gallery.search(vec, k)
        return [(self.gallery.ids[i], float(d)) for i, d in zip(idx, dist)]

    def estimate(self, points, viewpoint=None, up=None) -> PoseResult:
        """Retrieve, register, verify. Raises InvalidCloud for input no pose can be read from.

        viewpoint: the sensor's position in the cloud's frame when the cloud is what one sensor
        saw (np.zeros(3) for a cloud in the camera's own frame); None for complete objects.
        up: which way is up in the cloud's frame (against gravity), when the caller knows it;
        answers then keep the gallery's up axis (`up_axis`) within pose_options.up_tolerance_deg
        of it. None: any orientation.
        """
        t0 = time.perf_counter()
        # one snapshot of the settings, so a change made meanwhile (a node's parameter) never
        # mixes into a cloud already being answered
        opts, pose_opts = self.options, self.pose_options
        timings = {}
        up_pair = None if up is None else (self.check_up(up), self.up_axis)
        pts = self._clean(points, opts)
        centre = pts.mean(0)
        # size: how much the query is scaled before anything is computed on it (1 in metric mode;
        # in normalize mode, to the gallery's typical size, then to the first candidate's)
        size = 1.0
        if opts.scale_mode == "normalize":
            size = float(np.median(self._radii)) / max(_rms_radius(pts), 1e-12)
        normed = (pts - centre) * (size / self.unit)
        t1 = time.perf_counter()
        timings["preprocess"] = t1 - t0
        vp = self._viewpoint(viewpoint, centre)
        vp = None if vp is None else vp * size
        sampled, feats, vec = self._describe(normed, vp, timings)
        t2 = time.perf_counter()
        timings["features"] = t2 - t1
        idx, dist = self.gallery.search(vec, max(10, opts.n_candidates))
        t3 = time.perf_counter()
        timings["retrieval"] = t3 - t2
        rng = np.random.default_rng(opts.seed)
        ratio = 1.0
        if opts.scale_mode == "normalize":
            ratio = self._radii[idx[0]] / float(np.median(self._radii))
        registrar = Registrar(prepare(normed * ratio, sampled, feats), pose_opts, rng,
                              None if vp is None else vp * ratio, timings, up_pair)
        top = [int(i) for i in idx[: opts.n_candidates]]
        matched = [self._prepared(i, features=True) for i in top[: opts.n_matched]]
        verifiers = matched + [self._prepared(i, features=False) for i in top[opts.n_matched:]]
        j, h = registrar.best_pose(matched, verifiers, [self.gallery.categories[i] for i in top])
        i = top[j]
        timings["registration"] = time.perf_counter() - t3
        # g_n = R' (k q_n) + t'  with q_n = (q - centre)/unit, g_n = (g - c_g)/unit, k = size * ratio
        # => q = (1/k) R'^T (g - c_g) - (unit/k) R'^T t' + centre
        k = size * ratio
        c_g = self.gallery.clouds[i].astype(np.float64).mean(0)
        R = h.R.T
        scale = 1.0 / k
        t = centre - scale * (R @ (c_g + self.unit * h.t))
        score = h.fitness
        # until a calibrated confidence exists, the fit score stands in for it
        confidence = score
        rejected = confidence < opts.min_confidence
        timings["total"] = time.perf_counter() - t0
        return PoseResult(
            gallery_id=self.gallery.ids[i], category=self.gallery.categories[i], rotation=R,
            translation=t, scale=scale, score=score, fitness=h.fitness,
            inlier_rmse=h.rmse * self.unit / k, chamfer=h.chamfer, rejected=rejected,
            confidence=confidence,
            reason=f"confidence {confidence:.2f} below min_confidence {opts.min_confidence:.2f}" if rejected else "",
            candidates=tuple((self.gallery.ids[j], float(d)) for j, d in zip(idx, dist)),
            timings=timings, n_points=len(pts))
