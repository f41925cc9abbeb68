"""The benchmark's fault section: a venue's faults, each clean, with the fault and corrected.

Beyond the paper. Four-camera routines of the suite (the first ``limit``, one per apparatus
first) get each fault of :mod:`.faults` in one camera (a seeded choice per routine):
desync by 1, 3 and 8 frames (corrected: ``gymtrack sync``'s offsets applied as scene.yaml's
``frame_offsets`` would), a 0.5 and a 1 degree knock at mid-routine (with the fault: the tracker
without re-estimation; corrected: with it), 2 % of one camera's frames dropped and a camera
silent from mid-routine (no correction: the tracker's own handling). Every method runs on the
clean, faulty and corrected boxes; scored over the whole routine (target AED over performing
frames, coverage; all people's MOTA, IDF1). Rows also say what the venue check found (sync's
offset; the knock's camera and delay).
"""

from __future__ import annotations

import zlib
from typing import Sequence

import numpy as np

from ..detections import Detections
from .benchmark import RoutineSpec, evaluate_routine
from .dropout import silence_camera
from .faults import desync_camera, drop_frames, knock_camera, knock_rotation

__all__ = ["FAULTS", "FAULT_METHODS", "run_faults", "faults_table", "faults_markdown", "resynchronise"]

FAULT_METHODS: tuple[str, ...] = ("cascade+", "cascade", "triangulation")
FAULTS: tuple[str, ...] = ("desync 1", "desync 3", "desync 8", "knock 0.5 deg", "knock 1 deg", "2 % frames dropped",
                           "silent camera")


def resynchronise(det: Detections, rig, search: int = 10) -> tuple[Detections, np.ndarray]:
    """The boxes with the offsets :func:`gymtrack.tracking.sync.estimate_offsets` finds applied
    (as scene.yaml's ``frame_offsets``), and the (C,) offsets."""
    from ..formats.routine import apply_frame_offsets
    from ..tracking.sync import estimate_offsets

    res = estimate_offsets(det, rig, search=search)
    offsets = {n: int(o) for n, o in zip(rig.names, res.offsets) if o}
    return apply_frame_offsets(det, offsets, rig.names)[0], res.offsets


def _faulty(name: str, det: Detections, rig, cam: int, mid: int, seed: int):
    """(faulty boxes, corrected boxes or None, recalibrate for the faulty run, what the check found)."""
    if name.startswith("desync"):
        d = int(name.split()[1]) * (1 if seed % 2 else -1)
        bad = desync_camera(det, cam, d)
        fixed, offs = resynchronise(bad, rig)
        return bad, fixed, True, {"offset": d, "found": int(offs[cam]), "exact": bool(offs[cam] == d and
                                                                                       np.count_nonzero(offs) == 1)}
    if name.startswith("knock"):
        deg = float(name.split()[1])
        return knock_camera(det, rig[cam], cam, mid, knock_rotation(deg, seed)), None, False, {"degrees": deg}
    if name.startswith("2 %"):
        return drop_frames(det, cam, 0.02, seed)[0], None, True, {}
    return silence_camera(det, cam, mid)[0], None, True, {}


