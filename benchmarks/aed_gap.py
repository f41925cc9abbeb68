"""Where a method's target AED exceeds the oracle's: the gap taken apart frame by frame.

The benchmark's claim "AED cascade <= 1.25 x oracle" (:func:`gymtrack.eval.aggregate.claims`)
compares the apparatus-averaged AED of each method, each pooled over the performing frames
*it* covers (:func:`gymtrack.eval.metrics.average_euclidean_distance`). With ``R`` that ratio
and ``M_a``, ``O_a`` the pooled AED of the method and the oracle on apparatus ``a``,
``R - 1 = sum_a (M_a - O_a) / sum_a O_a``: this script splits every apparatus' share of it by
what happened at each frame both cover, in this order (the first that holds):

``other_person``
    the method's target follows a track with no box of the gymnast at that frame (a phantom of
    other people's boxes, a bystander, a false positive) -- an identification (Eq. 13) on a
    track the oracle's association never builds;
``gap_fill``
    the method's target point is interpolated (no view) there;
``mixed``
    the target track holds the gymnast's box in some views and someone else's in others (a
    wrong member of the cluster);
``views``
    only the gymnast's boxes, but not the oracle's set of views;
``source``
    the same views, a different source (plane candidate vs triangulation);
``same``
    the same views and source: the estimator, linking and smoothing alone;

plus ``cover``: what the two methods' different frame sets change (each AED is over its own
frames). The boxes of the target's track at each frame are labelled with the ground-truth person
by :func:`gymtrack.eval.gt.match_detections_to_gt` (IoU >= 0.5), as the oracle's input is. Also
printed: the same ratio over the frames both cover, and the runs of frames where the method's
target is more than 0.5 m worse than the oracle's because it follows someone else.

Usage::

    python benchmarks/aed_gap.py --suite SUITE [-m cascade -m cascade+] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import sys
import warnings
from collections import defaultdict

import numpy as np

from gymtrack.apparatus import APPARATUS_NAMES
from gymtrack.eval.benchmark import read_suite, run_method
from gymtrack.eval.gt import load_ground_truth, match_detections_to_gt
from gymtrack.eval.metrics import pairs_by_key
from gymtrack.formats.routine import load_routine
from gymtrack.tracking.types import INTERPOLATED

CATEGORIES = ("same", "source", "views", "mixed", "gap_fill", "other_person")


def per_frame(res, gt, frames: np.ndarray) -> dict[str, np.ndarray]:
    """Per performing frame (F,): the target's error (NaN: no output), source, and its track's
    boxes at that frame: views with the gymnast's box (bit mask), count of the gymnast's and of
    other boxes."""
    t, tg = gt.target(), res.target
    F = frames.size
    xyz, src, tid = np.full((F, 3), np.nan), np.full(F, -1), np.full(F, -1, np.int64)
    ia, ib = pairs_by_key(tg.frame, frames)
    xyz[ib], src[ib], tid[ib] = tg.xyz[ia], tg.source[ia], tg.track_id[ia]
    truth = np.full((F, 3), np.nan)
    ja, jb = pairs_by_key(t.frame, frames)
    truth[jb] = t.xyz[ja]
    mine, other, mask = np.zeros(F, int), np.zeros(F, int), np.zeros(F, np.int64)
    b = res.boxes
    if len(b):
        span = int(max(frames.max(), b.frame.max())) + 1
        has = tid >= 0
        ka, kb = pairs_by_key(b.track_id.astype(np.int64) * span + b.frame, np.where(has, tid * span + frames, -1))
        gymnast = match_detections_to_gt(b, gt).person_id[ka] == gt.target_id
        np.add.at(mine, kb[gymnast], 1)
        np.add.at(other, kb[~gymnast], 1)
        np.bitwise_or.at(mask, kb[gymnast], np.left_shift(1, b.camera[ka[gymnast]].astype(np.int64)))
    return {"err": np.linalg.norm(xyz - truth, axis=1), "src": src, "mine": mine, "other": other, "mask": mask}


def categorise(m: dict, o: dict) -> np.ndarray:
    """(F,) index into :data:`CATEGORIES` of each frame (meaningful where both have an output)."""
    cat = np.zeros(m["src"].size, int)
    cat[m["src"] != o["src"]] = CATEGORIES.index("source")
    cat[m["mask"] != o["mask"]] = CATEGORIES.index("views")
    cat[m["other"] > 0] = CATEGORIES.index("mixed")
    nobox = (m["mine"] == 0) & (m["other"] == 0)
    cat[nobox & (m["src"] == INTERPOLATED)] = CATEGORIES.index("gap_fill")
    cat[(m["mine"] == 0) & ~(nobox & (m["src"] == INTERPOLATED))] = CATEGORIES.index("other_person")
    return cat


def run(suite: str, methods: list[str]) -> list[dict]:
    """One entry per routine: apparatus, n_cam, frames and :func:`per_frame` of each method and the oracle."""
    out = []
    for spec in read_suite(suite):
        r = load_routine(spec.path)
        gt = load_ground_truth(spec.path, r.rig.names, image_size=np.array([c.size for c in r.rig], float))
        t = gt.target()
        perf = np.unique(t.frame[t.performing(np.asarray(r.scene.performance_space, float))])
        entry = {"routine": spec.name, "apparatus": spec.apparatus, "n_cam": spec.n_cam, "frames": perf}
        for m in [*methods, "oracle"]:
            entry[m] = per_frame(run_method(m, r.rig, r.scene, r.detections, gt)[0], gt, perf)
        out.append(entry)
        print(f"tracked {spec.name}", file=sys.stderr, flush=True)
    return out


def decompose(routines: list[dict], method: str) -> tuple[dict, list[str]]:
    """R - 1 taken apart: per n_cam, ``{"keys": [(apparatus, n_cam)], "M", "O": pooled AED of the
    method and the oracle per key, "Mb", "Ob": the same over the frames both cover, "R": the
    ratio, "parts": per key (len(CATEGORIES) + 1,) shares of R - 1 (the categories, then
    ``cover``), "n": per key frames of each category}``; and the runs of frames where the
    method's target follows someone else, > 0.5 m worse than the oracle's.

    routines: :func:`run`'s entries (``frames``, and per method ``err``, ``src``, ``mine``,
    ``other``, ``mask``). The parts of a key add up to ``(M - O) / sum(O)``: the categories split
    the frames both cover, and ``cover`` is the rest."""
    acc: dict = defaultdict(lambda: defaultdict(float))
    events = []
    for e in routines:
        m, o = e[method], e["oracle"]
        me, oe = m["err"], o["err"]
        fm, fo = np.isfinite(me), np.isfinite(oe)
        both = fm & fo
        a = acc[(e["apparatus"], e["n_cam"])]
        a["m_sum"] += me[fm].sum(); a["m_n"] += fm.sum(); a["o_sum"] += oe[fo].sum(); a["o_n"] += fo.sum()
        a["mb_sum"] += me[both].sum(); a["ob_sum"] += oe[both].sum(); a["b_n"] += both.sum(); a["F"] += me.size
        cat = categorise(m, o)
        for k, c in enumerate(CATEGORIES):
            s = both & (cat == k)
            a[c] += (me[s] - oe[s]).sum()
            a[f"n_{c}"] += s.sum()
        bad = np.flatnonzero(both & (cat >= CATEGORIES.index("gap_fill")) & (me - oe > 0.5))
        for run_ in (np.split(bad, np.flatnonzero(np.diff(bad) > 3) + 1) if bad.size else []):
            if run_.size >= 5:
                rel = e["frames"][run_] - e["frames"][0]
                events.append(f"{e['routine']}: performing frames {rel[0]}-{rel[-1]} of {e['frames'].size}, "
                              f"{run_.size} frames {np.mean(me[run_]):.1f} m off (oracle {np.mean(oe[run_]):.2f} m)")
    out = {}
    for n in sorted({k[1] for k in acc}):
        keys = [(app, n) for app in APPARATUS_NAMES if (app, n) in acc]
        M = {k: acc[k]["m_sum"] / acc[k]["m_n"] for k in keys}
        O = {k: acc[k]["o_sum"] / acc[k]["o_n"] for k in keys}
        Mb = {k: acc[k]["mb_sum"] / acc[k]["b_n"] for k in keys}
        Ob = {k: acc[k]["ob_sum"] / acc[k]["b_n"] for k in keys}
        so = sum(O.values())
        parts = {k: np.array([acc[k][c] / acc[k]["b_n"] / so for c in CATEGORIES] + [((M[k] - Mb[k]) - (O[k] - Ob[k])) / so])
                 for k in keys}
        out[n] = {"keys": keys, "M": M, "O": O, "Mb": Mb, "Ob": Ob, "R": sum(M.values()) / so, "parts": parts,
                  "n": {k: {c: int(acc[k]["n_" + c]) for c in CATEGORIES} for k in keys}}
    return out, events


def report(routines: list[dict], method: str) -> None:
    gap, events = decompose(routines, method)
    for n, g in gap.items():
        keys, M, O, Mb, Ob = g["keys"], g["M"], g["O"], g["Mb"], g["Ob"]
        so = sum(O.values())
        print(f"\nn_cam {n}: AED {method} / oracle = {g['R']:.3f} "
              f"({sum(M.values()) / len(keys):.3f} / {so / len(keys):.3f} m); over the frames both cover "
              f"{sum(Mb.values()) / sum(Ob.values()):.3f}")
        print(f"  share of R - 1 by frame kind (ratio points); frames of each kind\n  {'apparatus':15s} {'AED':>6s} {'oracle':>6s} "
              + " ".join(f"{c[:8]:>8s}" for c in (*CATEGORIES, "cover")) + "  | " + " ".join(f"{c[:6]:>6s}" for c in CATEGORIES[1:]))
        total = np.zeros(len(CATEGORIES) + 1)
        for k in keys:
            parts = g["parts"][k]
            total += parts
            print(f"  {k[0]:15s} {M[k]:6.3f} {O[k]:6.3f} " + " ".join(f"{v:+8.3f}" for v in parts)
                  + "  | " + " ".join(f"{g['n'][k][c]:6d}" for c in CATEGORIES[1:]))
        print(f"  {'all':15s} {'':6s} {'':6s} " + " ".join(f"{v:+8.3f}" for v in total) + f"   (sum {total.sum():+.3f})")
    print(f"\n{method}: runs of >= 5 frames where its target follows someone else, > 0.5 m worse than the oracle's:")
    print("\n".join(f"  {x}" for x in events) or "  none")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--suite", required=True, help="suite folder (gymtrack simulate-suite)")
    ap.add_argument("-m", "--method", action="append", help="compared with the oracle (repeat; default cascade)")
    ap.add_argument("--json", help="also write the per-frame rows here")
    args = ap.parse_args()
    methods = args.method or ["cascade"]
    warnings.filterwarnings("ignore")
    routines = run(args.suite, methods)
    for m in methods:
        report(routines, m)
    if args.json:
        with open(args.json, "w") as fh:
            json.dump([{k: (v.tolist() if isinstance(v, np.ndarray) else {q: w.tolist() for q, w in v.items()}
                            if isinstance(v, dict) else v) for k, v in e.items()} for e in routines], fh)


if __name__ == "__main__":
    main()
