"""Peak memory of the streaming tracker against stream length (an endless stream).

Paper: Section III, Fig. 2 -- the tracker is online; a one-hour routine session at 30 fps is
108,000 frames. The claim checked here: the streaming :class:`gymtrack.tracking.Tracker` runs
at bounded memory, peak RSS of a 108,000-frame stream within 1.2 x that of a 10,000-frame one.

Usage::

    python benchmarks/bench_stream.py [--frames 10000 108000] [--people 12] [--chunk 1000]

Every length runs in a fresh subprocess (peak RSS only grows within a process). The detections
are synthetic and made on the fly, ``--chunk`` frames at a time, never the whole stream: the
rig and scene of ``examples/balance_beam`` (4 cameras), ``--people`` people -- one gymnast
swinging high over the beam, the rest walking around it -- who leave and are replaced every
few hundred frames (so track ids keep growing while the crowd does not); a person is a 3D box
whose projected corners give each view's box (pixel noise, 5 % missed boxes). The tracker's
outputs are counted and dropped, as a consumer of the stream would. Prints, per length: frames,
boxes, seconds, frames per second, the tracker's held state (:meth:`Tracker.state_size`) at the
end, and peak RSS; then the ratio of the longest to the shortest. Exit status 1 when the ratio
exceeds ``--max-ratio``.

Measured (shared 2-core machine): peak RSS 278.5 MB at 10,000 frames, 278.5 MB at 30,000,
279.7 MB at 108,000 (ratio 1.004; 256 MB of it before the first frame: numpy, scipy, OpenCV,
numba's kernels); the tracker's held state at most 1,344 / 1,344 / 1,707 rows while ~3,000
tracks came and went; 1,400-2,600 frames per second with ~10 boxes per view.
"""

from __future__ import annotations

import argparse
import json
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

from gymtrack.detections import Detections

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "balance_beam"
#: metres: a person's half width, half depth and height (the 3D box the views see)
BODY = (0.25, 0.2, 1.75)
LIFE = (200, 900)  # frames a walker stays before someone else takes the place


def rig_and_scene():
    from gymtrack.formats.calibration import read_calibration
    from gymtrack.formats.scene import load_scene

    rig, _ = read_calibration(EXAMPLE / "cameras.yaml")
    return rig, load_scene(EXAMPLE / "scene.yaml")


class Crowd:
    """``people`` 3D positions per frame, generated a chunk at a time (seeded per chunk)."""

    def __init__(self, people: int, seed: int = 0):
        self.P, self.seed = people, seed
        self.rng = np.random.default_rng(seed)
        self.pos = self.rng.uniform([-6, -4], [6, 4], size=(people, 2))
        self.vel = self.rng.normal(0, 0.02, size=(people, 2))
        self.left = self.rng.integers(*LIFE, size=people)  # frames until replaced

    def chunk(self, f0: int, n: int) -> np.ndarray:
        """(n, P, 3) body centres of frames f0 .. f0 + n - 1 (P = people; person 0 the gymnast)."""
        out = np.empty((n, self.P, 3))
        for k in range(n):  # walkers: a damped random walk kept around the apparatus
            self.vel = 0.95 * self.vel + self.rng.normal(0, 0.004, size=self.vel.shape)
            self.pos = np.clip(self.pos + self.vel, [-7, -5], [7, 5])
            self.left -= 1
            new = self.left <= 0
            if new.any():  # a new person takes the place: a new 2D and 3D track
                self.pos[new] = self.rng.uniform([-6, -4], [6, 4], size=(int(new.sum()), 2))
                self.left[new] = self.rng.integers(*LIFE, size=int(new.sum()))
            out[k, :, :2] = self.pos
        out[:, :, 2] = BODY[2] / 2
        t = np.arange(f0, f0 + n)  # the gymnast swings over the beam, rising above 2 m
        out[:, 0] = np.stack([2.5 * np.sin(t / 40), 0.05 * np.sin(t / 7), 1.7 + 0.8 * np.sin(t / 10)], axis=1)
        return out


