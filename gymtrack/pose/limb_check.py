"""Arms checked against the track's own bone lengths and its motion: a wrist or elbow that does
not fit is re-estimated from the views that agree, or dropped and counted.

Rule (beyond the paper; several close people): in a crowd a view's crop may hold a neighbour,
and where only two or three views see a joint the consensus cannot always tell which view is
wrong. The wrong view leaves marks the track itself can see: the bone to the joint's parent
(shoulder-elbow, elbow-wrist) is far from its length on the track's other frames, or the joint
leaps between frames further than an arm moves. Per arm joint, proximal first:

1. the bone's length ``L`` on the track (median over frames where both ends are triangulated
   from 2+ views, at least ``min_frames``) and its spread ``s`` (1.4826 MAD);
2. a frame is suspect where ``|length - L| > max(k_sigma * s, min_frac * L)``, or where the
   joint is more than ``max_step_m`` from both neighbouring frames' positions (a spike: a wrist
   moves ~10 m/s at most in gymnastics, 0.4 m per frame at 25 fps) while those two agree;
3. a suspect joint is triangulated again from every subset of the views that found it, leaving
   at most two out (2+ views kept; the consensus may have kept the wrong view); a subset counts when each of its views reprojects within the lifting's
   gate and its bone is within the tolerance; the one with most views, then the bone nearest
   ``L``, is taken. Where none counts the joint is dropped (NaN) and counted.

Off by default (``LiftOptions(arms=LimbCheck())`` turns it on): on the simulated crowd
(``benchmarks/bench_all_tracks.py --crowd 6``) it changed forearm PCP by less than 0.01 either
way, and dropping the joints no subset explains (``drop=True``) lowered it (a dropped joint is a
missed limb): the crowd's wrong views mostly give whole skeletons of a neighbour whose bones fit.
``rescale`` moves a joint no subset explains along its bone to the track's length instead.
Only triangulated joints are checked (plane-anchored ones already follow the bones). Shapes:
X3 (T, J, 3); u, v, use, sc, gate (C, J, T) like :mod:`.lift`.
"""

from __future__ import annotations

from dataclasses import dataclass
from itertools import combinations

import numpy as np

from ..skeletons import Skeleton
from .dlt import gauss_newton, residuals, weighted_dlt


@dataclass(frozen=True)
class LimbCheck:
    """k_sigma, min_frac: the bone-length tolerance; max_step_m: the spike test's step (metres per
    frame); min_frames: frames a bone's length needs; refine_iterations: Gauss-Newton steps;
    drop: a joint no view subset explains is dropped (NaN, counted), else kept; rescale: (not
    dropped) moved along its bone to the track's length."""

    k_sigma: float = 5.0
    min_frac: float = 0.4
    max_step_m: float = 0.4
    min_frames: int = 10
    refine_iterations: int = 2
    drop: bool = False
    rescale: bool = True


def arm_chains(skeleton: Skeleton) -> list[tuple[int, int]]:
    """(parent, joint) index pairs of the arms, proximal first: shoulder-elbow, elbow-wrist."""
    names = {n: i for i, n in enumerate(skeleton.joints)}
    out = []
    for a, b in (("shoulder", "elbow"), ("elbow", "wrist")):
        for side in ("left", "right"):
            if f"{side}_{a}" in names and f"{side}_{b}" in names:
                out.append((names[f"{side}_{a}"], names[f"{side}_{b}"]))
    return out


def _subsets(C: int) -> np.ndarray:
    """(S, C) bool: view subsets of 2+ views that leave at most two views out."""
    rows = [np.isin(np.arange(C), keep) for k in range(C, max(2, C - 2) - 1, -1) for keep in combinations(range(C), k)]
    return np.array(rows, bool).reshape(-1, C)


def _suspect(X: np.ndarray, parent: np.ndarray, tri: np.ndarray, L: float, tol: float, step: float) -> np.ndarray:
    """(T,) frames whose joint X (T, 3) breaks its bone to parent (T, 3) or spikes."""
    length = np.linalg.norm(X - parent, axis=1)
    bad = tri & np.isfinite(length) & (np.abs(length - L) > tol)
    if len(X) >= 3:
        prev, nxt = X[:-2], X[2:]
        mid = X[1:-1]
        with np.errstate(invalid="ignore"):
            spike = (np.linalg.norm(mid - prev, axis=1) > step) & (np.linalg.norm(mid - nxt, axis=1) > step) \
                & (np.linalg.norm(prev - nxt, axis=1) < step)
        bad[1:-1] |= tri[1:-1] & spike
    return bad


