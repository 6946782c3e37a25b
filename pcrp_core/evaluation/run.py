"""Answer every view with a model and count what a robot would care about.

A view's answer is right when it names the right object and its pose is within ADD-S < 10 % of
the object's diameter. Since a robot acts on what it accepts, the summary also separates the
wrong answers the model accepted (the dangerous ones: it would grasp air) from the right ones it
rejected (the lost ones: it would ask again). Errors of answers naming the wrong object are not
measured (their pose is of another object's frame); they count as failures in the AUC.
"""
from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from pcrp_core.evaluation import metrics
from pcrp_core.evaluation.scenes import Scene
from pcrp_core.sources.camera import Mesh


@dataclass(frozen=True)
class Truth:
    """What scoring needs of one object, computed once per object."""
    points: np.ndarray      # model points ADD and ADD-S average over
    diameter: float
    centre: np.ndarray      # the mean of those points, where the translation error is measured


class Truths(dict):
    """object_id -> Truth, filled on first use from the meshes."""

    def __init__(self, meshes: dict[str, Mesh]):
        super().__init__()
        self.meshes = meshes

    def __missing__(self, object_id: str) -> Truth:
        mesh = self.meshes[object_id]
        pts = metrics.model_points(mesh)
        self[object_id] = Truth(pts, metrics.diameter(mesh), pts.mean(0))
        return self[object_id]


def record(scene: Scene, answer, seconds: float, truths: Truths, reason: str = "") -> dict:
    """One view's row. answer: anything with gallery_id, rotation, translation, rejected, reason
    and a confidence (or score) in [0, 1]; None when the method gave no answer (reason says why).
    candidate_rank: the true object's 1-based rank among the answer's retrieval candidates (0: not
    among them; None: the method lists none)."""
    truth = truths[scene.object_id]
    row = {"object_id": scene.object_id, "family": metrics.family(scene.object_id), "scenario": scene.scenario,
           "view": scene.view, "seed": scene.seed, "distance": round(scene.distance, 4),
           "occluded_share": round(scene.occluded_share, 4), "n_points": int(len(scene.points)),
           "diameter": round(truth.diameter, 5), "gallery_id": None, "right_object": False, "add": None,
           "add_s": None, "pose_right": False, "rotation_error_deg": None, "translation_error": None,
           "rejected": True, "reason": reason, "confidence": 0.0, "candidate_rank": None, "seconds": float(seconds)}
    if answer is None:
        return row
    right = answer.gallery_id == scene.object_id
    # where retrieval put the true object, to tell a retrieval miss from a wrong pick among candidates
    listed = [g for g, _ in getattr(answer, "candidates", ())]
    rank = (listed.index(scene.object_id) + 1 if scene.object_id in listed else 0) if listed else None
    row.update(gallery_id=answer.gallery_id, right_object=bool(right), rejected=bool(answer.rejected),
               reason=answer.reason, confidence=float(getattr(answer, "confidence", getattr(answer, "score", 0.0))),
               candidate_rank=rank)
    if right:
        R, t = np.asarray(answer.rotation, dtype=np.float64), np.asarray(answer.translation, dtype=np.float64)
        adds = metrics.add_s(R, t, scene.R, scene.t, truth.points)
        row.update(add=metrics.add(R, t, scene.R, scene.t, truth.points), add_s=adds,
                   pose_right=metrics.pose_right(adds, truth.diameter),
                   rotation_error_deg=metrics.rotation_error_deg(R, scene.R),
                   translation_error=metrics.translation_error(R, t, scene.R, scene.t, truth.centre))
    return row


def evaluate(model, scenes: list[Scene], meshes: dict[str, Mesh], use_up: bool = False, progress=None,
             truths: Truths | None = None) -> list[dict]:
    """Per-view records of model.estimate on every scene, as the node calls it: the cloud in the
    camera's frame (viewpoint at the origin) and, with use_up, the table's normal as up. seconds
    is the wall time of the call. A cloud the model refuses (InvalidCloud) is a rejected view
    without an answer."""
    from pcrp_core.errors import InvalidCloud

    truths = truths if truths is not None else Truths(meshes)
    rows = []
    for scene in progress(scenes, desc="estimate") if progress is not None else scenes:
        up = scene.up if use_up else None
        t0 = time.perf_counter()
        try:
            answer, reason = model.estimate(scene.points, viewpoint=np.zeros(3), up=up), ""
        except InvalidCloud as e:
            answer, reason = None, f"invalid cloud ({e.reason})"
        rows.append(record(scene, answer, time.perf_counter() - t0, truths, reason))
    return rows


