"""Where the target's failures come from: each failed (frame, view) pair of the FR given a cause.

Paper: Section IV-A's failure rate (Fig. 5), taken apart along the pipeline of Fig. 2. For every
performing frame where some view's ``b_buf`` fails, the frame gets the first cause that holds, in
the pipeline's order, and each of its failed pairs counts for it:

``no_detection``
    the detector gave no box of the gymnast in any view (input boxes labelled by ground truth,
    :func:`.gt.match_detections_to_gt`);
``box``
    the target's output centre is within ``near`` of the true one, yet the box fails (size,
    margin, or a view's projection: the estimate is right, b_buf is not);
``unclustered``
    no 3D track is within ``near`` of the gymnast and none of the tracks' 2D boxes is the gymnast's
    (its detections never made it into a cluster that was reported);
``phantom``
    no 3D track is within ``near``, but the gymnast's boxes are members of a track elsewhere (a
    wrong cluster, a phantom, took the gymnast's segment);
``identification``
    a track is within ``near`` of the gymnast, but the target follows another one, far away;
``linking``
    a track is within ``near`` of the gymnast, but the target has no output at that frame (its
    track broke and the target stage had not taken up the continuation).

The causes of one routine add up to the FR's failures. The tests are by place: for the oracle
(whose association is right) a ``phantom`` is its own track estimated more than ``near`` off (the
pommel horse's circling legs). Arrays: pairs ``(G,)``, frames ``(F,)``.
"""

from __future__ import annotations

from typing import Sequence

import numpy as np

from .gt import match_detections_to_gt
from .metrics import failure_rate, pairs_by_key

__all__ = ["CAUSES", "explain_failures", "explain_table", "explain_markdown"]

#: the causes, in the order they are tested
CAUSES: tuple[str, ...] = ("no_detection", "box", "unclustered", "phantom", "identification", "linking")


def _frames_near(frames: np.ndarray, xyz: np.ndarray, gt_frame: np.ndarray, gt_xyz: np.ndarray, near: float) -> np.ndarray:
    """(K,) the frames of ``frames`` (with points ``xyz``) whose point lies within ``near`` of the
    ground truth's point at that frame."""
    ia, ib = pairs_by_key(np.asarray(frames, np.int64), np.asarray(gt_frame, np.int64))
    ok = np.linalg.norm(np.asarray(xyz)[ia] - np.asarray(gt_xyz)[ib], axis=1) <= near
    return np.unique(np.asarray(frames)[ia[ok]])


def explain_failures(result, detections, gt, scene, rig=None, near: float = 0.5) -> dict[str, int]:
    """``{cause: failed (frame, view) pairs}`` for one output (a TrackResult) on one routine
    (``detections``: the tracker's input; ``gt``: its ground truth with the same cameras); the
    causes of :data:`CAUSES` sum to the FR's failures (also given, as ``failures``)."""
    perf_space = np.asarray(scene.performance_space, dtype=np.float64)
    t = gt.target()
    pid = gt.target_id
    perf_frames = np.unique(t.frame[t.performing(perf_space)])
    vis = t.box_visible & np.isin(t.box_frame, perf_frames)
    size = None if rig is None else np.array([c.size for c in rig], dtype=np.float64)
    tb = result.target_boxes
    fr, failed = failure_rate(t.box_frame[vis], t.box_camera[vis], t.box[vis], tb.frame, tb.camera, tb.box,
                              image_size=size, per_pair=True)
    pair_frame = t.box_frame[vis][failed]
    frames, per_frame = np.unique(pair_frame, return_counts=True)  # failing frames and their failed pairs
    seen = detections.frame[match_detections_to_gt(detections, gt).person_id == pid]
    boxes = result.boxes
    member = boxes.frame[match_detections_to_gt(boxes, gt).person_id == pid] if len(boxes) else np.zeros(0, np.int64)
    tr, tg = result.tracks, result.target
    track_near = _frames_near(tr.frame, tr.xyz, t.frame, t.xyz, near)
    target_near = _frames_near(tg.frame, tg.xyz, t.frame, t.xyz, near)
    cause = np.full(frames.size, len(CAUSES) - 1)  # linking unless an earlier cause holds
    cause[np.isin(frames, tg.frame)] = CAUSES.index("identification")
    no_track = ~np.isin(frames, track_near)
    cause[no_track] = np.where(np.isin(frames[no_track], member), CAUSES.index("phantom"), CAUSES.index("unclustered"))
    cause[np.isin(frames, target_near)] = CAUSES.index("box")
    cause[~np.isin(frames, seen)] = CAUSES.index("no_detection")
    counts = np.bincount(cause, weights=per_frame, minlength=len(CAUSES)).astype(int)
    return {"failures": fr.failures, "evaluated": fr.evaluated, **{c: int(k) for c, k in zip(CAUSES, counts)}}


def explain_table(rows: Sequence[dict], methods: Sequence[str] = ("cascade+", "cascade", "oracle")) -> list[dict]:
    """Per (n_cam, apparatus, method) of the benchmark rows (with ``why_<cause>`` columns): the FR
    and each cause's share of the evaluated pairs (they add up to the FR), pooled over routines;
    plus an ``all`` apparatus row per (n_cam, method), the mean over apparatus."""
    from ..apparatus import APPARATUS_NAMES
    from .aggregate import N_CAMS, ok_rows, present

    rows = [r for r in ok_rows(rows) if r["method"] in methods and "why_box" in r]
    acc: dict[tuple, np.ndarray] = {}
    for r in rows:
        key = (int(r["n_cam"]), r["apparatus"], r["method"])
        v = np.array([float(r["fr_evaluated"]), *[float(r[f"why_{c}"]) for c in CAUSES]])
        acc[key] = acc.get(key, 0) + v
    out = []
    for n in present(rows, "n_cam", N_CAMS):
        for m in [x for x in methods if any(k[0] == n and k[2] == x for k in acc)]:
            shares = []
            for app in present(rows, "apparatus", APPARATUS_NAMES):
                v = acc.get((n, app, m))
                if v is None or not v[0]:
                    continue
                s = v[1:] / v[0]
                shares.append(s)
                out.append({"n_cam": n, "apparatus": app, "method": m, "fr": float(s.sum()), **dict(zip(CAUSES, s.tolist()))})
            if shares:
                s = np.mean(shares, axis=0)
                out.append({"n_cam": n, "apparatus": "all (mean)", "method": m, "fr": float(s.sum()), **dict(zip(CAUSES, s.tolist()))})
    return out


def explain_markdown(rows: Sequence[dict]) -> str:
    """The breakdown of :func:`explain_table` as a markdown section (empty without the columns)."""
    from .render import markdown_table

    table = explain_table(rows)
    if not table:
        return ""
    body = [[r["n_cam"], r["apparatus"], r["method"], f"{100 * r['fr']:.2f}", *[f"{100 * r[c]:.2f}" for c in CAUSES]]
            for r in table]
    return ("## Where the target's failures come from\n\n"
            "Each failed (frame, view) pair of the FR, by the first cause that holds at its frame "
            "(`gymtrack.eval.explain`: no detection in any view; box wrong though the centre is within 0.5 m; "
            "no track near the gymnast and its boxes in none (unclustered) or in one elsewhere (phantom); a track near "
            "but the target on another (identification) or nowhere (linking)); % of evaluated pairs, adding up to the FR.\n\n"
            + markdown_table(["n_cam", "apparatus", "method", "FR %", *[f"{c} %" for c in CAUSES]], body) + "\n")
