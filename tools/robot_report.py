"""`python -m tools robot-report`: pcrp beside Open3D's pipelines on the YCB objects, as a robot's
depth camera sees them. Writes ROBOT.md, robot.json and robot_adds.png (tools/robot_writer.py).

The model is built as the README tells a user to build one for a depth camera (`pcrp build
<meshes> --views 12`, plus `--up-axis z`, which only matters to the scenarios that state up) and
answered with the node's defaults. Every method answers the very same views: per scenario, the
views of every object drawn from seed (split seed, object index, view index). Two splits keep
tuning honest: the validation views (seed 1000) are the only ones anything was chosen on, the
test views (seed 0) are the ones reported.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
import time
from pathlib import Path

SCENARIOS = {   # name: (kind, occluded, up known to the method)
    "free": ("free", False, False),
    "table": ("table", False, True),
    "free_occluded": ("free", True, False),
    "table_occluded": ("table", True, True),
}
SEEDS = {"test": 0, "validation": 1000}
METHODS = {
    "pcrp": "pcrp (node defaults)",
    "ransac": "FPFH + RANSAC + ICP, own retrieval",
    "fgr": "FPFH + FGR + ICP, own retrieval",
    "ransac_told": "FPFH + RANSAC + ICP, told the object",
    "fgr_told": "FPFH + FGR + ICP, told the object",
}
VIEWS_PER_OBJECT = 2
QUICK_OBJECTS = 4
GALLERY_VIEWS = 12
REPO = Path(__file__).resolve().parents[1]
CACHE = Path(os.environ.get("PCRP_CACHE", Path.home() / ".cache" / "pcrp")) / "robot"
THREAD_VARS = ("OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS")


def register(sub) -> None:
    p = sub.add_parser("robot-report", help="pcrp and Open3D's pipelines on YCB depth-camera views; write ROBOT.md",
                       description="Render seeded depth-camera views of every mesh (free, on a table with up known, "
                                   "and both occluded), answer them with pcrp and with Open3D's FPFH + RANSAC / FGR + "
                                   "ICP (told the object, and with their own retrieval), and write ROBOT.md, "
                                   "robot.json and robot_adds.png to --out.")
    p.add_argument("--data", default=str(REPO.parent / "shared" / "data" / "ycb"), help="folder of meshes in metres")
    p.add_argument("--out", default="docs/results", help="report folder (default docs/results)")
    p.add_argument("--split", default="test", choices=sorted(SEEDS),
                   help="test (seed 0, reported) or validation (seed 1000, the views to tune on); "
                        "validation writes ROBOT_validation.md and robot_validation.*")
    p.add_argument("--views-per-object", type=int, default=VIEWS_PER_OBJECT, help="per scenario (default 2)")
    p.add_argument("--quick", action="store_true", help=f"{QUICK_OBJECTS} objects, 1 view each: a smoke run")
    p.add_argument("--cache", default=None, help=f"where the model is built (default {CACHE})")
    p.add_argument("--rebuild", action="store_true", help="build the model even if the cache holds one")
    p.add_argument("--from-json", default=None, metavar="FILE", help="only re-render the report from a robot.json")
    p.set_defaults(func=_report)


def _say(text: str) -> None:
    print(text, file=sys.stderr, flush=True)


def _report(args) -> int:
    # one thread: the times per view are one core's, as on a robot's shared computer
    for var in THREAD_VARS:
        os.environ[var] = "1"
    from pcrp_core.cli import _fail
    from tools import robot_writer

    if args.from_json:
        res = json.loads(Path(args.from_json).read_text())
    else:
        data = Path(args.data)
        if not data.is_dir():
            return _fail(f"{data}: no such folder of meshes")
        res = run(data, args.split, 1 if args.quick else args.views_per_object, args.quick,
                  Path(args.cache) if args.cache else CACHE, args.rebuild)
    path = robot_writer.write(res, Path(args.out))
    print(f"wrote {path} ({res['seconds']['total'] / 60:.1f} minutes)")
    return 0


def build_model(data: Path, cache: Path, n_objects: int, rebuild: bool = False) -> Path:
    """The model the README's recipe builds, cached; rebuilt when the cache's was built from another
    folder, another number of objects or another number of views."""
    out = cache / f"{data.resolve().name}_views{GALLERY_VIEWS}"
    meta = out / "model.json"
    if meta.exists() and not rebuild:
        m = json.loads(meta.read_text())
        if m.get("sources") == [str(data)] and m.get("n_objects") == n_objects and m.get("views") == GALLERY_VIEWS:
            _say(f"robot-report: reusing the model in {out}")
            return out
    _say(f"robot-report: building the model into {out}")
    # --jobs 1: one process at a time on a shared machine; the model does not depend on it
    cmd = [sys.executable, "-m", "pcrp_core.cli", "build", str(data), "--views", str(GALLERY_VIEWS),
           "--up-axis", "z", "--jobs", "1", "--out", str(out)]
    done = subprocess.run(cmd, capture_output=True, text=True, cwd=REPO)
    if done.returncode != 0:
        raise RuntimeError(f"building the model failed: {done.stderr[-2000:]}")
    return out


def _options(model) -> dict:
    """The node-default settings the report names: read through get_params() where the model has it
    (settings defined in pcrp_core.config, min_score renamed min_confidence), else as attributes."""
    params = model.get_params() if hasattr(model, "get_params") else {
        k: getattr(model, k) for k in ("n_candidates", "min_score", "max_points", "scale_mode")}
    return {k: params[k] for k in ("n_candidates", "min_confidence", "min_score", "max_points", "scale_mode")
            if k in params}


def _view_seed(scene) -> int:
    import numpy as np
    return int(np.random.SeedSequence([scene.seed, scene.object_index, scene.view]).generate_state(1)[0] % 2**31)


def run(data: Path, split: str, views: int, quick: bool, cache: Path, rebuild: bool = False) -> dict:
    import numpy as np

    from pcrp_core import PCRP
    from pcrp_core.cli import _progress
    from pcrp_core.evaluation.run import Truths, evaluate, record
    from pcrp_core.evaluation.scenes import sample_scenes
    from pcrp_core.sources import load_source
    from tools import robot_open3d as ro
    from tools.bench import machine
    from tools.robot_twins import find_twins

    t_start = time.perf_counter()
    load = [os.getloadavg()[0]]
    seconds = {}
    seed = SEEDS[split]
    objects = load_source(str(data))
    model_path = build_model(data, cache, len(objects), rebuild)
    model = PCRP.load(model_path)
    meshes = {o.gallery_id: o.mesh for o in objects if o.mesh is not None}
    indices = {oid: i for i, oid in enumerate(meshes)}
    chosen = list(meshes)
    if quick:
        chosen = chosen[:: max(1, len(chosen) // QUICK_OBJECTS)][:QUICK_OBJECTS]
    ro.quiet()
    t0 = time.perf_counter()
    targets = {oid: ro.target(m) for oid, m in meshes.items()}
    seconds["baseline_gallery"] = time.perf_counter() - t0
    truths = Truths(meshes)
    results, gate = {}, {}
    for name, (kind, occluded, up) in SCENARIOS.items():
        _say(f"robot-report: {name}: drawing {views} view(s) of {len(chosen)} objects")
        t0 = time.perf_counter()
        scenes = sample_scenes({k: meshes[k] for k in chosen}, views, kind, occluded, seed, indices=indices)
        t1 = time.perf_counter()
        rows = {"pcrp": evaluate(model, scenes, meshes, use_up=up, progress=_progress, truths=truths)}
        t2 = time.perf_counter()
        for m in ("ransac", "fgr", "ransac_told", "fgr_told"):
            rows[m] = []
        kept, dropped = [], 0
        for s in _progress(scenes, desc=f"open3d {name}"):
            t_q = time.perf_counter()
            q = ro.query(s.points)
            t_features = time.perf_counter() - t_q
            for method in ro.METHODS:
                (told, t_told), (got, t_got), n, true_kept = ro.answer_view(method, q, t_features, targets,
                                                                            s.object_id, _view_seed(s))
                rows[f"{method}_told"].append(record(s, told, t_told, truths))
                rows[method].append(record(s, got, t_got, truths, "" if got else "no object passed the size gate"))
            kept.append(n)
            dropped += not true_kept
        results[name] = rows
        gate[name] = {"candidates_mean": float(np.mean(kept)), "true_dropped": int(dropped), "views": len(scenes)}
        seconds[name] = {"scenes": t1 - t0, "pcrp": t2 - t1, "open3d": time.perf_counter() - t2}
        _say(f"robot-report: {name} took {(time.perf_counter() - t0) / 60:.1f} min")
    t0 = time.perf_counter()
    twins, nearest, aligned = find_twins({k: meshes[k] for k in (chosen if quick else meshes)})
    seconds["twins"] = time.perf_counter() - t0
    seconds["total"] = time.perf_counter() - t_start
    load.append(os.getloadavg()[0])
    model_meta = json.loads((model_path / "model.json").read_text())
    return {
        "split": split, "seed": seed, "quick": quick, "views_per_object": views, "data": str(data),
        "objects": chosen, "gallery_size": len(meshes), "machine": machine(), "load": load, "seconds": seconds,
        "model": {"recipe": f"pcrp build {data.name} --views {GALLERY_VIEWS} --up-axis z",
                  "views": model_meta.get("views"), "up_axis": model_meta.get("up_axis"),
                  "n_objects": model_meta.get("n_objects"),
                  "options": _options(model)},
        "baselines": {"voxel": ro.VOXEL, "normal_radius": ro.NORMAL_RADIUS, "feature_radius": ro.FEATURE_RADIUS,
                      "ransac_distance": ro.RANSAC_DISTANCE, "ransac_criteria": list(ro.RANSAC_CRITERIA),
                      "fgr_distance": ro.FGR_DISTANCE, "icp_distance": ro.ICP_DISTANCE, "gate": list(ro.GATE)},
        "gate": gate, "twins": {"within": 0.002, "pairs": twins, "nearest_others": nearest, "pairs_aligned": aligned},
        "methods": METHODS, "scenarios": {k: list(v) for k, v in SCENARIOS.items()}, "results": results,
    }
