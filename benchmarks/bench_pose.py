"""Lifting speed: frames per second of ``dlt`` and ``robust`` for one target seen by 4 views.

The paper's Section III-D lifts the target's 2D poses per frame; the pose
stage must not be the bottleneck of a tracker that runs at >= 1000 frames per second. Target:
>= 2000 frames per second for ``robust`` lifting of one target in 4 views.

Usage::

    python benchmarks/bench_pose.py [--frames 1800] [--repeat 3] [--profile]

A 60 s (1800-frame) track of a COCO-17 body (walking gait while turning over, like a salto) is
seen by a random 4-camera rig with lens distortion; its 2D keypoints get 2 px noise, a few
missed joints, left/right swaps in one view and another person's pose in another (so the
robust path does all its work). Each method lifts the whole track in one call, ``--repeat``
times; the best wall time counts (the machine is shared) and this process's CPU time is shown
beside it. ``robust`` runs with the plane anchoring (centre and apparatus normal given), as the
pose stage calls it. ``--profile`` prints a cProfile of one robust call.
"""

from __future__ import annotations

import argparse
import cProfile
import pstats
import time

import numpy as np

from gymtrack.geometry import Camera, Rig
from gymtrack.geometry.camera import look_at
from gymtrack.pose import lift_track
from gymtrack.simulate.body import BodyModel, gait_angles
from gymtrack.skeletons import COCO17


def make_input(T: int, seed: int = 0):
    """rig, keypoints (T, 4, 17, 3), centre (T, 3), plane normal (3,), true joints (T, 17, 3)."""
    rng = np.random.default_rng(seed)
    cams = []
    for i in range(4):
        az = np.pi / 4 + i * np.pi / 2 + rng.uniform(-0.2, 0.2)
        pos = np.array([13 * np.cos(az), 13 * np.sin(az), rng.uniform(2, 6)])
        R, t = look_at(pos, np.array([0.0, 0.0, 1.2]))
        K = np.array([[1600.0, 0, 960], [0, 1600.0, 540], [0, 0, 1]])
        cams.append(Camera(f"cam{i}", (1920, 1080), K, R, t, np.array([-0.2, 0.05, 0, 0, 0])))
    rig = Rig(cams)
    s = np.arange(T) / 30.0
    rel, _ = BodyModel(1.6).oriented(gait_angles(2 * np.pi * s), np.zeros(T), np.pi * s, np.zeros(T))
    centre = np.stack([2 * np.sin(0.3 * s), 0.1 * np.cos(s), 1.2 + 0.3 * np.sin(s)], axis=1)
    X = rel[:, :17] + centre[:, None]
    kp = np.zeros((T, 4, 17, 3))
    for c, cam in enumerate(rig):
        kp[:, c, :, :2] = cam.project(X)
    kp[..., :2] += rng.normal(0, 2.0, kp[..., :2].shape)
    kp[..., 2] = rng.uniform(0.4, 1.0, kp.shape[:3])
    kp[rng.random(kp.shape[:3]) < 0.05, 2] = 0.0  # missed joints
    swap = rng.random(T) < 0.1
    kp[swap, 1] = kp[swap, 1][:, COCO17.flip]  # left/right swaps in view 1
    other = rng.random(T) < 0.05
    kp[other, 2, :, :2] += 120.0  # another person's pose in view 2
    return rig, kp, centre, np.array([0.0, 1.0, 0.0]), X


def timed(fn, repeat: int) -> tuple[float, float, object]:
    best_wall, best_cpu, out = np.inf, np.inf, None
    for _ in range(repeat):
        t0, c0 = time.perf_counter(), time.process_time()
        out = fn()
        best_wall = min(best_wall, time.perf_counter() - t0)
        best_cpu = min(best_cpu, time.process_time() - c0)
    return best_wall, best_cpu, out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--frames", type=int, default=1800)
    ap.add_argument("--repeat", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--profile", action="store_true")
    args = ap.parse_args()
    rig, kp, centre, normal, X = make_input(args.frames, args.seed)
    T = args.frames
    print(f"one target, {len(rig)} views, {T} frames, {kp.shape[2]} joints ({T * kp.shape[2]} joints to lift)")
    calls = {
        "dlt": lambda: lift_track(rig, kp, COCO17, "dlt"),
        "robust": lambda: lift_track(rig, kp, COCO17, "robust", centre=centre, plane_normal=normal),
    }
    calls["robust"]()  # warm-up (imports, caches) outside the clock
    for name, fn in calls.items():
        wall, cpu, res = timed(fn, args.repeat)
        err = np.linalg.norm(res.xyz - X, axis=2)
        print(f"{name:7s} {T / wall:8.0f} frames/s wall ({wall * 1e3:6.1f} ms), {T / cpu:8.0f} frames/s CPU; "
              f"MPJPE {np.nanmean(err) * 1e3:5.1f} mm on these keypoints")
    if args.profile:
        prof = cProfile.Profile()
        prof.runcall(calls["robust"])
        pstats.Stats(prof).sort_stats("tottime").print_stats(15)


if __name__ == "__main__":
    main()