def jsonable(x, digits: int | None = None):
    """x with numpy scalars as Python numbers and nan/inf as None (JSON has neither), floats to
    `digits` significant digits when given."""
    if isinstance(x, np.generic):
        x = x.item()
    if isinstance(x, float):
        return None if not np.isfinite(x) else (float(f"{x:.{digits}g}") if digits else x)
    if isinstance(x, dict):
        return {k: jsonable(v, digits) for k, v in x.items()}
    if isinstance(x, (list, tuple)):
        return [jsonable(v, digits) for v in x]
    return x


def _median(values) -> float:
    v = [x for x in values if x is not None]
    return float(np.median(v)) if v else float("nan")


def statistics(rows: list[dict]) -> dict:
    """Shares are of all views in rows; error medians are over the views answered with the right
    object (accepted or not)."""
    n = len(rows)
    if n == 0:
        return {"views": 0}
    share = lambda f: float(np.mean([bool(f(r)) for r in rows]))  # noqa: E731
    seconds = np.array([r["seconds"] for r in rows])
    return {"views": n, "right_object": share(lambda r: r["right_object"]),
            "pose_right": share(lambda r: r["pose_right"]),
            "auc": metrics.adds_auc([r["add_s"] for r in rows]),
            "rotation_median_deg": _median([r["rotation_error_deg"] for r in rows]),
            "translation_median": _median([r["translation_error"] for r in rows]),
            "rejected": share(lambda r: r["rejected"]),
            "wrong_accepted": share(lambda r: not r["rejected"] and not r["pose_right"]),
            "right_rejected": share(lambda r: r["rejected"] and r["pose_right"]),
            "seconds_median": float(np.median(seconds)), "seconds_p95": float(np.quantile(seconds, 0.95))}


def summarise(rows: list[dict]) -> dict:
    """{"overall": statistics, "families": {family: statistics}} in the YCB families' order."""
    order = [name for name, _, _ in metrics.FAMILIES] + ["all"]
    present = sorted({r["family"] for r in rows}, key=order.index)
    return {"overall": statistics(rows), "families": {f: statistics([r for r in rows if r["family"] == f])
                                                      for f in present}}


COLUMNS = (("views", "views", "{:d}"), ("right_object", "right obj", "{:.0%}"), ("pose_right", "pose right", "{:.0%}"),
           ("auc", "ADD-S AUC", "{:.3f}"), ("rotation_median_deg", "rot med", "{:.1f}°"),
           ("translation_median", "trans med", "{:.1f} mm"), ("wrong_accepted", "wrong acc", "{:.0%}"),
           ("right_rejected", "right rej", "{:.0%}"), ("seconds_median", "time med", "{:.2f} s"),
           ("seconds_p95", "time p95", "{:.2f} s"))


def cell(key: str, value) -> str:
    fmt = dict((k, f) for k, _, f in COLUMNS)[key]
    if value is None or (isinstance(value, float) and not np.isfinite(value)):
        return "-"
    return fmt.format(value * 1000 if key == "translation_median" else value)


def format_summary(summary: dict) -> str:
    """The summary as a plain-text table: one row per family, then all views."""
    rows = [(f, s) for f, s in summary["families"].items() if f != "all" or len(summary["families"]) > 1]
    rows.append(("overall", summary["overall"]))
    table = [["family"] + [title for _, title, _ in COLUMNS]]
    table += [[name] + [cell(k, s.get(k)) for k, _, _ in COLUMNS] for name, s in rows]
    widths = [max(len(r[i]) for r in table) for i in range(len(table[0]))]
    return "\n".join("  ".join(c.ljust(w) if i == 0 else c.rjust(w) for i, (c, w) in enumerate(zip(r, widths)))
                     for r in table)