def detections_of(rig, centres: np.ndarray, f0: int, rng) -> Detections:
    """Raw-pixel boxes (bounding boxes of the projected 3D box corners) of every view."""
    n, P, _ = centres.shape
    sx, sy, h = BODY
    corners = np.array([[x, y, z] for x in (-sx, sx) for y in (-sy, sy) for z in (-h / 2, h / 2)])
    X = centres[:, :, None, :] + corners  # (n, P, 8, 3)
    frames, cams, boxes = [], [], []
    for c, cam in enumerate(rig):
        uv = cam.project(X)  # (n, P, 8, 2)
        lo, hi = np.nanmin(uv, axis=2), np.nanmax(uv, axis=2)
        ok = np.isfinite(lo).all(axis=2) & cam.in_image((lo + hi) / 2) & (cam.depth(centres) > 0)
        ok &= rng.random(ok.shape) > 0.05
        f, p = np.nonzero(ok)
        xywh = np.concatenate([(lo[f, p] + hi[f, p]) / 2, hi[f, p] - lo[f, p]], axis=1)
        xywh[:, :2] += rng.normal(0, 1.0, size=(len(f), 2))
        frames.append(f0 + f)
        cams.append(np.full(len(f), c))
        boxes.append(xywh)
    det = Detections.from_arrays(np.concatenate(frames), np.concatenate(cams), np.concatenate(boxes), rig.names)
    return det.sorted()


def peak_rss_mb() -> float:
    """This process's peak resident memory: VmHWM where /proc has it (ru_maxrss keeps, across exec,
    the peak of the process that forked this one), else ru_maxrss."""
    try:
        with open("/proc/self/status") as fh:
            return [int(line.split()[1]) for line in fh if line.startswith("VmHWM")][0] / 1024
    except (OSError, IndexError):
        return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024


def run_stream(frames: int, people: int, chunk: int) -> dict:
    """One stream in this process: returns its figures (peak RSS in MB)."""
    from gymtrack.tracking import Tracker

    rig, scene = rig_and_scene()
    tracker = Tracker(rig, scene)  # compiles / loads the kernels first: not stream time
    rss0 = peak_rss_mb()
    crowd, rng = Crowd(people), np.random.default_rng(1)
    boxes = points = target = 0
    state = []
    t0 = time.perf_counter()
    for f0 in range(0, frames, chunk):
        det = detections_of(rig, crowd.chunk(f0, min(chunk, frames - f0)), f0, rng)
        boxes += len(det)
        fr, first = np.unique(det.frame, return_index=True)
        bounds = np.r_[first, len(det)]
        for i, f in enumerate(fr.tolist()):
            out = tracker.update(f, det.select(slice(bounds[i], bounds[i + 1])))
            points, target = points + len(out.tracks), target + len(out.target)
        state.append(tracker.state_size())
    out = tracker.finish()
    seconds = time.perf_counter() - t0
    return {"frames": frames, "boxes": boxes, "boxes_per_view": round(boxes / frames / len(rig), 1),
            "seconds": round(seconds, 1), "fps": round(frames / seconds, 1), "tracks": tracker.linker.next_track_id,
            "track_points": points + len(out.tracks), "target_frames": target + len(out.target),
            "state_max": max(state), "state_end": state[-1],
            "rss_start_mb": round(rss0, 1), "rss_peak_mb": round(peak_rss_mb(), 1)}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, nargs="+", default=[10_000, 108_000])
    ap.add_argument("--people", type=int, default=12)
    ap.add_argument("--chunk", type=int, default=1000)
    ap.add_argument("--max-ratio", type=float, default=1.2)
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args(argv)
    if a.child:
        print(json.dumps(run_stream(a.frames[0], a.people, a.chunk)))
        return 0
    rows = []
    for n in sorted(a.frames):
        p = subprocess.run([sys.executable, __file__, "--child", "--frames", str(n), "--people", str(a.people),
                            "--chunk", str(a.chunk)], capture_output=True, text=True, check=True)
        rows.append(json.loads(p.stdout.strip().splitlines()[-1]))
        r = rows[-1]
        print(f"{r['frames']:>8} frames  {r['boxes_per_view']:>5} boxes/view  {r['seconds']:>7} s  {r['fps']:>7} fps  "
              f"{r['tracks']:>6} tracks  state max {r['state_max']:>6}  RSS start {r['rss_start_mb']:>7} MB  "
              f"peak {r['rss_peak_mb']:>7} MB", flush=True)
    ratio = rows[-1]["rss_peak_mb"] / rows[0]["rss_peak_mb"]
    ok = ratio <= a.max_ratio
    print(f"peak RSS {rows[-1]['frames']} / {rows[0]['frames']} frames: {ratio:.3f} (target <= {a.max_ratio}): "
          f"{'ok' if ok else 'FAILED'}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
