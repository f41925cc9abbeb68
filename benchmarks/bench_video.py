"""The pipeline's own work around the models, in ms per multi-view frame (four 1080p cameras).

The target: decode, resize/letterbox, crops, output decoding, tracking and lifting
must keep up with four 1080p cameras at 30 frames per second (total < 33 ms per multi-view
frame) on this machine; the models' own inference is not counted (it depends on the model and
the accelerator) but the stand-ins' time is shown apart.

Usage::

    python benchmarks/bench_video.py [--frames 60] [--seconds 10] [--tracks 2]

* decode: four H.264 1080p videos (moving shapes on a gradient, libx264 default preset) read
  together by :class:`gymtrack.formats.video.VideoSet` (one thread per camera, the next frame
  decoded ahead).
* letterbox: the four frames to the detector's 640 x 640 input (top-left, padding 114) and to a
  (4, 3, 640, 640) float32 blob.
* crops: ``--tracks`` boxes per view (the target's b_buf and others) -> affine crops 256 x 192
  and the normalised (N, 3, 256, 192) blob.
* output decoding: a YOLOX raw output (4, 8400, 85) with low background scores and 12 people
  (5 anchors each, so NMS has work) -> boxes in raw pixels; SimCC outputs (N, 17, 384/512) ->
  keypoints in raw pixels.
* tracking: ``track_detections`` on a simulated 4-camera vault routine (``--seconds``), per frame.
* lifting: ``lift_poses`` of the target from the simulated pose model in its b_buf, per frame.

Every step runs a warm-up pass, then the best of ``--repeat`` passes counts (the machine is shared).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))


def make_videos(folder: Path, n: int, cams: int = 4) -> list[Path]:
    import cv2

    from gymtrack.formats.video import write_video

    yy, xx = np.mgrid[0:1080, 0:1920]
    base = np.stack([(xx / 1920 * 200).astype(np.uint8), (yy / 1080 * 200).astype(np.uint8),
                     np.full_like(xx, 60, np.uint8)], -1).astype(np.uint8)
    paths = []
    for c in range(cams):
        def frames(c=c):
            for i in range(n):
                im = base.copy()
                for k in range(6):
                    x = int(200 + 250 * k + 6 * i + 40 * c) % 1800
                    cv2.rectangle(im, (x, 500), (x + 90, 800), (30 * k, 200 - 20 * k, 120), -1)
                    cv2.circle(im, (x + 45, 470), 30, (200, 180, 160), -1)
                yield im
        p = folder / f"cam{c}.mp4"
        write_video(p, frames(), 30)
        paths.append(p)
    return paths


CPU: dict[float, float] = {}  # wall -> process CPU seconds of the same pass


def best(fn, repeat: int) -> float:
    """Best wall time of ``repeat`` passes (after a warm-up); its CPU time goes to :data:`CPU`."""
    fn()  # warm-up
    runs = []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        fn()
        runs.append((time.perf_counter() - t, time.process_time() - c))
    wall, cpu = min(runs)
    CPU[wall] = cpu
    return wall


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=60, help="video frames per camera")
    ap.add_argument("--seconds", type=float, default=10.0, help="length of the simulated routine for tracking/lifting")
    ap.add_argument("--tracks", type=int, default=2, help="pose crops per view")
    ap.add_argument("--repeat", type=int, default=3)
    a = ap.parse_args()

    from onnx_standins import affine_graph, yolox_rows

    from gymtrack.formats.video import VideoReader, VideoSet
    from gymtrack.models import Detector, PoseModel
    from gymtrack.models.image import letterbox_batch, to_blob
    from gymtrack.pose.stage import lift_poses
    from gymtrack.simulate import simulate_routine
    from gymtrack.simulate.pose_model import simulate_pose_model_for_routine
    from gymtrack.tracking.offline import track_detections

    F = a.frames
    ms: dict[str, float] = {}
    cpu_ms: dict[str, float] = {}

    def record(name: str, fn, per: int) -> None:
        wall = best(fn, a.repeat)
        ms[name], cpu_ms[name] = 1000 * wall / per, 1000 * CPU[wall] / per
    with tempfile.TemporaryDirectory() as tmp:
        tmp = Path(tmp)
        print(f"writing 4 x {F} frames of 1080p H.264 ...", flush=True)
        paths = make_videos(tmp, F)

        def decode():
            with VideoSet([VideoReader(p) for p in paths], [p.stem for p in paths]) as vs:
                for _ in vs.iter_frames():
                    pass
        record("decode (4 x 1080p H.264)", decode, F)
        with VideoSet([VideoReader(p) for p in paths], [p.stem for p in paths]) as vs:
            frames = [ims for _, ims in vs.iter_frames(range(1, 11))]

        # stand-in models with the real exports' signatures
        rng = np.random.default_rng(0)
        people = np.column_stack([rng.uniform(50, 590, 12), rng.uniform(100, 300, 12), rng.uniform(20, 60, 12),
                                  rng.uniform(60, 180, 12)])
        jitter = np.repeat(people, 5, axis=0) + rng.normal(0, 2, (60, 4)) * [1, 1, 0, 0]
        rows = yolox_rows((640, 640), jitter, rng.uniform(0.5, 0.95, 60), n_classes=80)
        rows[:, 4] = np.where(rows[:, 4] > 0, 0.95, rng.uniform(0, 0.05, len(rows)))
        rows[:, 5:] = np.maximum(rows[:, 5:], rng.uniform(0, 0.05, rows[:, 5:].shape).astype(np.float32))
        det = Detector(affine_graph(tmp / "yolox.onnx", ["batch", 3, 640, 640], [("output", rows[None], np.zeros_like(rows[None]))]))
        sx = rng.uniform(0, 0.1, (1, 17, 384)).astype(np.float32)
        sy = rng.uniform(0, 0.1, (1, 17, 512)).astype(np.float32)
        pm = PoseModel(affine_graph(tmp / "rtm.onnx", ["batch", 3, 256, 192],
                                    [("simcc_x", sx, np.zeros_like(sx)), ("simcc_y", sy, np.zeros_like(sy))], input_name="input"))

        def lb():
            for ims in frames:
                batch, _ = letterbox_batch(ims, (640, 640))
                to_blob(batch)
        record("letterbox 4 frames -> (4, 3, 640, 640)", lb, len(frames))

        N = 4 * a.tracks
        tlwh = np.column_stack([rng.uniform(300, 1500, N), rng.uniform(200, 500, N), rng.uniform(150, 300, N),
                                rng.uniform(300, 550, N)])
        cam_idx = np.repeat(np.arange(4), a.tracks)

        def crops():
            for ims in frames:
                pm.prepare(ims, cam_idx, tlwh)
        record(f"crops {N} boxes -> ({N}, 3, 256, 192)", crops, len(frames))

        blob, lbs = det.prepare(frames[0])
        out = det.infer(blob)
        shapes = [im.shape[:2] for im in frames[0]]
        record("detector output decoding (4 x 8400 x 85, NMS)", lambda: [det.decode(out, lbs, shapes) for _ in range(10)], 10)
        pblob, M = pm.prepare(frames[0], cam_idx, tlwh)
        pout = pm.infer(pblob)
        record("pose output decoding (SimCC)", lambda: [pm.decode(pout, M) for _ in range(10)], 10)
        stand_in = {"stand-in detector": 1000 * best(lambda: det.infer(blob), 1),
                    "stand-in pose model": 1000 * best(lambda: pm.infer(pblob), 1)}

    print(f"simulating {a.seconds:g} s of vault, 4 cameras ...", flush=True)
    sim = simulate_routine("vault", n_cam=4, seed=0, seconds=a.seconds)
    T = sim.n_frames
    track_detections(sim.rig, sim.scene, sim.detections)  # compiles the kernels
    res = {}

    def track():
        res["r"] = track_detections(sim.rig, sim.scene, sim.detections)
    record("tracking (cascade)", track, T)
    poses = simulate_pose_model_for_routine(sim, res["r"].target_boxes)
    record("lifting (robust, target)", lambda: lift_poses(res["r"], sim.rig, sim.scene, poses), T)

    total = sum(ms.values())
    cpu_total = sum(cpu_ms.values())
    w = max(map(len, ms)) + 2
    print(f"\n{'step':<{w}}   wall ms    CPU ms   per multi-view frame (4 cameras; CPU = this process, all threads)")
    for k, v in ms.items():
        print(f"{k:<{w}}{v:10.2f}{cpu_ms[k]:10.2f}")
    print(f"{'total':<{w}}{total:10.2f}{cpu_total:10.2f}   (target < 33 ms wall: {'met' if total < 33 else 'NOT met'})")
    try:
        import os

        print(f"load average {os.getloadavg()[0]:.1f} on {os.cpu_count()} CPUs (a shared machine inflates wall times)")
    except OSError:
        pass
    print("\nnot counted (stand-in models, CPU):", ", ".join(f"{k} {v:.1f} ms" for k, v in stand_in.items()))


if __name__ == "__main__":
    main()
