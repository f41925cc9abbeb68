"""Compiled kernels of the venue check (beyond the paper; :mod:`..drift`).

:func:`residuals`: one window's residuals -- the point one view pair triangulates (Eq. 3's
two-view case, midpoint of the rays) projected into each third view that saw it, minus where that
view saw it -- and the sync regression's sums; :func:`medians`: a sample's rows grouped per
camera x pair with their medians; :func:`scan_steps`: the change scan of :mod:`..drift_scan`; :func:`key_medians` and
:func:`turn_fits`: the median points and the robust fit of :meth:`..drift.DriftMonitor._fit`.
One call each instead of some sixty numpy calls and a median per group; the numpy
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
def residuals(box, observed, members, Kinv, Rt, centres, Pn, pa, pb, max_residual, w_lo, w_hi):
    """box (K, W, 4) undistorted boxes, observed (K, W), members (M, C) int64 (clusters of fewer than
    three views are skipped), Kinv / Rt (C, 3, 3), centres (C, 3), Pn (C, 3, 4), pa / pb (Np,) the
    pairs, max_residual (radians), the window's frames ``w_lo .. w_hi - 1`` -> the residuals' rows:
    key (n,) camera x pair (``c * Np + p``), R (n, 2) seen - predicted, X (n, 3) the triangulated
    point, S (n, 2) where the camera saw it; sums (C * Np, 3) by key: n, v.v, v.r of the rows with
    an image velocity (central difference inside the window); w (n,) each row's frame in the window."""
    M, C = members.shape
    W = box.shape[1]
    Np = len(pa)
    cap = 0
    for m in range(M):
        n = 0
        for c in range(C):
            n += members[m, c] >= 0
        if n >= 3:
            cap += Np * (w_hi - w_lo) * (n - 2)
    key = np.empty(cap, np.int64)
    R = np.empty((cap, 2))
    X = np.empty((cap, 3))
    S = np.empty((cap, 2))
    Wr = np.empty(cap, np.int64)
    sums = np.zeros((C * Np, 3))
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
            for w in range(w_lo, w_hi):
                if not (observed[ka, w] and observed[kb, w]):
                    continue
                xa0, xa1 = _normalised(box, ka, w, Kinv, a)
                xb0, xb1 = _normalised(box, kb, w, Kinv, b)
                da0 = Rt[a, 0, 0] * xa0 + Rt[a, 0, 1] * xa1 + Rt[a, 0, 2]
                da1 = Rt[a, 1, 0] * xa0 + Rt[a, 1, 1] * xa1 + Rt[a, 1, 2]
                da2 = Rt[a, 2, 0] * xa0 + Rt[a, 2, 1] * xa1 + Rt[a, 2, 2]
                db0 = Rt[b, 0, 0] * xb0 + Rt[b, 0, 1] * xb1 + Rt[b, 0, 2]
                db1 = Rt[b, 1, 0] * xb0 + Rt[b, 1, 1] * xb1 + Rt[b, 1, 2]
                db2 = Rt[b, 2, 0] * xb0 + Rt[b, 2, 1] * xb1 + Rt[b, 2, 2]
                w0, w1, w2 = centres[a, 0] - centres[b, 0], centres[a, 1] - centres[b, 1], centres[a, 2] - centres[b, 2]
                aa = da0 * da0 + da1 * da1 + da2 * da2
                bb = da0 * db0 + da1 * db1 + da2 * db2
                cc = db0 * db0 + db1 * db1 + db2 * db2
                d = da0 * w0 + da1 * w1 + da2 * w2
                e = db0 * w0 + db1 * w1 + db2 * w2
                den = aa * cc - bb * bb
                s, t = (bb * e - cc * d) / den, (aa * e - bb * d) / den
                P0 = (centres[a, 0] + s * da0 + centres[b, 0] + t * db0) / 2
                P1 = (centres[a, 1] + s * da1 + centres[b, 1] + t * db1) / 2
                P2 = (centres[a, 2] + s * da2 + centres[b, 2] + t * db2) / 2
                for c in range(C):
                    kc = members[m, c]
                    if c == a or c == b or kc < 0 or not observed[kc, w]:
                        continue
                    q0 = Pn[c, 0, 0] * P0 + Pn[c, 0, 1] * P1 + Pn[c, 0, 2] * P2 + Pn[c, 0, 3]
                    q1 = Pn[c, 1, 0] * P0 + Pn[c, 1, 1] * P1 + Pn[c, 1, 2] * P2 + Pn[c, 1, 3]
                    q2 = Pn[c, 2, 0] * P0 + Pn[c, 2, 1] * P1 + Pn[c, 2, 2] * P2 + Pn[c, 2, 3]
                    x0, x1 = _normalised(box, kc, w, Kinv, c)
                    r0, r1 = x0 - q0 / q2, x1 - q1 / q2
                    if not (q2 > 0 and abs(r0) < max_residual and abs(r1) < max_residual):
                        continue
                    key[n] = c * Np + p
                    R[n, 0], R[n, 1] = r0, r1
                    X[n, 0], X[n, 1], X[n, 2] = P0, P1, P2
                    S[n, 0], S[n, 1] = x0, x1
                    Wr[n] = w
                    n += 1
                    if 0 < w < W - 1 and observed[kc, w - 1] and observed[kc, w + 1]:
                        u0, u1 = _normalised(box, kc, w + 1, Kinv, c)
                        l0, l1 = _normalised(box, kc, w - 1, Kinv, c)
                        v0, v1 = (u0 - l0) / 2, (u1 - l1) / 2
                        if np.isfinite(v0):
                            sums[c * Np + p, 0] += 1
                            sums[c * Np + p, 1] += v0 * v0 + v1 * v1
                            sums[c * Np + p, 2] += v0 * r0 + v1 * r1
    return key[:n], R[:n], X[:n], S[:n], sums, Wr[:n]


