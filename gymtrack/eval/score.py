"""Scoring an output folder of ``gymtrack track`` against a routine's ground truth.

Paper: Section IV-A's metrics of the target gymnast (ID switches, AED, FR, plus coverage) and
the all-people MOT metrics (MOTA, IDF1), computed exactly as the benchmark computes them
(:func:`gymtrack.eval.benchmark.evaluate_routine`) but from files: the output folder is read
back with :func:`gymtrack.formats.outputs.read_outputs` (metres to 4 decimals, pixels to 2), so
any tracker's results written in that layout can be scored.

Poses (MPJPE, PA-MPJPE, PCK, pose share of the target) are scored when both
``<out>/poses_3d.csv`` and ``<routine>/gt/keypoints_3d.csv`` exist and the pose stage's modules
are installed; otherwise a note says why they were left out. Judging measurements
(:mod:`gymtrack.eval.elements`) are scored when both ``<out>/analysis/elements.json`` and
``<routine>/gt/elements.json`` exist: the elements, and the angles of ``analysis/angles.csv``
against the analysis of ``gt/keypoints_3d.csv``; they are also saved as ``<out>/analysis/scores.json``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import InputError, RoutineError
from ..formats.outputs import read_outputs
from .benchmark import evaluate_routine
from ..formats.ground_truth import load_ground_truth

__all__ = ["score_output", "target_summary", "people_summary"]


def _ratio(a: float, b: float) -> float:
    return float(a) / float(b) if b else float("nan")


def target_summary(row: dict) -> dict:
    """The target's metrics from the additive parts of :func:`evaluate_routine`'s row."""
    return {
        "id_switches": int(row["idsw"]), "id_switches_track": int(row["idsw_track"]),
        "id_switches_person": int(row["idsw_person"]),
        "aed_m": _ratio(row["aed_sum"], row["aed_n"]), "aed_frames": int(row["aed_n"]),
        "fr": _ratio(row["fr_failures"], row["fr_evaluated"]), "fr_failures": int(row["fr_failures"]),
        "fr_evaluated": int(row["fr_evaluated"]), "fr_missing": int(row["fr_missing"]),
        "fr_outside": int(row["fr_outside"]), "fr_too_small": int(row["fr_too_small"]),
        "coverage": _ratio(row["cov_covered"], row["cov_frames"]), "covered_frames": int(row["cov_covered"]),
        "performing_frames": int(row["cov_frames"]),
    }


def people_summary(row: dict) -> dict | None:
    """MOTA, IDF1 and their counts from the row (None when MOT metrics were not computed)."""
    if "mota" not in row:
        return None
    return {"mota": float(row["mota"]), "idf1": float(row["idf1"]), "id_switches": int(row["mot_idsw"]),
            "false_positives": int(row["mot_fp"]), "misses": int(row["mot_fn"]), "objects": int(row["mot_objects"])}


def _pose_scores(routine: Path, out: Path, result, gt, scene, notes: list[str]) -> dict | None:
    """The target's pose metrics, or None with a note (files absent, pose stage not installed)."""
    pred, truth = out / "poses_3d.csv", routine / "gt" / "keypoints_3d.csv"
    if not pred.is_file() or not truth.is_file():
        if pred.is_file() or truth.is_file():
            missing = truth if pred.is_file() else pred
            notes.append(f"poses not scored: no {missing.name} in {missing.parent}")
        return None
    try:  # the pose stage is a separate step; without it, say so instead of failing
        from ..formats.gt_keypoints import read_keypoints_3d
        from ..formats.poses3d import read_poses_3d
        from ..skeletons import COCO17
        from .pose_metrics import target_pose_error
    except ImportError as exc:
        notes.append(f"poses not scored: the pose metrics are not installed ({exc.name})")
        return None
    poses = read_poses_3d(pred)
    frames, pid, joints = read_keypoints_3d(truth)
    k = np.flatnonzero(pid == gt.target_id)
    if not k.size:
        raise RoutineError(f"no joints of the target (person {gt.target_id})", source=truth)
    keep = np.ones(len(poses.frame), bool)
    if np.unique(poses.frame).size != poses.frame.size:  # --all-tracks: keep the target's track
        tf = result.target.frame * (1 << 32) + result.target.track_id
        keep = np.isin(poses.frame * (1 << 32) + poses.track_id, tf)
    t = gt.target()
    perf = np.unique(t.frame[t.performing(np.asarray(scene.performance_space, np.float64))])
    e = target_pose_error(poses.frame[keep], poses.xyz[keep], poses.skeleton.joints, frames, joints[k[0]],
                          COCO17.joints, perf)
    return {"mpjpe_mm": e.mpjpe, "pa_mpjpe_mm": e.pa_mpjpe, "pck": e.pck, "pose_share": e.pose_share, **e.as_dict()}


