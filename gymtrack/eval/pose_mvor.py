"""Lifting real detector keypoints: MVOR's OpenPose output against its 3D ground truth.

Paper: Section III-D triangulates the joints a pose model finds in the calibrated views (Eq. 3
per joint); this measures the pose stage's lifting (:func:`gymtrack.pose.lift.lift_track`, ``dlt``
and ``robust``) on real detections nobody here made. Data: MVOR (Srivastav et al., "MVOR: A
Multi-view RGB-D Operating Room Dataset for 2D and 3D Human Pose Estimation", MICCAI-LABELS
2018, arXiv:1808.08180; CC BY-NC-SA 4.0), read by :mod:`gymtrack.formats.mvor` from
``shared/data/mvor``.

Protocol (the data README's baseline, so its plain-DLT figure sits beside ours): each detection
is linked to the ground-truth person whose 2D annotation it is nearest to (mean joint distance,
one-to-one per image, no distance limit), mapped to MVOR's 10 upper-body joints; every person
with 3D ground truth is lifted on its own (a (1, 3, 10, 3) array: the frames are independent
snapshots, so no temporal smoothing, temporal prior or cross-frame bone lengths can help).
``robust`` adds its own rules, the same as the pose stage's where the stage has them: one body,
one person (a detection two persons of a frame share -- the file repeats 890 entries -- stays with
the person whose other views it fits, :func:`one_body_one_person`); and the cascade for joints
on a room (:func:`body_plane`): an operating room has no apparatus plane, so a joint one view
alone sees is anchored on the vertical plane through the person's other joints facing that view
(vertical by the room frame's up, ``firstCamToRoomRef``), and a person seen by one view is
centred where its joints' rays meet their usual heights in the room (medians over the persons
2+ views placed; no ground truth); the depth of such a joint is pulled to its bone's length from
its placed neighbour, the lengths pooled over every person's 2-view joints
(:func:`gymtrack.pose.snapshots.pooled_bone_lengths`; no ground truth); a person whose views agree
on no body (the README's linking gives a view another person's detection where that view missed
the person) is declined, its joints counted as not estimated, never guessed
(``LiftOptions.decline_disagreeing``). ``dlt`` keeps the protocol's keypoints as they are. One snapshot is too little for ``robust``
to measure the 2D noise its gate scales with, so that level is measured once over every person
(:func:`gymtrack.pose.snapshots.measure_noise`, from the detections' own residuals; MVOR's real
calibration reprojects its own ground truth with a ~6.5 px median error at 640x480, far above a
simulated rig's). Errors in mm over the joints with 3D
ground truth: MPJPE over the joints each method estimated, the share estimated, the median, the
share off by more than 50 cm, and MPJPE on the joints both methods estimated (a fair comparison
when one method declines more joints).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path
from typing import Callable

import numpy as np

__all__ = ["README_BASELINE", "lift_mvor", "mvor_errors", "run_mvor_pose", "mvor_markdown"]

#: The data README's plain-DLT baseline on OpenPose (1054 persons, no matching limit).
README_BASELINE = {"mpjpe_mm": 345.0, "median_mm": 194.0, "estimated": 0.759, "over_500mm": 0.23}


def lift_mvor(mv, detector: str = "openpose", frames: np.ndarray | None = None,
              methods: tuple[str, ...] = ("dlt", "robust"), one_body: bool = True,
              plane_anchor: bool = True, decline: bool = True, bones: bool = True) -> dict:
    """Lift every MVOR person with 3D ground truth from a detector's linked keypoints.

    mv: :class:`gymtrack.formats.mvor.MVOR`; frames: frame indices to use (default all).
    Returns ``{"gt": (K, J, 3) metres, method: (K, J, 3) estimates, "views": (K,) views with a
    detection, "same_body": views robust left to another person, "plane_persons": persons whose
    lone joints robust anchored, "joints_declined": joints robust declined (views that agree on no
    body), "bone_lengths_m": the pooled lengths}`` over the K persons. one_body, plane_anchor,
    decline, bones: robust's rules (module doc), for the ablation.
    """
    from ..pose.identity import TorsoIdentity
    from ..pose.lift import LiftOptions, lift_track
    from ..pose.snapshots import measure_noise, pooled_bone_lengths

    dk = mv.detected_keypoints(detector)  # (F, V, P, J, 3)
    F, P = mv.person_id.shape
    J = len(mv.skeleton.joints)
    sel = np.arange(F) if frames is None else np.asarray(frames, np.int64)
    want = np.zeros((F, P), bool)
    want[sel] = mv.has3d[sel]
    f_idx, p_idx = np.nonzero(want)
    kp = dk[f_idx, :, p_idx]  # (K, V, J, 3)
    kp[..., 2] = np.clip(kp[..., 2], 0.0, 1.0)  # OpenPose's confidences reach 1.02
    out = {"gt": mv.joints3d[f_idx, p_idx], "views": (kp[..., 2] > 0).any(-1).sum(-1)}
    # one snapshot is too little to measure the detector's and calibration's noise on: pool it
    # over every person (from their own residuals, no ground truth) for robust's gate
    # (several people in every view: a neighbour's body in a person's view is set aside, pose.identity)
    opt = LiftOptions(noise_frac=measure_noise(mv.rig, kp, mv.skeleton) if len(kp) else 0.0, identity=TorsoIdentity())
    out["noise_frac"] = opt.noise_frac
    kp_robust = kp.copy()  # robust's own rules; dlt keeps the protocol's keypoints as they are
    out["same_body"] = one_body_one_person(mv.rig, mv.skeleton, kp_robust, f_idx) if one_body else 0
    up, up0 = mv.up, mv.room[2, 3]
    out["plane_persons"], out["joints_declined"], out["bone_lengths_m"] = 0, 0, None
    for m in methods:
        src = kp_robust if m == "robust" else kp
        est = np.full((f_idx.size, J, 3), np.nan)
        how, n_views = np.zeros((f_idx.size, J), np.int8), np.zeros((f_idx.size, J), np.int64)
        mopt = replace(opt, decline_disagreeing=decline) if m == "robust" else opt
        for k in range(f_idx.size):
            lifted = lift_track(mv.rig, src[k][None], mv.skeleton, method=m, options=mopt)
            est[k], how[k], n_views[k] = lifted.xyz[0], lifted.how[0], lifted.n_views[0]
            if m == "robust":
                out["joints_declined"] += lifted.counts["joints_declined"]
        if m == "robust" and bones and len(est):
            # a snapshot has no frames to measure its own bones on: pooled over the persons (no ground truth)
            out["bone_lengths_m"] = pooled_bone_lengths(est, how, n_views, mv.skeleton)
            mopt = replace(mopt, bone_lengths_m=out["bone_lengths_m"])
        if m == "robust" and plane_anchor and np.isfinite(up).all():
            # each joint's height in the room, measured on the persons 2+ views placed (no ground truth)
            height = np.nanmedian(est @ up + up0, axis=0)
            for k in range(f_idx.size):
                plane = body_plane(mv.rig, src[k], est[k], up, up0, height)
                if plane is not None:
                    est[k] = lift_track(mv.rig, src[k][None], mv.skeleton, method=m, centre=plane[0][None],
                                        plane_normal=plane[1], options=mopt).xyz[0]
                    out["plane_persons"] += 1
        out[m] = est
    return out


def body_plane(rig, kp: np.ndarray, est: np.ndarray, up: np.ndarray, up0: float, height: np.ndarray,
               min_joints: int = 2):
    """The vertical plane a person's lone joints are anchored on (a room has no apparatus plane):
    through the centre of its joints est (J, 3) that 2+ views placed, facing the view that alone
    sees most of the others (its normal that view's line of sight with the room's up taken out).
    A person with fewer than ``min_joints`` placed has its centre where its joints' rays meet
    their usual heights in the room (``height`` (J,), up . X + up0 = height: hips near 0). None
    where every found joint is placed already. kp (V, J, 3)."""
    placed = np.isfinite(est).all(-1)
    seen = kp[..., 2] > 0  # (V, J)
    lone = seen.any(0) & ~placed
    if not lone.any():
        return None
    view = int(np.argmax((seen & lone[None]).sum(1)))
    o = rig[view].centre
    if placed.sum() >= min_joints:
        centre = np.median(est[placed], axis=0)
    else:  # its joints' rays in that view, at their usual heights
        cam = rig[view]
        j = np.flatnonzero(seen[view] & np.isfinite(height))
        if not j.size:
            return None
        d = (np.linalg.inv(cam.K @ cam.R) @ np.c_[cam.undistort(kp[view, j, :2]), np.ones(j.size)].T).T
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (height[j] - up0 - o @ up) / (d @ up)
        good = np.isfinite(s) & (s > 0)
        if not good.any():
            return None
        centre = np.median(o + s[good, None] * d[good], axis=0)
    n = centre - o
    n -= (n @ up) * up
    norm = np.linalg.norm(n)
    return (centre, n / norm) if norm > 1e-9 else None


def one_body_one_person(rig, skeleton, kp: np.ndarray, f_idx: np.ndarray) -> int:
    """Remove, in place, the views of kp (K, V, J, 3) whose pose is the same body as another
    person's of the same frame (f_idx (K,)) and fits that person's other views better
    (:func:`gymtrack.pose.exclusive.exclusive_bodies`, the pose stage's rule); returns how many."""
    from ..poses import Poses2D
    from ..pose.exclusive import exclusive_bodies

    k, v = np.nonzero((kp[..., 2] > 0).any(-1))
    if not k.size:
        return 0
    poses = Poses2D(f_idx[k].astype(np.int64), v.astype(np.int64), k.astype(np.int64), kp[k, v],
                    np.full((k.size, 4), np.nan), skeleton, tuple(rig.names))
    lose = exclusive_bodies(poses, rig, k.astype(np.int64))
    kp[k[lose], v[lose]] = [np.nan, np.nan, 0.0]
    return int(lose.sum())


def mvor_errors(est: np.ndarray, gt: np.ndarray, common: np.ndarray | None = None) -> dict:
    """Error figures (mm) of (K, J, 3) estimates against (K, J, 3) ground truth (metres)."""
    has_g = np.isfinite(gt).all(-1)
    has_e = np.isfinite(est).all(-1) & has_g
    d = 1000.0 * np.linalg.norm(np.where(has_e[..., None], est - gt, 0.0), axis=-1)[has_e]
    out = {"joints_gt": int(has_g.sum()), "joints_estimated": int(has_e.sum()),
           "estimated": float(has_e.sum() / max(has_g.sum(), 1)),
           "mpjpe_mm": float(d.mean()) if d.size else float("nan"),
           "median_mm": float(np.median(d)) if d.size else float("nan"),
           "over_500mm": float((d > 500).mean()) if d.size else float("nan")}
    if common is not None:
        c = common & has_e
        dc = 1000.0 * np.linalg.norm(np.where(c[..., None], est - gt, 0.0), axis=-1)[c]
        out["mpjpe_common_mm"] = float(dc.mean()) if dc.size else float("nan")
        out["joints_common"] = int(c.sum())
    return out


def run_mvor_pose(folder: str | Path | None = None, detector: str = "openpose", frames: np.ndarray | None = None,
                  log: Callable[[str], None] | None = None) -> dict:
    """The MVOR section's figures: ``{"available", "note", "persons", "dlt": {...}, "robust": {...}}``."""
    from ..errors import InputError
    from ..formats.mvor import read_mvor

    try:
        mv = read_mvor(folder, detectors=(detector,), max_match_px=np.inf)
    except (InputError, FileNotFoundError) as exc:
        return {"available": False, "note": f"MVOR section skipped: {exc}"}
    if log:
        log(f"MVOR: lifting {int(mv.has3d.sum())} persons from {detector} keypoints (dlt, robust)")
    r = lift_mvor(mv, detector, frames)
    common = np.isfinite(r["dlt"]).all(-1) & np.isfinite(r["robust"]).all(-1)
    return {"available": True, "note": "", "detector": detector, "persons": int(len(r["gt"])), "noise_frac": r["noise_frac"],
            "same_body": r["same_body"], "plane_persons": r["plane_persons"], "joints_declined": r["joints_declined"],
            "bone_lengths_m": r["bone_lengths_m"],
            "persons_2_views": int((r["views"] >= 2).sum()),
            "dlt": mvor_errors(r["dlt"], r["gt"], common), "robust": mvor_errors(r["robust"], r["gt"], common),
            "readme_baseline": README_BASELINE}


def mvor_markdown(d: dict) -> str:
    """The report section for :func:`run_mvor_pose`'s result."""
    from .render import markdown_table

    head = ["## Real detector keypoints: MVOR (OpenPose), dlt vs robust lifting", ""]
    if not d.get("available"):
        return "\n".join(head + [d.get("note", "MVOR not available.")])

    def f(v, kind="mm"):
        if v is None or not np.isfinite(v):
            return "-"
        return f"{v:.0f}" if kind == "mm" else f"{100 * v:.1f}%"

    b = d["readme_baseline"]
    rows = [["plain DLT (data README, 1054 persons)", f(b["mpjpe_mm"]), f(b["median_mm"]), f(b["estimated"], "pct"),
             f(b["over_500mm"], "pct"), "-"]]
    for m in ("dlt", "robust"):
        e = d[m]
        rows.append([f"{m} (ours)", f(e["mpjpe_mm"]), f(e["median_mm"]), f(e["estimated"], "pct"), f(e["over_500mm"], "pct"),
                     f(e.get("mpjpe_common_mm"))])
    return "\n".join(head + [
        f"MVOR (Srivastav et al., MICCAI-LABELS 2018, arXiv:1808.08180; CC BY-NC-SA 4.0): {d['persons']} persons with 3D "
        f"ground truth ({d['persons_2_views']} with a detection of {d['detector']} in at least 2 views), 10 upper-body joints. "
        "Detections linked to the nearest annotated person without a distance limit (the README's protocol); each "
        f"person lifted on its own; robust leaves {d.get('same_body', 0)} views of a body another person of the frame "
        f"fits better and anchors lone joints on a vertical plane through the person ({d.get('plane_persons', 0)} "
        "persons), their depth pulled to the bone lengths pooled over the persons' 2-view joints; robust declines the "
        f"{d.get('joints_declined', 0)} joints of persons whose views agree on no body (no estimate, not a guess); "
        "robust's gate scales with the 2D noise level measured once over "
        f"every person's own residuals (no ground truth): {100 * d.get('noise_frac', float('nan')):.1f}% of the box. MPJPE over the joints each method estimated; the last column "
        f"over the {d['robust'].get('joints_common', 0)} joints both estimated.", "",
        markdown_table(["lifting", "MPJPE (mm)", "median (mm)", "joints estimated", "> 50 cm", "MPJPE, common joints (mm)"], rows),
    ])