@njit(cache=True, error_model="numpy")
def medians(key, R, X, S, F, n_keys, min_points):
    """The rows of :func:`residuals` (of one or more windows) grouped by key -> med (n_keys, 2) each
    key's median residual (NaN with fewer than ``min_points`` rows), start (n_keys + 1,) offsets of
    each key's rows in X (n, 3), S (n, 2) and F (n,) (their frames), their order kept within a key."""
    order, start = _by_key(key, n_keys)
    return _group_medians(R, order, start, min_points), start, X[order], S[order], F[order]


@njit(cache=True)
def _by_key(key, n_keys):
    """Rows (n,) of keys ``0 .. n_keys - 1`` -> order (n,) grouping them by key, their order kept
    within a key (a counting sort: numpy's stable argsort), start (n_keys + 1,) each key's offset."""
    start = np.zeros(n_keys + 1, np.int64)
    for j in range(len(key)):
        start[key[j] + 1] += 1
    for k in range(n_keys):
        start[k + 1] += start[k]
    order, at = np.empty(len(key), np.int64), start[:-1].copy()
    for j in range(len(key)):
        order[at[key[j]]] = j
        at[key[j]] += 1
    return order, start


@njit(cache=True)
def _group_medians(V, order, start, min_points):
    """Values V (n, d), grouped by :func:`_by_key`'s ``order`` and ``start`` -> (n_keys, d) each
    group's column medians (numpy's: quickselect, the two middle values' mean; NaN for a group
    of fewer than ``min_points`` rows)."""
    out = np.full((len(start) - 1, V.shape[1]), np.nan)
    buf = np.empty(len(order))
    for k in range(len(start) - 1):
        n = start[k + 1] - start[k]
        if n and n >= min_points:
            for q in range(V.shape[1]):
                for i in range(n):
                    buf[i] = V[order[start[k] + i], q]
                out[k, q] = np.median(buf[:n])
    return out