def check_arms(P: np.ndarray, X3: np.ndarray, u: np.ndarray, v: np.ndarray, use: np.ndarray, found: np.ndarray,
               sc: np.ndarray, gate: np.ndarray, skeleton: Skeleton, check: LimbCheck | None = LimbCheck()) -> tuple[np.ndarray, np.ndarray, dict]:
    """Re-estimate or drop the arm joints that break the track's bones or leap (module doc).

    use: the views each joint was lifted from; found: the views that found it (the candidates:
    the consensus may have kept the wrong one). Returns X3 (T, J, 3) and use (C, J, T) updated (a re-estimated joint's dropped views are no
    longer used), and counts ``arm_joints_suspect``, ``arm_joints_reestimated``, ``arm_joints_dropped``.
    """
    C, J, T = u.shape
    X3, use = X3.copy(), use.copy()
    counts = {"arm_joints_suspect": 0, "arm_joints_reestimated": 0, "arm_joints_dropped": 0}
    subsets = _subsets(C)
    if check is None or not len(subsets) or T < check.min_frames:
        return X3, use, counts
    for a, b in arm_chains(skeleton):
        n_a, n_b = use[:, a].sum(axis=0), use[:, b].sum(axis=0)  # (T,)
        tri = np.isfinite(X3[:, b]).all(axis=1) & (n_b >= 2)
        both = tri & (n_a >= 2) & np.isfinite(X3[:, a]).all(axis=1)
        if both.sum() < check.min_frames:
            continue
        length = np.linalg.norm(X3[both, b] - X3[both, a], axis=1)
        L = float(np.median(length))
        tol = max(check.k_sigma * 1.4826 * float(np.median(np.abs(length - L))), check.min_frac * L)
        bad = np.flatnonzero(_suspect(X3[:, b], X3[:, a], tri, L, tol, check.max_step_m))
        if not bad.size:
            continue
        counts["arm_joints_suspect"] += int(bad.size)
        # every (suspect frame, subset) at once: (C, n * S)
        S = len(subsets)
        mask = found[:, b, bad][:, :, None] & subsets.T[:, None, :]  # (C, n, S)
        w = np.where(mask, sc[:, b, bad][:, :, None], 0.0).reshape(C, -1)
        uu = np.repeat(u[:, b, bad], S, axis=1)
        vv = np.repeat(v[:, b, bad], S, axis=1)
        Xc = gauss_newton(P, weighted_dlt(P, uu, vv, w), uu, vv, w, check.refine_iterations)  # (3, n S)
        r = residuals(P, Xc, uu, vv)
        g = np.repeat(gate[:, b, bad], S, axis=1)
        fits = np.all(np.where(w > 0, r <= g, True), axis=0) & ((w > 0).sum(axis=0) >= 2)
        par = np.repeat(X3[bad, a], S, axis=0)  # (n S, 3)
        dev = np.abs(np.linalg.norm(Xc.T - par, axis=1) - L)
        fits &= np.isfinite(dev) & (dev <= tol)
        if len(X3) >= 3:  # the spike test on the candidate too, where both neighbours exist
            t = np.repeat(bad, S)
            inner = (t > 0) & (t < T - 1)
            prev, nxt = X3[np.clip(t - 1, 0, T - 1), b], X3[np.clip(t + 1, 0, T - 1), b]
            with np.errstate(invalid="ignore"):
                leap = (np.linalg.norm(Xc.T - prev, axis=1) > check.max_step_m) & \
                    (np.linalg.norm(Xc.T - nxt, axis=1) > check.max_step_m)
            fits &= ~(inner & np.nan_to_num(leap, nan=False).astype(bool))
        nv = (w > 0).sum(axis=0)
        rank = np.where(fits, nv * 1e3 - dev / max(L, 1e-6), -np.inf).reshape(-1, S)
        pick = np.argmax(rank, axis=1)
        fixed = np.isfinite(rank[np.arange(bad.size), pick])
        k = np.arange(bad.size) * S + pick
        tf, tl = bad[fixed], bad[~fixed]
        X3[tf, b] = Xc[:, k[fixed]].T
        use[:, b, tf] = mask.reshape(C, -1)[:, k[fixed]]
        if check.drop:
            X3[tl, b] = np.nan
            use[:, b, tl] = False
        elif check.rescale:  # along its bone, to the track's length (the direction is better known than the depth)
            d = X3[tl, b] - X3[tl, a]
            n = np.linalg.norm(d, axis=1, keepdims=True)
            X3[tl, b] = np.where(n > 0, X3[tl, a] + d * (L / np.maximum(n, 1e-9)), X3[tl, b])
        counts["arm_joints_reestimated"] += int(fixed.sum())
        counts["arm_joints_dropped"] += int((~fixed).sum())
    return X3, use, counts
