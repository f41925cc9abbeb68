"""Compiled kernels of the venue check (beyond the paper; :mod:`..drift`).

:func:`residuals`: one sampled window's residuals -- the point one view pair triangulates (Eq. 3's
two-view case, midpoint of the rays) projected into each third view that saw it, minus where that
view saw it -- grouped per camera x pair with their medians, and the sync regression's sums.
:func:`steps`: per camera x pair, the step of the last second's median residual against the
seconds before. One call each instead of some sixty numpy calls and a median per group; the numpy
code they replace is ``tests/reference/drift.py`` (same residuals up to rounding, same medians).
"""

from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True, error_model="numpy")
def _normalised(box, k, w, Kinv, c):
    u, v = box[k, w, 0], box[k, w, 1]
    return (Kinv[c, 0, 0] * u + Kinv[c, 0, 1] * v + Kinv[c, 0, 2],
            Kinv[c, 1, 0] * u + Kinv[c, 1, 1] * v + Kinv[c, 1, 2])


@njit(cache=True, error_model="numpy")
def residuals(box, observed, members, Kinv, Rt, centres, Pn, pa, pb, max_residual, min_points):
    """box (K, W, 4) undistorted boxes, observed (K, W), members (M, C) int64 (clusters of fewer than
    three views are skipped), Kinv / Rt (C, 3, 3), centres (C, 3), Pn (C, 3, 4), pa / pb (Np,) the
    pairs, max_residual (radians), min_points -> med (C * Np, 2) each key's median residual (NaN with
    fewer than ``min_points``), start (C * Np + 1,) offsets of each key's rows in X (n, 3) the
    triangulated points and seen (n, 2) where the camera saw them, sums (C, 3): n, v.v, v.r of
    the points with an image velocity (central difference inside the window)."""
    M, C = members.shape
    W = box.shape[1]
    Np = len(pa)
    Nk = C * Np
    cap = 0
    for m in range(M):
        n = 0
        for c in range(C):
            n += members[m, c] >= 0
        if n >= 3:
            cap += Np * W * (n - 2)
    key = np.empty(cap, np.int64)
    R = np.empty((cap, 2))
    X = np.empty((cap, 3))
    S = np.empty((cap, 2))
    sums = np.zeros((C, 3))
    n = 0
    for m in range(M):
        views = 0
        for c in range(C):
            views += members[m, c] >= 0
        if views < 3:
            continue
        for p in range(Np):
            a, b = pa[p], pb[p]
            ka, kb = members[m, a], members[m, b]
            if ka < 0 or kb < 0:
                continue
            for w in range(W):
                if not (observed[ka, w] and observed[kb, w]):
                    continue
                xa0, xa1 = _normalised(box, ka, w, Kinv, a)
                xb0, xb1 = _normalised(box, kb, w, Kinv, b)
                da = np.empty(3)
                db = np.empty(3)
                for i in range(3):
                    da[i] = Rt[a, i, 0] * xa0 + Rt[a, i, 1] * xa1 + Rt[a, i, 2]
                    db[i] = Rt[b, i, 0] * xb0 + Rt[b, i, 1] * xb1 + Rt[b, i, 2]
                aa = bb = cc = d = e = 0.0
                for i in range(3):
                    w0 = centres[a, i] - centres[b, i]
                    aa += da[i] * da[i]
                    bb += da[i] * db[i]
                    cc += db[i] * db[i]
                    d += da[i] * w0
                    e += db[i] * w0
                den = aa * cc - bb * bb
                s, t = (bb * e - cc * d) / den, (aa * e - bb * d) / den
                P = np.empty(3)
                for i in range(3):
                    P[i] = (centres[a, i] + s * da[i] + centres[b, i] + t * db[i]) / 2
                for c in range(C):
                    kc = members[m, c]
                    if c == a or c == b or kc < 0 or not observed[kc, w]:
                        continue
                    q = np.empty(3)
                    for i in range(3):
                        q[i] = Pn[c, i, 0] * P[0] + Pn[c, i, 1] * P[1] + Pn[c, i, 2] * P[2] + Pn[c, i, 3]
                    x0, x1 = _normalised(box, kc, w, Kinv, c)
                    r0, r1 = x0 - q[0] / q[2], x1 - q[1] / q[2]
                    if not (q[2] > 0 and abs(r0) < max_residual and abs(r1) < max_residual):
                        continue
                    key[n] = c * Np + p
                    R[n, 0], R[n, 1] = r0, r1
                    X[n, 0], X[n, 1], X[n, 2] = P[0], P[1], P[2]
                    S[n, 0], S[n, 1] = x0, x1
                    n += 1
                    if 0 < w < W - 1 and observed[kc, w - 1] and observed[kc, w + 1]:
                        u0, u1 = _normalised(box, kc, w + 1, Kinv, c)
                        l0, l1 = _normalised(box, kc, w - 1, Kinv, c)
                        v0, v1 = (u0 - l0) / 2, (u1 - l1) / 2
                        if np.isfinite(v0):
                            sums[c, 0] += 1
                            sums[c, 1] += v0 * v0 + v1 * v1
                            sums[c, 2] += v0 * r0 + v1 * r1
    order = np.argsort(key[:n], kind="mergesort")
    start = np.zeros(Nk + 1, np.int64)
    for j in range(n):
        start[key[j] + 1] += 1
    for k in range(Nk):
        start[k + 1] += start[k]
    Xs, Ss, Rs = X[order], S[order], R[order]
    med = np.full((Nk, 2), np.nan)
    for k in range(Nk):
        if start[k + 1] - start[k] >= min_points:
            med[k, 0] = np.median(Rs[start[k]:start[k + 1], 0])
            med[k, 1] = np.median(Rs[start[k]:start[k + 1], 1])
    return med, start, Xs, Ss, sums