def run_faults(specs: Sequence[RoutineSpec], methods: Sequence[str] = FAULT_METHODS, faults: Sequence[str] = FAULTS,
               limit: int = 2) -> list[dict]:
    """Every fault on the first ``limit`` four-camera routines (one per apparatus first); one row
    per (routine, fault, method, state) with state ``clean`` | ``fault`` | ``corrected``."""
    from ..formats.ground_truth import load_ground_truth
    from ..formats.routine import load_routine
    from ..tracking.offline import track_detections

    four, seen = [], set()
    for s in specs:
        if s.n_cam == 4 and s.apparatus not in seen:
            four.append(s)
            seen.add(s.apparatus)
    rows = []
    for s in four[:limit]:
        r = load_routine(s.path)
        gt = load_ground_truth(s.path, r.rig.names, image_size=np.array([c.size for c in r.rig], dtype=np.float64))
        seed = zlib.crc32(s.name.encode())
        cam = 1 + seed % (len(r.rig) - 1)  # (camera 0 is sync's reference)
        mid = int((r.detections.frame.min() + r.detections.frame.max()) // 2)

        def score(det, m, recalibrate=True):
            res = track_detections(r.rig, r.scene, det, mode=m, watch_cameras=True, recalibrate=recalibrate)
            return res, evaluate_routine(res, gt, r.scene, r.rig)

        base = {"routine": s.name, "apparatus": s.apparatus, "camera": r.rig.names[cam]}
        clean = {m: score(r.detections, m)[1] for m in methods}
        for f in faults:
            bad, fixed, recal, found = _faulty(f, r.detections, r.rig, cam, mid, seed)
            for m in methods:
                rows.append({**base, "fault": f, "method": m, "state": "clean", **clean[m]})
                res, row = score(bad, m, recal)
                moved = res.summary.get("camera_moved", [])
                hit = [e for e in moved if e["camera"] == r.rig.names[cam] and e["start_frame"] >= mid - 30]
                check = dict(found)
                if f.startswith("knock"):
                    check |= {"detected": bool(hit), "delay_s": round((hit[0]["detected_frame"] - mid) / r.scene.fps, 2)
                              if hit else None, "false_alarms": len(moved) - len(hit)}
                rows.append({**base, "fault": f, "method": m, "state": "fault", **check, **row})
                if fixed is not None or f.startswith("knock"):
                    row = score(fixed, m)[1] if fixed is not None else score(bad, m, True)[1]
                    rows.append({**base, "fault": f, "method": m, "state": "corrected", **row})
    return rows


def faults_table(rows: Sequence[dict]) -> list[dict]:
    """Per (fault, method, state): target AED (pooled), coverage (pooled), MOTA and IDF1 (means)."""
    out = []
    keys = dict.fromkeys((r["fault"], r["method"], r["state"]) for r in rows)
    for f, m, st in keys:
        rs = [r for r in rows if (r["fault"], r["method"], r["state"]) == (f, m, st)]
        aed_n, cov_n = sum(r["aed_n"] for r in rs), sum(r["cov_frames"] for r in rs)
        out.append({"fault": f, "method": m, "state": st, "routines": len(rs),
                    "aed": sum(r["aed_sum"] for r in rs) / aed_n if aed_n else float("nan"),
                    "coverage": sum(r["cov_covered"] for r in rs) / cov_n if cov_n else float("nan"),
                    "mota": float(np.mean([r["mota"] for r in rs])), "idf1": float(np.mean([r["idf1"] for r in rs]))})
    return out


def faults_markdown(rows: Sequence[dict]) -> str:
    """The report section: one table row per (fault, method), clean / fault / corrected side by side."""
    from .render import fmt, markdown_table

    lines = ["## A venue's faults", ""]
    if not rows:
        return "\n".join(lines + ["No four-camera routine in the suite: section skipped.", ""])
    lines += ["Each fault in one camera of the suite's first four-camera routines (see `gymtrack.eval.fault_bench`): "
              "target AED (m) and coverage, all people's MOTA / IDF1, clean / with the fault / corrected "
              "(desync: the offsets `gymtrack sync` finds applied; knock: the tracker's re-estimation; "
              "dropped frames and a silent camera: no correction).", ""]
    t = {(x["fault"], x["method"], x["state"]): x for x in faults_table(rows)}
    body = []
    for f, m in dict.fromkeys((x[0], x[1]) for x in t):
        cells = [t.get((f, m, st)) for st in ("clean", "fault", "corrected")]

        def trio(key):
            return " / ".join(fmt(c[key]) if c else "-" for c in cells)

        body.append([f, m, trio("aed"), trio("coverage"), trio("mota"), trio("idf1")])
    lines.append(markdown_table(["fault", "method", "target AED", "target coverage", "MOTA", "IDF1"], body))
    sync = [r for r in rows if r["state"] == "fault" and "exact" in r]
    knock = [r for r in rows if r["state"] == "fault" and "detected" in r]
    if sync:
        lines += ["", f"Sync recovered the offset exactly in {sum(r['exact'] for r in sync)} of {len(sync)} runs."]
    if knock:
        lines += [f"The knock was detected in the right camera in {sum(r['detected'] for r in knock)} of {len(knock)} "
                  f"runs, with {sum(r['false_alarms'] for r in knock)} alarms elsewhere."]
    return "\n".join(lines) + "\n"
