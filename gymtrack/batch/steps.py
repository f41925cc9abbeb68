"""One routine of a batch, in a worker: the steps track, pose, analyse, eval into ``<out>/<routine>/``.

Paper: Section III (the tracker, :func:`gymtrack.tracking.track_detections`), III-D (the pose
stage, :func:`gymtrack.pose.stage.lift_poses`; the judging layer, :func:`gymtrack.analysis.analyse`) and IV-A (the metrics,
:func:`gymtrack.eval.score.score_output`). Each step does what its command does
(``gymtrack track``, ``gymtrack pose``, ``gymtrack analyse``, ``gymtrack eval``) and reads its inputs back from the
files the previous step wrote, so a batch gives the files and numbers of running the commands
one routine at a time.

The outputs are written through :func:`gymtrack.formats.atomic.atomic_output`: into a staging
folder beside ``<out>/<routine>`` that takes its place, with the completeness marker written
last, only when every step succeeded -- a failed or killed routine leaves the previous outputs
(or none), never a mix.

:func:`process_routine` never raises for a routine's own problem (bad file, exception in a
step): it returns a row with ``status`` ``"failed"`` and the error. A worker killed mid-run
(out of memory, ``os._exit``) is the scheduler's to report (:mod:`.engine`).
"""

from __future__ import annotations

import json
import math
import os
import shutil
import time
import traceback
from pathlib import Path

from ..errors import InputError
from ..modes import DEFAULT_MODE
from ..formats.atomic import MARKER, atomic_output
from .routines import BatchRoutine, marker_inputs, output_complete

#: batch.csv's columns before the metrics.
BASE_COLUMNS: tuple[str, ...] = ("routine", "status", "error", "frames", "seconds")
#: The metrics in batch.csv (``eval`` step on a routine with ``gt/``): the target's (Section
#: IV-A), all people's, and the target's 3D pose when the pose step ran.
METRIC_COLUMNS: tuple[str, ...] = ("id_switches", "aed_m", "fr", "coverage", "mota", "idf1",
                                   "mpjpe_mm", "pa_mpjpe_mm", "pck", "pose_share")
#: The row of a finished routine, kept in its output folder (a skipped routine reports it again).
ROW_FILE = "batch_row.json"
_TMP_TAG = ".gymtrack-tmp-"


def error_text(exc: BaseException) -> str:
    """``Type: message`` on one line (gymtrack errors already name the file, line or field)."""
    return " ".join("".join(traceback.format_exception_only(type(exc), exc)).split())


def metrics_of(score: dict) -> dict:
    """The batch.csv metrics from :func:`gymtrack.eval.score.score_output`'s dict (NaN as None)."""
    t, p, q = score["target"], score.get("people") or {}, score.get("poses") or {}
    vals = {"id_switches": t["id_switches"], "aed_m": t["aed_m"], "fr": t["fr"], "coverage": t["coverage"],
            "mota": p.get("mota"), "idf1": p.get("idf1"), "mpjpe_mm": q.get("mpjpe_mm"),
            "pa_mpjpe_mm": q.get("pa_mpjpe_mm"), "pck": q.get("pck"), "pose_share": q.get("pose_share")}
    return {k: (None if isinstance(v, float) and math.isnan(v) else v) for k, v in vals.items()}


def _apply_fault(fault: str | None) -> None:
    """Test hook: make this routine fail the way a real one can ("exit": the worker process dies,
    as when the kernel kills it for memory; "raise": an exception in a step; "hang": a step that
    takes minutes, to interrupt)."""
    if fault == "hang":
        time.sleep(300)
    if fault == "exit":
        os._exit(3)
    if fault == "raise":
        raise RuntimeError("fault injected by the test hook")


def remove_staging(dest: Path) -> None:
    """Remove the staging folders of the routine whose outputs go to ``dest`` (left by a killed worker)."""
    for p in dest.parent.glob(f".{dest.name}{_TMP_TAG}*"):
        shutil.rmtree(p, ignore_errors=True)


def _previous_row(dest: Path) -> dict:
    try:
        return json.loads((dest / ROW_FILE).read_text())
    except (OSError, ValueError):
        return {}


