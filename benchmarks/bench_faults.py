"""The venue check's figures: sync accuracy, knock detection, false alarms, AED after correction.

Beyond the paper. Simulated routines (``--seconds`` long, ``--seeds`` per apparatus, the seven
apparatus, n_cam 3 and 4; other people are seen by all four cameras) get one fault each
(:mod:`gymtrack.eval.faults`), in a seeded camera:

- sync: one camera's frames moved by a seeded offset in +-1..+-8; exact when
  :func:`gymtrack.tracking.sync.estimate_offsets` returns that offset for it and 0 for the others.
  At n_cam 2 the rig is cut to the opposite pair cam0/cam1 (a two-camera venue).
  Target AED (cascade+) of the resynchronised boxes against the synchronised run.
- knock: a ``--degrees`` turn of one camera at mid-routine; detected when the tracker's summary
  names that camera within 5 s; a false alarm is any other event, and any event on the clean
  routine. Target AED with re-estimation against the unknocked run; the turn the offline second
  pass applied against the simulator's (degrees), and the frame it applied it from against the knock's.

Usage::

    python benchmarks/bench_faults.py [--seconds 20] [--seeds 2 | --seed-list 3,4] [--apparatus all] [--part sync|sync-only|knock|both]  (sync-only: no AED runs)
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np

from gymtrack.apparatus import APPARATUS_NAMES
from gymtrack.eval.benchmark import evaluate_routine
from gymtrack.eval.fault_bench import resynchronise
from gymtrack.eval.faults import desync_camera, knock_camera, knock_rotation
from gymtrack.simulate.routine import simulate_n_cams
from gymtrack.tracking import offline
from gymtrack.tracking.offline import track_detections
from gymtrack.tracking.sync import estimate_offsets
from gymtrack.tracking.turn_fit import degrees


APPLIED: dict = {}  # the turns the offline second pass applied: {camera: (from frame, rotation)}


def _recording(*args):
    if len(args) > 8 and args[8]:
        APPLIED.update(args[8])
    return _pass(*args)


_pass, offline._track = offline._track, _recording


def aed(sim, det, rig=None, recalibrate=True):
    rig = rig or sim.rig
    APPLIED.clear()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        res = track_detections(rig, sim.scene, det, mode="cascade+", watch_cameras=True, recalibrate=recalibrate)
    row = evaluate_routine(res, sim.ground_truth(), sim.scene, sim.rig, mot=False)
    return row["aed_sum"] / max(row["aed_n"], 1), res.summary


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--seconds", type=float, default=20)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--seed-list", default=None, help="comma-separated seeds (held-out ones); replaces --seeds")
    ap.add_argument("--apparatus", default="all")
    ap.add_argument("--part", default="both")
    ap.add_argument("--degrees", type=float, nargs="+", default=[0.5, 1.0])
    a = ap.parse_args()
    apps = APPARATUS_NAMES if a.apparatus == "all" else a.apparatus.split(",")
    sync_rows, knock_rows, clean_alarms, n_clean = [], [], 0, 0
    t0 = time.time()
    for app in apps:
        for seed in ([int(x) for x in a.seed_list.split(",")] if a.seed_list else range(a.seeds)):
            sims = simulate_n_cams(app, seed=seed, seconds=a.seconds, n_cams=(2, 3, 4))
            rng = np.random.default_rng(seed * 100 + len(app))
            for n, sim in sims.items():
                cam = int(rng.integers(1, 4 if n > 2 else 2))
                d = int(rng.integers(1, 9)) * int(rng.choice([-1, 1]))
                rig, det = sim.rig, sim.detections
                if n == 2:  # a two-camera venue: the opposite pair only
                    rig = rig.subset(rig.names[:2])
                    det = det.select(np.flatnonzero(det.camera < 2))
                if a.part in ("sync", "sync-only", "both"):
                    bad = desync_camera(det, cam, d)
                    res = estimate_offsets(bad, rig)
                    want = np.zeros(len(rig), int)
                    want[cam] = d
                    row = {"app": app, "seed": seed, "n_cam": n, "cam": cam, "offset": d, "found": res.offsets.tolist(),
                           "exact": bool(np.array_equal(res.offsets, want)), "conf": round(float(res.confidence[cam]), 2)}
                    if n > 2 and a.part != "sync-only":
                        clean, _ = aed(sim, det)
                        fixed, _ = resynchronise(bad, rig)
                        late, _ = aed(sim, bad)
                        row |= {"aed_clean": clean, "aed_fault": late, "aed_fixed": aed(sim, fixed)[0]}
                    sync_rows.append(row)
                    print("sync", row, flush=True)
                if a.part in ("knock", "both") and n > 2:
                    clean, summ = aed(sim, det)
                    n_clean += 1
                    clean_alarms += len(summ.get("camera_moved", []))
                    mid = int((det.frame.min() + det.frame.max()) // 2)
                    for deg in a.degrees:
                        truth = knock_rotation(deg, seed + cam)
                        bad = knock_camera(det, rig[cam], cam, mid, truth)
                        fixed, s = aed(sim, bad, recalibrate=True)
                        applied = APPLIED.get(cam)
                        plain, _ = aed(sim, bad, recalibrate=False)
                        ev = s.get("camera_moved", [])
                        hit = [e for e in ev if e["camera"] == rig.names[cam] and mid - 30 <= e["start_frame"]
                               and e["detected_frame"] <= mid + 5 * sim.scene.fps]
                        row = {"app": app, "seed": seed, "n_cam": n, "cam": cam, "deg": deg, "detected": bool(hit),
                               "other_events": len(ev) - len(hit), "events": ev, "aed_clean": clean,
                               "aed_knocked": plain, "aed_recal": fixed,
                               "turn_error": None if applied is None else round(degrees(applied[1] @ truth.T), 3),
                               "start_error": None if applied is None else applied[0] - mid}
                        knock_rows.append(row)
                        print("knock", row, flush=True)
    print(f"--- {time.time() - t0:.0f} s")
    for n in (2, 3, 4):
        rs = [r for r in sync_rows if r["n_cam"] == n]
        if rs:
            print(f"sync n_cam {n}: exact {sum(r['exact'] for r in rs)}/{len(rs)}")
    rs = [r for r in sync_rows if "aed_fixed" in r]
    if rs:
        ratio = np.array([r["aed_fixed"] / r["aed_clean"] for r in rs])
        print(f"sync AED resynchronised / synchronised: mean {ratio.mean():.3f}, max {ratio.max():.3f}; "
              f"desynchronised / synchronised: mean {np.mean([r['aed_fault'] / r['aed_clean'] for r in rs]):.3f}")
    for deg in a.degrees:
        rs = [r for r in knock_rows if r["deg"] == deg]
        if rs:
            ratio = np.array([r["aed_recal"] / r["aed_clean"] for r in rs])
            print(f"knock {deg} deg: detected right camera within 5 s {sum(r['detected'] for r in rs)}/{len(rs)}, "
                  f"other events {sum(r['other_events'] for r in rs)}; AED recalibrated / unknocked mean {ratio.mean():.3f} "
                  f"max {ratio.max():.3f}; knocked (no re-estimation) / unknocked mean "
                  f"{np.mean([r['aed_knocked'] / r['aed_clean'] for r in rs]):.3f}")
            err = np.array([r["turn_error"] for r in rs if r["turn_error"] is not None])
            start = np.array([r["start_error"] for r in rs if r["start_error"] is not None])
            if len(err):
                fixed = np.array([r["aed_recal"] / r["aed_clean"] for r in rs if r["turn_error"] is not None])
                print(f"knock {deg} deg: applied turn's error (deg) mean {err.mean():.3f} max {err.max():.3f} "
                      f"({len(err)} applied: their AED ratio mean {fixed.mean():.3f} max {fixed.max():.3f}); start "
                      f"frame - knock frame median {np.median(start):.0f}, range {start.min()}..{start.max()}")
    if n_clean:
        print(f"clean routines: {clean_alarms} alarms over {n_clean} routines")


if __name__ == "__main__":
    main()
