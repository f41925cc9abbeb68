"""Lifting every track (``gymtrack pose --all-tracks``): person-frames per second with 4 views.

The pose stage on a whole routine with every person lifted (target, coaches, judges, gymnasts):
a simulated routine (4 views) is tracked (cascade), the simulated pose model runs on every
track's boxes, and :func:`gymtrack.pose.stage.lift_poses` with ``all_tracks=True`` assigns the
poses to the tracks and lifts each (``robust``, plane anchoring). A person-frame is one (frame,
track) row of ``poses_3d.csv``. Target: >= 500 person-frames per second. The best wall time of
``--repeat`` runs counts (the machine is shared); this process's CPU time is shown beside it.

Accuracy beside the speed: PCP (Shelf protocol: a limb is correct when both its ends lie within
half the limb's length of the truth) of every lifted (frame, track) against the simulated person
it lies on (the one whose true joints are nearest, within 0.5 m on average), over the limbs upper
arm, forearm, thigh, shin and the torso; beside it, how many true person-frames lie in the
tracking space.

A crowd (``--crowd N``, :func:`gymtrack.simulate.crowd.simulate_crowd`): the same routine plus N
people (gymnasts and coaches) standing within arm's reach of each other beside the apparatus
and gesturing, so that their boxes overlap in every view and the simulated top-down model's
crops often hold a neighbour (its crop confusion, :func:`gymtrack.simulate.pose_view.choose_person`).

Usage::

    python benchmarks/bench_all_tracks.py [--apparatus balance_beam] [--seconds 30] [--repeat 3] [--crowd 6]
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from gymtrack.pose.stage import lift_poses, pose_model_boxes
from gymtrack.simulate import simulate_routine
from gymtrack.simulate.crowd import simulate_crowd
from gymtrack.simulate.pose_model import simulate_pose_model
from gymtrack.tracking import track_detections


LIMBS = {"upper arm": ("shoulder", "elbow"), "forearm": ("elbow", "wrist"), "thigh": ("hip", "knee"),
         "shin": ("knee", "ankle")}


def pcp(out, sim) -> dict:
    """Shelf-protocol PCP per limb kind of the lifted poses against the nearest true person."""
    from gymtrack.scene import in_box
    from gymtrack.skeletons import COCO17

    p = out.poses3d
    fi = np.searchsorted(sim.frames, p.frame)
    truth = sim.keypoints[:, fi, :, :3].transpose(1, 0, 2, 3)  # (M, P, 17, 3)
    idx = p.skeleton.index(COCO17.joints)
    est = p.xyz[:, idx]  # (M, 17, 3)
    with np.errstate(invalid="ignore"), warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # a person absent in that frame: all NaN
        d = np.nanmean(np.linalg.norm(truth - est[:, None], axis=-1), axis=-1)  # (M, P)
    d = np.where(np.isfinite(d), d, np.inf)
    who = np.argmin(d, axis=1)
    ok = d[np.arange(len(p)), who] < 0.5
    gt = truth[np.arange(len(p)), who][ok]
    est = est[ok]
    j = {n: i for i, n in enumerate(COCO17.joints)}
    res = {}
    for name, (a, b) in LIMBS.items():
        hits = []
        for side in ("left", "right"):
            ia, ib = j[f"{side}_{a}"], j[f"{side}_{b}"]
            L = np.linalg.norm(gt[:, ia] - gt[:, ib], axis=-1)
            good = (np.linalg.norm(est[:, ia] - gt[:, ia], axis=-1) <= L / 2) & \
                   (np.linalg.norm(est[:, ib] - gt[:, ib], axis=-1) <= L / 2)
            hits.append(good)
        res[name] = float(np.mean(hits))
    ms, mh = 0.5 * (gt[:, j["left_shoulder"]] + gt[:, j["right_shoulder"]]), 0.5 * (gt[:, j["left_hip"]] + gt[:, j["right_hip"]])
    es, eh = 0.5 * (est[:, j["left_shoulder"]] + est[:, j["right_shoulder"]]), 0.5 * (est[:, j["left_hip"]] + est[:, j["right_hip"]])
    L = np.linalg.norm(ms - mh, axis=-1)
    res["torso"] = float(np.mean((np.linalg.norm(es - ms, axis=-1) <= L / 2) & (np.linalg.norm(eh - mh, axis=-1) <= L / 2)))
    res["all"] = float(np.mean([res[k] for k in ("upper arm", "forearm", "thigh", "shin")] * 2 + [res["torso"]]))
    inside = in_box(sim.centre, sim.scene.tracking_space) & sim.alive  # (P, T)
    res["matched"], res["inside"] = int(ok.sum()), int(inside.sum())
    return res


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--apparatus", default="balance_beam")
    ap.add_argument("--seconds", type=float, default=30)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--method", default="robust")
    ap.add_argument("--no-bbox", action="store_true", help="drop the poses' crop boxes, as a bottom-up model gives them")
    ap.add_argument("--box-only", action="store_true", help="assign by box overlap only (no joint-level pass)")
    ap.add_argument("--crowd", type=int, default=0, metavar="N",
                    help="add a group of N people within arm's reach beside the apparatus (simulate.crowd)")
    a = ap.parse_args()
    if a.crowd:
        sim = simulate_crowd(a.apparatus, n_cam=4, seed=a.seed, seconds=a.seconds, size=a.crowd)
    else:
        sim = simulate_routine(a.apparatus, n_cam=4, seed=a.seed, seconds=a.seconds)
    res = track_detections(sim.rig, sim.scene, sim.detections, mode="cascade")
    poses = simulate_pose_model(sim.rig, sim.keypoints, sim.person_id, sim.frames, pose_model_boxes(res, True), seed=a.seed)
    poses.track_id[:] = -1  # as a pose model run on its own gives them: assigned by their boxes
    if a.no_bbox:
        poses.bbox[:] = np.nan
    best, cpu, out = float("inf"), 0.0, None
    for _ in range(a.repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = lift_poses(res, sim.rig, sim.scene, poses, all_tracks=True, method=a.method, joints=not a.box_only)
        dt = time.perf_counter() - t0
        if dt < best:
            best, cpu = dt, time.process_time() - c0
    n = len(out.poses3d)
    s = out.summary()
    print(f"{a.apparatus}, {a.seconds:g} s, 4 views, {len(sim.frames)} frames: {len(poses)} 2D poses, "
          f"{s['tracks_with_pose']} tracks lifted, {n} person-frames ({a.method})")
    print(f"all-tracks lifting: {best:.2f} s wall ({cpu:.2f} s CPU) = {n / best:.0f} person-frames/s "
          f"(target >= 500)")
    r = pcp(out, sim)
    print("PCP: " + ", ".join(f"{k} {r[k]:.3f}" for k in (*LIMBS, "torso", "all"))
          + f" over {r['matched']} lifted person-frames on a true person ({r['inside']} true person-frames in the "
          "tracking space)")


if __name__ == "__main__":
    main()