@njit(cache=True, error_model="numpy")
def steps(meds, n_base, min_step, noise_factor):
    """meds (Nk, L, 2) the samples' median residuals (NaN: not judged), the first ``n_base`` the
    baseline -> step (Nk,) the smallest distance of a recent sample from the baseline's median (0
    where not ready), thr (Nk,) max(min_step, noise_factor x 1.4826 x the baseline's median
    distance from its median; inf where not ready), base (Nk, 2) the baseline's median."""
    Nk, L, _ = meds.shape
    step = np.zeros(Nk)
    thr = np.full(Nk, np.inf)
    base = np.full((Nk, 2), np.nan)
    for k in range(Nk):
        good = np.isfinite(meds[k, :n_base, 0])
        if good.sum() == 0:
            continue
        base[k, 0] = np.median(meds[k, :n_base, 0][good])
        base[k, 1] = np.median(meds[k, :n_base, 1][good])
        if good.sum() < n_base - 1:
            continue
        lo = np.inf
        for j in range(n_base, L):
            dev = np.hypot(meds[k, j, 0] - base[k, 0], meds[k, j, 1] - base[k, 1])
            if not np.isfinite(dev):
                lo = -1.0
                break
            lo = min(lo, dev)
        if lo < 0:
            continue
        dist = np.hypot(meds[k, :n_base, 0][good] - base[k, 0], meds[k, :n_base, 1][good] - base[k, 1])
        step[k] = lo
        thr[k] = max(min_step, noise_factor * 1.4826 * np.median(dist))
    return step, thr, base


def warm_up() -> None:
    """Compile (or load) the kernels: three views of a synthetic cluster, and a short history."""
    C, W = 3, 4
    box = np.ones((C, W, 4))
    eye = np.ascontiguousarray(np.broadcast_to(np.eye(3), (C, 3, 3)))
    Pn = np.zeros((C, 3, 4))
    Pn[:, :, :3] = eye
    pa, pb = np.array([0, 0, 1], np.int64), np.array([1, 2, 2], np.int64)
    residuals(box, np.ones((C, W), np.bool_), np.arange(C, dtype=np.int64).reshape(1, C), eye, eye,
              np.eye(3), Pn, pa, pb, 0.05, 8)
    steps(np.zeros((2, 5, 2)), 3, 0.005, 3.0)
