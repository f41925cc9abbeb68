"""Which views show the track's person, where the per-frame consensus is open: the track's own
bone lengths decide.

Rule (beyond the paper; several close people): in a crowd a top-down model's crop may hold a
neighbour, whose pose in that view fits the track's pose in one other view as well as the right
view does (two rays to two different bodies still meet somewhere). With three views, one of
them wrong, the per-frame consensus (:mod:`.consensus`) then weighs two pairs of equal support
and picks by noise. The wrong pair's skeleton is distorted: its bones are not the track's. So,
in every frame where views were dropped (or none agreed) and 3+ views saw the body:

1. the track's bone lengths ``L_b``: the median over frames of the consensus skeleton (2+ views
   on both ends), needing ``min_frames`` frames;
2. every subset of 2+ of the frame's views is triangulated (confidence-weighted DLT) and kept
   as a candidate when each of its views reprojects within the gate (mean capped, gate-normalised
   error below ``inlier_error``, the consensus' own test);
3. among the candidates with most views, the one whose skeleton's median relative bone error
   ``median_b |l_b / L_b - 1|`` is least replaces the consensus' views when it is lower than
   theirs by more than ``margin``.

Shapes: C views, J joints, T frames; u, v, ok, sc, gate (C, J, T); keep (C, T); box (C, T).
"""

from __future__ import annotations

from itertools import combinations

import numpy as np

from ..skeletons import Skeleton
from .consensus import _view_errors
from .dlt import project, weighted_dlt


def _bone_error(X: np.ndarray, bones: np.ndarray, L: np.ndarray) -> np.ndarray:
    """(...,) median relative bone-length error of skeletons X (3, ..., J) (NaN bones skipped)."""
    lb = np.linalg.norm(X[..., bones[:, 0]] - X[..., bones[:, 1]], axis=0)  # (..., B)
    with np.errstate(invalid="ignore"), __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("ignore", RuntimeWarning)
        e = np.nanmedian(np.abs(lb / L - 1.0), axis=-1)
    return np.where(np.isfinite(e), e, np.inf)


def _off_centre(X: np.ndarray, centre: np.ndarray | None, t: np.ndarray, weight: float) -> np.ndarray:
    """(..., n) weight x horizontal distance of skeletons X (3, ..., n, J) from centre[t] (0 where unknown)."""
    if centre is None or weight <= 0:
        return np.zeros(X.shape[1:-1])
    with np.errstate(invalid="ignore"), __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("ignore", RuntimeWarning)
        m = np.nanmean(X[:2], axis=-1)  # (2, ..., n)
    d = np.hypot(m[0] - centre[t, 0], m[1] - centre[t, 1])
    return weight * np.where(np.isfinite(centre[t, :2]).all(axis=1), np.nan_to_num(d, nan=np.inf), 0.0)


def prior_views(P: np.ndarray, u: np.ndarray, v: np.ndarray, ok: np.ndarray, sc: np.ndarray, box: np.ndarray,
                gate: np.ndarray, keep: np.ndarray, open_: np.ndarray, skeleton: Skeleton, inlier_error: float,
                margin: float = 0.05, min_frames: int = 10, centre: np.ndarray | None = None,
                centre_weight: float = 1.0) -> tuple[np.ndarray, int]:
    """The views to keep (C, T) after the bone-length vote (module doc) and how many frames changed.

    open_ (T,) bool: frames whose consensus is open besides those that dropped a view (no two
    views agreed). centre (T, 3): the track's 3D position (NaN where unknown): a candidate's cost
    adds ``centre_weight`` x the horizontal distance (m) of its skeleton's mean from it."""
    C, J, T = u.shape
    present = ok.any(axis=1)
    bones = np.asarray(skeleton.bones, np.int64).reshape(-1, 2)
    amb = (present.sum(axis=0) >= 3) & (((keep & present).sum(axis=0) < present.sum(axis=0)) | open_)
    if not amb.any() or not len(bones) or C < 3:
        return keep, 0
    use = ok & keep[:, None, :]
    w = np.where(use, sc / box[:, None, :], 0.0).reshape(C, -1)
    X = weighted_dlt(P, u.reshape(C, -1), v.reshape(C, -1), w).reshape(3, J, T)
    nv = use.sum(axis=0)
    good = (nv[bones[:, 0]] >= 2) & (nv[bones[:, 1]] >= 2)  # (B, T)
    lb = np.linalg.norm(X[:, bones[:, 0]] - X[:, bones[:, 1]], axis=0)  # (B, T)
    lb = np.where(good & np.isfinite(lb), lb, np.nan)
    if (np.isfinite(lb).sum(axis=1) >= min_frames).sum() < len(bones) // 2:
        return keep, 0
    with np.errstate(invalid="ignore"), __import__("warnings").catch_warnings():
        __import__("warnings").simplefilter("ignore", RuntimeWarning)
        L = np.where(np.isfinite(lb).sum(axis=1) >= min_frames, np.nanmedian(lb, axis=1), np.nan)  # (B,)
    t = np.flatnonzero(amb)
    n = t.size
    subs = np.array([np.isin(np.arange(C), s) for k in range(2, C + 1) for s in combinations(range(C), k)])  # (S, C)
    S = len(subs)
    full = (subs[:, :, None] & present[None, :, t]).sum(axis=1) == subs.sum(axis=1)[:, None]  # (S, n)
    m = subs[:, :, None, None] & ok[None][:, :, :, t]  # (S, C, J, n)
    ws = np.where(m, (sc[:, :, t] / box[:, None, t])[None], 0.0).transpose(1, 0, 2, 3).reshape(C, -1)
    ut = np.broadcast_to(u[:, None, :, t], (C, S, J, n)).reshape(C, -1)
    vt = np.broadcast_to(v[:, None, :, t], (C, S, J, n)).reshape(C, -1)
    Xs = weighted_dlt(P, ut, vt, ws)  # (3, S J n)
    pu, pv = (p.reshape(C, S, J, n) for p in project(P, Xs))
    g = np.broadcast_to(gate[:, None, :, t], (C, S, J, n))
    okt = np.broadcast_to(ok[:, None, :, t], (C, S, J, n))
    e, me = _view_errors(pu, pv, ut.reshape(C, S, J, n), vt.reshape(C, S, J, n), okt, g)  # (C, S, J, n)
    ev = (e * me).sum(axis=2) / np.maximum(me.sum(axis=2), 1)  # (C, S, n)
    inlier = np.all(np.where(subs.T[:, :, None], ev < inlier_error, True), axis=0)  # (S, n)
    cand = full & inlier
    Xs = Xs.reshape(3, S, J, n).transpose(0, 1, 3, 2)  # (3, S, n, J)
    cost = _bone_error(Xs, bones, L) + _off_centre(Xs, centre, t, centre_weight)  # (S, n)
    count = np.where(cand, subs.sum(axis=1)[:, None], 0)
    best_n = count.max(axis=0)
    rank = np.where(cand & (count == best_n[None]), cost, np.inf)
    pick = np.argmin(rank, axis=0)
    c_new = rank[pick, np.arange(n)]
    Xc = X[:, :, t].transpose(0, 2, 1)  # (3, n, J)
    c_cur = _bone_error(Xc, bones, L) + _off_centre(Xc, centre, t, centre_weight)  # (n,)
    change = np.isfinite(c_new) & (c_new + margin < c_cur) & np.any(subs[pick].T != keep[:, t], axis=0)
    keep = keep.copy()
    keep[:, t[change]] = subs[pick[change]].T
    return keep, int(change.sum())