def run_steps(routine: BatchRoutine, staging: Path, steps: tuple[str, ...], mode: str, mot: bool = True,
              fault: str | None = None, routine_options: dict | None = None) -> dict:
    """Run ``steps`` on one routine, writing into ``staging``; returns frames, metrics and counts.

    Without ``track`` the staging folder must already hold the track outputs (a copy of the
    previous ones). Raises whatever a step raises. ``routine_options``: ``calibration`` (one file
    for every routine) and ``keypoints`` (a folder inside each routine), as ``load_routine`` takes.
    """
    from ..formats.routine import load_routine

    ropts = dict(routine_options or {})
    if ropts.get("keypoints") is not None:
        ropts["keypoints"] = Path(routine.path) / ropts["keypoints"]
    r = load_routine(routine.path, **ropts)
    info: dict = {}
    if "track" in steps:
        from ..formats.outputs import write_outputs
        from ..tracking.offline import track_detections

        _apply_fault(fault)
        result = track_detections(r.rig, r.scene, r.detections, mode=mode)
        write_outputs(result, staging)
        info["frames"] = int(result.summary["frames"])
    if "pose" in steps:
        from ..formats.keypoints import write_keypoints
        from ..formats.poses3d import write_poses_3d
        from ..pose.sources import routine_poses
        from ..pose.stage import lift_poses, read_track_result

        result = read_track_result(staging, r.rig.names)  # as `gymtrack pose` reads it
        poses = routine_poses(r, result)
        res = lift_poses(result, r.rig, r.scene, poses)
        write_keypoints(staging / "keypoints", res.poses2d)
        write_poses_3d(staging / "poses_3d.csv", res.poses3d)
        info["pose"] = {k: (int(v) if isinstance(v, (int, float)) and float(v).is_integer() else v)
                        for k, v in res.summary().items()}
    if "analyse" in steps:
        from ..analysis.folder import analyse_output, write_analysis

        a = analyse_output(routine.path, staging)  # as `gymtrack analyse` reads it
        notes = write_analysis(a, staging / "analysis")
        info["analysis"] = {k: a.summary[f"{k}s"] for k in ("flight", "landing", "hold", "circle", "turn")}
        if notes:
            info["analysis"]["notes"] = notes
    if "eval" in steps:
        if r.has_gt:
            from ..eval.score import score_output

            score = score_output(routine.path, staging, mot=mot, **ropts)
            (staging / "eval.json").write_text(json.dumps(score, indent=1, default=str, allow_nan=True) + "\n")
            info["metrics"] = metrics_of(score)
        else:
            info["note"] = "no gt/: not scored"
    return info


def process_routine(routine: BatchRoutine, out_root: str, steps: tuple[str, ...], mode: str = DEFAULT_MODE,
                    force: bool = False, mot: bool = True, fault: str | None = None,
                    routine_options: dict | None = None) -> dict:
    """Run one routine into ``<out_root>/<routine.name>/`` (a worker task); returns its batch.csv row.

    Skipped (``status`` ``"skipped"``, the previous row's frames and metrics) when the folder is
    complete for ``steps`` and ``mode`` and not ``force``. ``fault`` is the test hook of
    :func:`_apply_fault`.
    """
    dest = Path(out_root) / routine.name
    base = {"routine": routine.name, "status": "ok", "error": "", "frames": 0, "seconds": 0.0}
    if not force and output_complete(dest, steps, mode):
        prev = _previous_row(dest)
        return {**base, **{k: prev.get(k) for k in ("frames", *METRIC_COLUMNS) if k in prev}, "status": "skipped",
                "seconds": 0.0}
    t0 = time.perf_counter()
    try:
        prev = {}
        if "track" not in steps:
            if not (dest / "target_3d.csv").is_file():
                raise InputError("no track outputs to start from: run the 'track' step first", source=dest)
            prev = _previous_row(dest)
        with atomic_output(dest, "batch", marker_inputs(routine.name, steps, mode), overwrite=force,
                           protect=[routine.path]) as staging:
            if "track" not in steps:  # the later steps add to a copy of the earlier outputs
                shutil.copytree(dest, staging, ignore=shutil.ignore_patterns(MARKER), dirs_exist_ok=True)
            info = run_steps(routine, staging, steps, mode, mot, fault, routine_options)
            row = {**base, "frames": info.get("frames", prev.get("frames", 0)), **info.get("metrics", {}),
                   "seconds": round(time.perf_counter() - t0, 3)}
            saved = {**row, "steps": list(steps), "mode": mode, **{k: info[k] for k in ("pose", "analysis", "note") if k in info}}
            (staging / ROW_FILE).write_text(json.dumps(saved, indent=1) + "\n")
        return row
    except Exception as exc:  # one routine's failure is its row, never the batch's
        return {**base, "status": "failed", "error": error_text(exc), "seconds": round(time.perf_counter() - t0, 3)}
