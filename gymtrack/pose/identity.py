"""Whose body is in each view: a track's view whose torso does not fit its other views, or its
own neighbouring frames, shows another person and is set aside before lifting.

Rule (beyond the paper; several close people): a top-down model run on a track's crop locks on
to the body in the crop's middle; in a crowd that is often a neighbour, 0.3-1 m away. Lifted with
the track's other views, that pose mixes two people into one skeleton. The torso (shoulders and
hips) is the part a pose model finds most reliably, so it says whose body a view shows:

1. geometry, per frame: every view pair whose torsos triangulate consistently (each reprojects
   within ``tol`` of its own pose's size) is a hypothesis; the views whose torso lies within
   ``tol`` of the pair's reprojection are its inliers. The hypothesis with most inliers (then
   the smallest error) wins; where it has 2+ inliers and no hypothesis with as many inliers
   holds another view (two bodies that each fit), the frame is *decided*: its other views are
   set aside;
2. time, for the frames geometry cannot decide (one view, two disagreeing views, ties): the
   torso of the nearest decided frames before and after (within ``half_window``; interpolated
   between both), reprojected, says which views still show the same body (within
   ``tol_time``: a body moves in the meantime); the others are set aside. Far from any decided
   frame nothing is set aside.

A view's torso error is the median over its found torso joints of the reprojection distance
over the pose's box (the larger side of its keypoints' extent), in the view's best reading (as
found, left/right swapped, legs swapped: a swapped view shows the same body, and the consensus
after this rule reads it right); each pair is tried with its second view as found and swapped.
Shapes like :mod:`.lift`: u, v, ok (C, J, T); box (C, T).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .dlt import project, weighted_dlt

TORSO = ("left_shoulder", "right_shoulder", "left_hip", "right_hip")
READINGS = ([0, 1, 2, 3], [1, 0, 3, 2], [0, 1, 3, 2])  # as found, swapped, legs swapped


@dataclass(frozen=True)
class TorsoIdentity:
    """tol: a view's torso agrees with a hypothesis within this share of its pose's size (the
    model's own torso noise is ~3 %, a neighbour's ~8-30 % away: larger keeps more neighbours,
    smaller sets aside more of the body's own views); tol_time: the same against the torso of
    neighbouring frames (the body moves meanwhile); half_window: frames each side a decided
    frame may lie; min_joints: torso joints a view needs to be judged."""

    tol: float = 0.07
    tol_time: float = 0.1
    half_window: int = 8
    min_joints: int = 3


def _median(r):
    """(C, T) median over axis 1 of r (C, K, T), NaN ignored; by sorting (nanmedian is slow on short axes)."""
    r = np.sort(r, axis=1)  # NaN last
    n = np.isfinite(r).sum(axis=1)
    lo = np.take_along_axis(r, np.clip((n - 1) // 2, 0, None)[:, None], 1)[:, 0]
    hi = np.take_along_axis(r, (n // 2)[:, None], 1)[:, 0]
    return np.where(n > 0, 0.5 * (lo + hi), np.nan)


def _errors_any(P, X, u, v, ok, box):
    """(C, T) median torso reprojection error of X (3, K T) over box, in each view's best reading
    (as found, left/right swapped, legs swapped: a swapped view is the same body; the consensus
    after this rule reads it right); NaN where not judged. u, v, ok (C, K, T)."""
    C, K, T = u.shape
    pu, pv = (p.reshape(C, K, T) for p in project(P, X))  # projected once, compared in each reading
    e = [_median(np.where(ok[:, r], np.hypot(pu - u[:, r], pv - v[:, r]), np.nan)) for r in READINGS]
    return np.fmin(np.fmin(e[0], e[1]), e[2]) / box


def torso_views(P: np.ndarray, u: np.ndarray, v: np.ndarray, ok: np.ndarray, box: np.ndarray, joints: list[str],
                opt: TorsoIdentity | None = TorsoIdentity(), info: dict | None = None) -> np.ndarray:
    """(C, T) bool: the views whose pose shows the track's body (module doc); views without a
    pose are True. ``joints``: the skeleton's joint names (without all four torso joints:
    nothing judged).
    info: a dict given is filled with ``decided`` (T,) and ``by_time`` (T,) (frames judged by
    the neighbouring frames)."""
    C, J, T = u.shape
    keep = np.ones((C, T), bool)
    if opt is None or C < 2 or not all(n in joints for n in TORSO):
        return keep
    idx = [joints.index(n) for n in TORSO]
    tu, tv, tok = u[:, idx], v[:, idx], ok[:, idx]
    K = len(idx)
    judged = tok.sum(axis=1) >= opt.min_joints  # (C, T)
    best_n, best_e = np.zeros(T, np.int64), np.full(T, np.inf)
    best_in = np.zeros((C, T), bool)
    n_best = np.zeros(T, np.int64)  # best-count hypotheses holding different views: >1 = two bodies fit
    best_X = np.full((3, K * T), np.nan)
    for a, b, r in ((a, b, r) for a in range(C) for b in range(a + 1, C) for r in READINGS[:2]):
        both = judged[a] & judged[b]
        if not both.any():
            continue
        pr = [a, b]
        ub, vb, okb = tu[b][r], tv[b][r], tok[b][r]  # the second view read as found or swapped
        w = (np.stack([tok[a], okb]) & both[None, None, :]).reshape(2, -1).astype(np.float64)
        X = weighted_dlt(P[pr], np.stack([tu[a], ub]).reshape(2, -1), np.stack([tv[a], vb]).reshape(2, -1), w)
        e = _errors_any(P, X, tu, tv, tok & judged[:, None, :], box)
        valid = both & (e[a] < opt.tol) & (e[b] < opt.tol)
        inl = valid[None] & (e < opt.tol)
        n = inl.sum(axis=0)
        err = np.where(inl, e, 0.0).sum(axis=0)
        more = n > best_n
        tie = valid & (n == best_n) & (n > 0) & (inl & ~best_in).any(axis=0)  # another body fits as well
        better = more | (valid & (n == best_n) & (err < best_e))
        n_best = np.where(more, 1, n_best + tie)
        best_in = np.where(better[None], inl, best_in)
        best_X = np.where(np.tile(better, K)[None], X, best_X)
        best_n, best_e = np.where(better, n, best_n), np.where(better, err, best_e)
    present = judged.sum(axis=0)
    decided = (n_best == 1) & (best_n >= 2)
    keep = np.where(decided[None], best_in | ~judged, keep)
    Xd = best_X.reshape(3, K, T)  # the decided frames' torso is the reference for the others
    good = decided & np.isfinite(Xd).all(axis=0).all(axis=0)
    todo = ~decided & (present >= 1)
    if info is not None:
        info.update(decided=decided, by_time=np.zeros(T, bool))
    if not good.any() or not todo.any():
        return keep
    t = np.arange(T)
    prev = np.maximum.accumulate(np.where(good, t, -1))
    nxt = np.minimum.accumulate(np.where(good, t, T)[::-1])[::-1]
    h = opt.half_window
    has_p, has_n = (prev >= 0) & (t - prev <= h), (nxt < T) & (nxt - t <= h)
    pi, ni = np.clip(prev, 0, T - 1), np.clip(nxt, 0, T - 1)
    s = np.where(has_p & has_n, (t - pi) / np.maximum(ni - pi, 1), np.where(has_n, 1.0, 0.0))
    R = (1 - s) * Xd[:, :, pi] + s * Xd[:, :, ni]  # (3, K, T)
    ref = todo & (has_p | has_n)
    e = _errors_any(P, R.reshape(3, -1), tu, tv, tok & judged[:, None, :], box)
    keep = np.where(ref[None] & judged, e < opt.tol_time, keep)
    if info is not None:
        info["by_time"] = ref
    return keep