@njit(cache=True, inline="always")
def _median_of(buf, n):
    """The median of ``buf[:n]`` (sorted in place, by insertion: the scan's ten-odd samples; NaN
    when n = 0): numpy's, the two middle values' mean."""
    if n == 0:
        return np.nan
    for i in range(1, n):
        v, j = buf[i], i - 1
        while j >= 0 and buf[j] > v:
            buf[j + 1] = buf[j]
            j -= 1
        buf[j + 1] = v
    return (buf[(n - 1) // 2] + buf[n // 2]) / 2


@njit(cache=True, error_model="numpy")
def key_medians(key, V, n_keys):
    """Rows (n,) of keys ``0 .. n_keys - 1`` with values V (n, d) -> (n_keys, d) each key's
    column medians (numpy's; NaN where a key has no rows)."""
    order, start = _by_key(key, n_keys)
    return _group_medians(V, order, start, 1)


@njit(cache=True, error_model="numpy")
def turn_fits(A, z, inv, prior, huber, iterations):
    """Each camera's turn fitted alone to the keys' shifts: A (C, n, 2, 3) how the keys' shifts (in
    their scatter) move with camera c's turn (0 for keys it is not in), z (n, 2) the shifts, inv
    (C, n) the keys each camera is in, prior (3, 3) -> w (C, 3) the turns, miss (C, n) each key's
    shift left unexplained: least squares, then Huber's reweighting (``iterations`` solves)."""
    C, n = inv.shape
    w, miss = np.zeros((C, 3)), np.zeros((C, n))
    weight, G, b = np.empty(n), np.empty((3, 3)), np.empty(3)
    for c in range(C):
        for i in range(n):
            weight[i] = 1.0 if inv[c, i] else 0.0
        for _ in range(iterations):
            G[:], b[:] = prior, 0.0
            for i in range(n):
                if weight[i] == 0.0:
                    continue
                for j in range(2):
                    for p in range(3):
                        b[p] += weight[i] * A[c, i, j, p] * z[i, j]
                        for q in range(3):
                            G[p, q] += weight[i] * A[c, i, j, p] * A[c, i, j, q]
            w[c] = np.linalg.solve(G, b)
            for i in range(n):
                r0 = z[i, 0] - (A[c, i, 0, 0] * w[c, 0] + A[c, i, 0, 1] * w[c, 1] + A[c, i, 0, 2] * w[c, 2])
                r1 = z[i, 1] - (A[c, i, 1, 0] * w[c, 0] + A[c, i, 1, 1] * w[c, 1] + A[c, i, 1, 2] * w[c, 2])
                miss[c, i] = np.sqrt(r0 * r0 + r1 * r1)
                weight[i] = min(1.0, huber / max(miss[c, i], 1e-12)) if inv[c, i] else 0.0
    return w, miss


@njit(cache=True, error_model="numpy")
def scan_steps(meds, n_base, n_recent, min_sigma, cap, shortest):
    """:func:`gymtrack.tracking.drift_scan.scan_steps` in one call: every candidate step m
    (``shortest .. L - n_base`` recent samples) weighed over every key, the first of the best
    kept. meds (Nk, L, 2). Returns shift (Nk, 2), sigma (Nk,), scatter (Nk,), base (Nk, 2), m."""
    Nk, L = meds.shape[0], meds.shape[1]
    best_chi, best_m = -1.0, shortest
    shift, sigma, scatter, base = np.zeros((Nk, 2)), np.full(Nk, np.inf), np.full(Nk, np.inf), np.full((Nk, 2), np.nan)
    sh, sg, sc, bs = np.zeros((Nk, 2)), np.empty(Nk), np.empty(Nk), np.empty((Nk, 2))
    buf = np.empty(n_base)
    for m in range(shortest, L - n_base + 1):
        lo, chi = L - m - n_base, 0.0
        for k in range(Nk):
            good = 0
            for i in range(n_base):
                good += np.isfinite(meds[k, lo + i, 0])
            for q in range(2):
                n = 0
                for i in range(n_base):
                    v = meds[k, lo + i, q]
                    if v == v:
                        buf[n] = v
                        n += 1
                bs[k, q] = _median_of(buf, n)
            n = 0
            for i in range(n_base):
                dx, dy = meds[k, lo + i, 0] - bs[k, 0], meds[k, lo + i, 1] - bs[k, 1]
                d = np.sqrt(dx * dx + dy * dy)
                if d == d:
                    buf[n] = d
                    n += 1
            spread = _median_of(buf, n)
            n_r, t0, t1 = 0, 0.0, 0.0
            for i in range(L - m, L):
                if np.isfinite(meds[k, i, 0]):
                    n_r += 1
                    t0 += meds[k, i, 0] - bs[k, 0]
                    t1 += meds[k, i, 1] - bs[k, 1]
            ready = good >= n_base - 1 and n_r >= n_recent
            n1 = max(n_r, 1)
            sh[k, 0], sh[k, 1] = (t0 / n1, t1 / n1) if ready else (0.0, 0.0)
            sc[k] = max(min_sigma, 1.4826 * (0.0 if spread != spread else spread)) if ready else np.inf
            sg[k] = sc[k] * np.sqrt(n_recent / n1)
            chi += min(cap, (sh[k, 0] ** 2 + sh[k, 1] ** 2) / sg[k] ** 2)
        if chi > best_chi:
            best_chi, best_m = chi, m
            shift[:], sigma[:], scatter[:], base[:] = sh, sg, sc, bs
    return shift, sigma, scatter, base, best_m


def warm_up() -> None:
    """Compile (or load) the kernels: three views of a synthetic cluster, and a short history."""
    C, W = 3, 4
    box = np.ones((C, W, 4))
    eye = np.ascontiguousarray(np.broadcast_to(np.eye(3), (C, 3, 3)))
    Pn = np.zeros((C, 3, 4))
    Pn[:, :, :3] = eye
    pa, pb = np.array([0, 0, 1], np.int64), np.array([1, 2, 2], np.int64)
    key, R, X, S, _, _ = residuals(box, np.ones((C, W), np.bool_), np.arange(C, dtype=np.int64).reshape(1, C), eye, eye,
                                np.eye(3), Pn, pa, pb, 0.05, 1, W - 1)
    medians(key, R, X, S, np.zeros(len(key), np.int64), C * len(pa), 8)
    scan_steps(np.zeros((2, 6, 2)), 3, 2, 1e-5, 16.0, 2)
    key_medians(key, X, C * len(pa))
    turn_fits(np.ones((C, 2, 2, 3)), np.ones((2, 2)), np.ones((C, 2), np.bool_), np.eye(3), 2.5, 2)
