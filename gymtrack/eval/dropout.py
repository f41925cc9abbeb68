"""The benchmark's camera drop-out section (beyond the paper).

A camera that goes silent mid-routine (unplugged, its detector crashed) leaves the tracker with
one view fewer from that frame on. The section takes the suite's four-camera routines, silences
one camera from ``from_frame`` on (its detections removed; the camera is chosen per routine by
a seeded draw, so the apparatus see different views drop), runs the methods and scores
everything with :func:`.benchmark.evaluate_routine` over the frames after the drop-out only
(all people: MOTA, IDF1; the target: AED, coverage). Kept cheap: ``limit`` routines at most.

Rows: one per (routine, method) with the routine's apparatus, the silenced camera and the
additive metric parts; :func:`dropout_table` averages them per method, :func:`dropout_markdown`
renders the report section.
"""

from __future__ import annotations

import zlib
from typing import Sequence

import numpy as np

from ..detections import Detections
from ..formats.ground_truth import GroundTruth
from .benchmark import RoutineSpec, evaluate_routine, run_method

__all__ = ["silence_camera", "after_frame", "run_dropout", "dropout_table", "dropout_markdown", "DROPOUT_METHODS"]

DROPOUT_METHODS: tuple[str, ...] = ("cascade", "cascade+", "triangulation")


def silence_camera(det: Detections, camera: int, from_frame: int) -> tuple[Detections, int]:
    """The detections (N,) without camera ``camera``'s boxes of frames >= ``from_frame``, and how
    many were removed."""
    drop = (det.camera == camera) & (det.frame >= from_frame)
    return det.select(np.flatnonzero(~drop)), int(drop.sum())


def after_frame(gt: GroundTruth, from_frame: int) -> GroundTruth:
    """The ground truth of frames >= ``from_frame`` (people's points and boxes)."""
    import dataclasses

    keep, keep_box = gt.frame >= from_frame, gt.box_frame >= from_frame
    changes = {n: getattr(gt, n)[keep] for n in ("frame", "person_id", "role", "xyz", "top_z", "bottom_z")}
    changes |= {n: getattr(gt, n)[keep_box] for n in ("box_frame", "box_camera", "box_person", "box", "box_visible")}
    if gt.phase is not None:
        changes["phase"] = gt.phase[keep]
    return dataclasses.replace(gt, **changes)


def run_dropout(specs: Sequence[RoutineSpec], methods: Sequence[str] = DROPOUT_METHODS, from_frame: int = 300,
                limit: int = 4) -> list[dict]:
    """Silence one camera of each four-camera routine (the first ``limit``, one per apparatus
    first) from ``from_frame`` on; every method on it, scored after the drop-out."""
    from ..formats.ground_truth import load_ground_truth
    from ..formats.routine import load_routine

    four, seen = [], set()
    for s in specs:  # one per apparatus first, so a few routines cover several apparatus
        if s.n_cam == 4 and s.apparatus not in seen:
            four.append(s)
            seen.add(s.apparatus)
    four += [s for s in specs if s.n_cam == 4 and s not in four]
    rows = []
    for s in four[:limit]:
        r = load_routine(s.path)
        size = np.array([c.size for c in r.rig], dtype=np.float64)
        gt = load_ground_truth(s.path, r.rig.names, image_size=size)
        cam = zlib.crc32(s.name.encode()) % len(r.rig)
        det, removed = silence_camera(r.detections, cam, from_frame)
        late = after_frame(gt, from_frame)
        for m in methods:
            res, sec, _ = run_method(m, r.rig, r.scene, det, gt)
            tr = res.tracks
            res = _after(res, from_frame)
            row = evaluate_routine(res, late, r.scene, r.rig)
            rows.append({"routine": s.name, "apparatus": s.apparatus, "method": m, "camera": r.rig.names[cam],
                         "removed": removed, "from_frame": from_frame, "tracks": int(np.unique(tr.track_id).size), **row})
    return rows


def _after(res, from_frame: int):
    """A TrackResult restricted to frames >= ``from_frame``."""
    import dataclasses

    def cut(x, frame):
        return x.select(np.flatnonzero(frame >= from_frame))

    return dataclasses.replace(res, tracks=cut(res.tracks, res.tracks.frame), target=cut(res.target, res.target.frame),
                               target_boxes=cut(res.target_boxes, res.target_boxes.frame))


def dropout_table(rows: Sequence[dict]) -> list[dict]:
    """Per method: MOTA, IDF1 (means over routines), target AED (pooled) and coverage (pooled)."""
    out = []
    for m in dict.fromkeys(r["method"] for r in rows):
        rs = [r for r in rows if r["method"] == m]
        aed_n = sum(r["aed_n"] for r in rs)
        cov_n = sum(r["cov_frames"] for r in rs)
        out.append({"method": m, "routines": len(rs), "mota": float(np.mean([r["mota"] for r in rs])),
                    "idf1": float(np.mean([r["idf1"] for r in rs])),
                    "aed": sum(r["aed_sum"] for r in rs) / aed_n if aed_n else float("nan"),
                    "coverage": sum(r["cov_covered"] for r in rs) / cov_n if cov_n else float("nan")})
    return out


def dropout_markdown(rows: Sequence[dict]) -> str:
    """The report section."""
    from .render import fmt, markdown_table

    lines = ["## Camera drop-out", ""]
    if not rows:
        return "\n".join(lines + ["No four-camera routine in the suite: section skipped.", ""])
    f0 = rows[0]["from_frame"]
    lines += [f"One camera of each four-camera routine silent from frame {f0} on (a seeded choice per routine); "
              f"scored over the frames from {f0} on: all people (MOTA, IDF1, mean over routines) and the target "
              "(AED over performing frames, coverage).", ""]
    body = [[t["method"], t["routines"], fmt(t["mota"]), fmt(t["idf1"]), fmt(t["aed"]), fmt(t["coverage"])]
            for t in dropout_table(rows)]
    lines.append(markdown_table(["method", "routines", "MOTA", "IDF1", "target AED (m)", "target coverage"], body))
    return "\n".join(lines) + "\n"