def judging_scores(routine: Path, out: Path, scene, target_id: int, notes: list[str]) -> dict | None:
    """The judging measurements of ``<out>/analysis/`` scored against ``<routine>/gt/``, or None with a
    note naming what is absent; written to ``<out>/analysis/scores.json``."""
    import json

    from ..formats.elements import read_angles, read_elements
    from .elements import angle_parts, element_parts, summarise_angles, summarise_elements

    meas, truth = out / "analysis" / "elements.json", routine / "gt" / "elements.json"
    absent = [str(p) for p in (meas, truth) if not p.is_file()]
    if absent:
        notes.append(f"judging measurements not scored: no {' and no '.join(absent)}")
        return None
    doc = read_elements(meas)
    angles_path, kp_path = out / "analysis" / "angles.csv", routine / "gt" / "keypoints_3d.csv"
    cols = read_angles(angles_path) if angles_path.is_file() else None
    jt = None
    if cols is None or not kp_path.is_file():
        notes.append(f"angle and apex errors not scored: no {angles_path if cols is None else kp_path}")
    else:
        try:
            from ..formats.gt_keypoints import read_keypoints_3d
            from .judging import JudgingTruth

            frames, pid, joints = read_keypoints_3d(kp_path)
            k = np.flatnonzero(pid == target_id)
            if not k.size:
                raise RoutineError(f"no joints of the target (person {target_id})", source=kp_path)
            jt = JudgingTruth.from_truth(truth, scene, frames, joints[k[0]], target_id)
        except ImportError as exc:
            notes.append(f"angle and apex errors not scored: the analysis stage is not installed ({exc.name})")
    parts = element_parts(doc, read_elements(truth), frames=None if cols is None else cols["frame"],
                          true_com_z=None if jt is None else jt.com_z)
    res = {"elements": summarise_elements([parts]),
           "angles": None if jt is None else summarise_angles([angle_parts(cols, jt.angles)])}
    (out / "analysis" / "scores.json").write_text(json.dumps(_json_ready(res), indent=1) + "\n")
    return res


def _json_ready(v):
    """NaN (nothing to average) as null: JSON has no NaN."""
    if isinstance(v, dict):
        return {str(k): _json_ready(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_json_ready(x) for x in v]
    if isinstance(v, (float, np.floating)):
        return None if not np.isfinite(v) else float(v)
    return v


def score_output(routine: str | Path, out: str | Path, mot: bool = True, calibration_format: str | None = None,
                 explain: bool = False, **calibration_options) -> dict:
    """Score the output folder ``out`` against ``<routine>/gt/``.

    Returns a JSON-ready dict: ``routine``, ``out``, ``cameras``, ``target`` (:func:`target_summary`),
    ``people`` (:func:`people_summary`, None without ``mot``), ``poses`` (None when not scored),
    ``notes`` (what was left out and why) and ``row`` (the benchmark's additive parts, the same
    keys and numbers as :func:`gymtrack.eval.benchmark.evaluate_routine`); with ``explain``, also
    ``explain``: the target's failed (frame, view) pairs by cause (:func:`gymtrack.eval.explain.explain_failures`).
    Raises :class:`InputError` naming the file when a needed file is missing or malformed.
    """
    from ..formats.routine import load_routine

    routine, out = Path(routine), Path(out)
    if not routine.is_dir():
        raise RoutineError("routine folder not found", source=routine)
    if not (routine / "gt").is_dir():
        raise RoutineError("routine has no gt/ folder: nothing to score against", source=routine)
    if not out.is_dir():
        raise InputError("output folder not found (what `gymtrack track --out` wrote)", source=out)
    r = load_routine(routine, calibration_format, **calibration_options)
    size = np.array([c.size for c in r.rig], dtype=np.float64)
    gt = load_ground_truth(routine, r.rig.names, image_size=size)
    result = read_outputs(out, r.rig.names)
    notes = [f"{p} is not a camera of the routine: not scored" for p in result.extra_files]
    row = evaluate_routine(result, gt, r.scene, r.rig, mot=mot)
    if not mot:
        notes.append("all-people metrics not computed (--no-mot)")
    why = None
    if explain:
        from .explain import explain_failures

        why = explain_failures(result, r.detections, gt, r.scene, r.rig)
    return {
        "routine": str(routine), "out": str(out), "cameras": list(r.rig.names), **({"explain": why} if explain else {}),
        "target": target_summary(row), "people": people_summary(row),
        "poses": _pose_scores(routine, out, result, gt, r.scene, notes),
        "judging": judging_scores(routine, out, r.scene, gt.target_id, notes),
        "notes": notes, "row": {k: (v.item() if isinstance(v, np.generic) else v) for k, v in row.items()},
    }
