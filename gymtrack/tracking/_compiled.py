"""Compiled (numba) kernels of the tracker's small per-frame and per-window loops.

Paper: no method of its own; these are the hot loops of Section III-A (IoU tracker), III-B
(Eq. 2 distances, Algorithm 1, Eq. 3 triangulation, Eq. 4 outliers, Eq. 10 linking) and
III-C (Eq. 5-7 plane candidates, Eq. 8 plane distances, Eq. 9 fusion) and III-D (Eq. 14 boxes),
written as plain loops.
The arrays of one frame or window are small (tens of boxes, tracklets of 10 frames), so numpy's
per-call overhead dominated the vectorised versions; each kernel here replaces a dozen or more
numpy calls by one call.

Every kernel computes what its numpy reference computes (named in its docstring; the tests in
``tests/test_tracking_compiled.py`` and ``tests/test_plane_compiled.py`` compare them on random
inputs): the same comparisons, tie-breaking and NaN rules, so identifiers and counts never
change; floating-point results are the same up to rounding where the reference sums in a
different order (matrix products).

Compiled with ``cache=True`` (later processes load the machine code from numba's cache, next
to this file or in ``NUMBA_CACHE_DIR``); :func:`warm_up` compiles or loads every kernel with
the argument types the tracker uses, and the :class:`~.tracker.Tracker` calls it when it is
constructed, so that compilation is never counted as tracking time.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_NAN = np.nan


@njit(cache=True, inline="always")
def _nanmin(x, y):
    """``np.minimum`` of two scalars: NaN if either is NaN."""
    if x != x or y != y:
        return _NAN
    return x if x <= y else y


@njit(cache=True, inline="always")
def _nanmax(x, y):
    """``np.maximum`` of two scalars: NaN if either is NaN."""
    if x != x or y != y:
        return _NAN
    return x if x >= y else y


@njit(cache=True, inline="always")
def _fmax(x, y):
    """``np.fmax`` of two scalars: NaN only if both are NaN."""
    if x != x:
        return y
    if y != y:
        return x
    return x if x >= y else y


# ===================================================================== single view (III-A)
@njit(cache=True, error_model="numpy")
def iou_frame(tbox, tcam, tlast, tid, frame, max_age, camera, box, threshold):
    """One frame of :class:`~.single_view.IoUTracker` up to the assignment.

    tbox: (5, T) live tracks' last boxes as :func:`~.single_view.corners` rows; tcam, tlast,
    tid: (T,) their camera, last frame and id; camera: (N,) int64; box: (N, 4) centre-form boxes.

    Drops tracks older than ``max_age + 1`` frames, builds the boxes' corners (shifted per
    camera) and the IoU (:func:`~.single_view.iou_corners`) of every track and box of one camera
    (boxes of different cameras never overlap). Of the allowed pairs (IoU >= ``threshold``)
    those whose track and box have no other allowed partner are matched directly; the rest
    (the tracks and boxes of conflicting components) are left to the caller's assignment as a
    sub-matrix, ``-IoU`` where allowed and 0 elsewhere (``assign``'s cost).

    Returns (tbox', tcam', tlast', tid', cb (5, N), rows, cols (the direct matches),
    conflict_rows (R,), conflict_cols (Q,), cost (R, Q), allowed (R, Q)).
    """
    T = tid.shape[0]
    keep = np.empty(T, np.int64)
    n_keep = 0
    for i in range(T):
        if frame - tlast[i] <= max_age + 1:
            keep[n_keep] = i
            n_keep += 1
    tb = np.empty((5, n_keep))
    tc = np.empty(n_keep, np.int64)
    tl = np.empty(n_keep, np.int64)
    ti = np.empty(n_keep, np.int64)
    for a in range(n_keep):
        i = keep[a]
        for r in range(5):
            tb[r, a] = tbox[r, i]
        tc[a] = tcam[i]
        tl[a] = tlast[i]
        ti[a] = tid[i]
    N = box.shape[0]
    cb = np.empty((5, N))
    for j in range(N):
        half_w, half_h = box[j, 2] * 0.5, box[j, 3] * 0.5
        shift = camera[j] * 1e6
        cb[0, j] = (box[j, 0] - half_w) + shift
        cb[1, j] = box[j, 1] - half_h
        cb[2, j] = (box[j, 0] + half_w) + shift
        cb[3, j] = box[j, 1] + half_h
        cb[4, j] = box[j, 2] * box[j, 3]
    iou = np.zeros((n_keep, N))
    allowed = np.zeros((n_keep, N), np.bool_)
    row_count = np.zeros(n_keep, np.int64)
    col_count = np.zeros(N, np.int64)
    for i in range(n_keep):
        for j in range(N):
            if tc[i] != camera[j]:
                continue
            iw = _nanmax(_nanmin(tb[2, i], cb[2, j]) - _nanmax(tb[0, i], cb[0, j]), 0.0)
            ih = _nanmax(_nanmin(tb[3, i], cb[3, j]) - _nanmax(tb[1, i], cb[1, j]), 0.0)
            inter = iw * ih
            v = inter / (tb[4, i] + cb[4, j] - inter)
            if v >= threshold:
                iou[i, j] = v
                allowed[i, j] = True
                row_count[i] += 1
                col_count[j] += 1
    # direct matches: an allowed pair whose track and box have no other candidate
    n_direct = 0
    for i in range(n_keep):
        for j in range(N):
            if allowed[i, j] and row_count[i] == 1 and col_count[j] == 1:
                n_direct += 1
    rows = np.empty(n_direct, np.int64)
    cols = np.empty(n_direct, np.int64)
    in_row = np.zeros(n_keep, np.bool_)  # a track / box in a conflicting component
    in_col = np.zeros(N, np.bool_)
    k = 0
    for i in range(n_keep):
        for j in range(N):
            if allowed[i, j]:
                if row_count[i] == 1 and col_count[j] == 1:
                    rows[k] = i
                    cols[k] = j
                    k += 1
                else:
                    in_row[i] = True
                    in_col[j] = True
    conflict_rows = np.flatnonzero(in_row)
    conflict_cols = np.flatnonzero(in_col)
    R, Q = conflict_rows.shape[0], conflict_cols.shape[0]
    cost = np.zeros((R, Q))
    sub = np.zeros((R, Q), np.bool_)
    for a in range(R):
        for b in range(Q):
            i, j = conflict_rows[a], conflict_cols[b]
            if allowed[i, j]:
                cost[a, b] = -iou[i, j]
                sub[a, b] = True
    return tb, tc, tl, ti, cb, rows, cols, conflict_rows, conflict_cols, cost, sub


@njit(cache=True)
def iou_commit(tbox, tcam, tlast, tid, next_id, frame, camera, cb, rows, cols):
    """The rest of one :class:`~.single_view.IoUTracker` frame: matched tracks take their box,
    unmatched boxes start tracks (ids ``next_id, next_id + 1, ...`` in box order).

    tbox (5, T), tcam, tlast, tid (T,): the live tracks; camera (N,), cb (5, N): the frame's
    cameras and corners; rows, cols: matched (track, box) pairs.
    Returns (tbox', tcam', tlast', tid', ids (N,), next_id').
    """
    N = cb.shape[1]
    T = tid.shape[0]
    ids = np.full(N, -1, np.int64)
    n_new = N
    for k in range(rows.shape[0]):
        ids[cols[k]] = tid[rows[k]]
        n_new -= 1
    out_b = np.empty((5, T + n_new))
    out_c = np.empty(T + n_new, np.int64)
    out_l = np.empty(T + n_new, np.int64)
    out_i = np.empty(T + n_new, np.int64)
    out_b[:, :T] = tbox
    out_c[:T] = tcam
    out_l[:T] = tlast
    out_i[:T] = tid
    for k in range(rows.shape[0]):
        r, c = rows[k], cols[k]
        for q in range(5):
            out_b[q, r] = cb[q, c]
        out_l[r] = frame
    a = T
    for j in range(N):
        if ids[j] < 0:
            ids[j] = next_id
            for q in range(5):
                out_b[q, a] = cb[q, j]
            out_c[a] = camera[j]
            out_l[a] = frame
            out_i[a] = next_id
            next_id += 1
            a += 1
    return out_b, out_c, out_l, out_i, ids, next_id


# ===================================================================== windows (III-A)
@njit(cache=True)
def fill_missing(box, observed, max_extrapolate):
    """:func:`~.windows.fill_missing`: box (K, W, 4), observed (K, W) bool ->
    (filled (K, W, 4) NaN where not valid, valid (K, W) bool)."""
    K, W = observed.shape
    filled = box.copy()
    valid = observed.copy()
    prev = np.empty(W, np.int64)
    nxt = np.empty(W, np.int64)
    for k in range(K):
        p = -1
        for t in range(W):
            if observed[k, t]:
                p = t
            prev[t] = p
        n = W
        for t in range(W - 1, -1, -1):
            if observed[k, t]:
                n = t
            nxt[t] = n
        for t in range(W):
            if observed[k, t]:
                continue
            p, n = prev[t], nxt[t]
            hasp, hasn = p >= 0, n < W
            inside = hasp and hasn
            ok = inside or ((not hasp) and n - t <= max_extrapolate) or ((not hasn) and t - p <= max_extrapolate)
            valid[k, t] = ok
            if not ok:
                for q in range(4):
                    filled[k, t, q] = _NAN
                continue
            lo = p if hasp else n
            hi = n if hasn else p
            a = (t - lo) / max(hi - lo, 1) if inside else 0.0
            for q in range(4):
                filled[k, t, q] = box[k, lo, q] * (1.0 - a) + box[k, hi, q] * a
    return filled, valid


# ===================================================================== clustering (III-B)
@njit(cache=True, error_model="numpy")
def tracklet_distances(camera, box, observed, F):
    """Eq. 2, :func:`~.clustering.tracklet_distances`: camera (K,) int64, box (K, W, 4),
    observed (K, W) bool, F (C, C, 3, 3) -> (K, K) (NaN: no shared frame; inf: same camera)."""
    K, W = observed.shape
    C = F.shape[0]
    xh = np.zeros((K, W, 3))
    for k in range(K):
        for t in range(W):
            if observed[k, t]:
                s = abs(box[k, t, 2] + box[k, t, 3])
                xh[k, t, 0] = box[k, t, 0] / s
                xh[k, t, 1] = box[k, t, 1] / s
                xh[k, t, 2] = 1.0 / s
    # lines[k, c, t]: epipolar line in view c of segment k's centre at frame t, unit normal
    lines = np.zeros((K, C, W, 3))
    for k in range(K):
        ck = camera[k]
        for c in range(C):
            if c == ck:
                continue
            for t in range(W):
                if not observed[k, t]:
                    continue
                x0, x1, x2 = xh[k, t, 0], xh[k, t, 1], xh[k, t, 2]
                l0 = F[ck, c, 0, 0] * x0 + F[ck, c, 0, 1] * x1 + F[ck, c, 0, 2] * x2
                l1 = F[ck, c, 1, 0] * x0 + F[ck, c, 1, 1] * x1 + F[ck, c, 1, 2] * x2
                l2 = F[ck, c, 2, 0] * x0 + F[ck, c, 2, 1] * x1 + F[ck, c, 2, 2] * x2
                norm = np.sqrt(l0 * l0 + l1 * l1)
                if norm == 0:
                    norm = 1.0
                lines[k, c, t, 0] = l0 / norm
                lines[k, c, t, 1] = l1 / norm
                lines[k, c, t, 2] = l2 / norm
    D = np.empty((K, K))
    for i in range(K):
        D[i, i] = np.inf
        for j in range(i + 1, K):
            if camera[i] == camera[j]:
                D[i, j] = np.inf
                D[j, i] = np.inf
                continue
            ci, cj = camera[i], camera[j]
            s = 0.0
            n = 0
            for t in range(W):
                if observed[i, t] and observed[j, t]:
                    n += 1
                    # centre of j against the line of i in view cj, and the other way round
                    s += abs(xh[j, t, 0] * lines[i, cj, t, 0] + xh[j, t, 1] * lines[i, cj, t, 1]
                             + xh[j, t, 2] * lines[i, cj, t, 2])
                    s += abs(xh[i, t, 0] * lines[j, ci, t, 0] + xh[i, t, 1] * lines[j, ci, t, 1]
                             + xh[i, t, 2] * lines[j, ci, t, 2])
            v = s / n if n > 0 else _NAN
            D[i, j] = v
            D[j, i] = v
    return D


@njit(cache=True)
def number_by_first_member(owner):
    """:func:`~.clustering._number_by_first_member`: (K,) cluster representatives -> labels
    0..n-1 in order of each cluster's first member."""
    K = owner.shape[0]
    first = np.full(K, K, np.int64)
    for i in range(K):
        o = owner[i]
        if i < first[o]:
            first[o] = i
    label_of = np.full(K, -1, np.int64)
    labels = np.empty(K, np.int64)
    n = 0
    for i in range(K):
        f = first[owner[i]]
        if label_of[f] < 0:
            label_of[f] = n
            n += 1
        labels[i] = label_of[f]
    return labels


@njit(cache=True)
def complete_linkage(D, threshold):
    """Algorithm 1, :func:`~.clustering.complete_linkage` (the same reciprocal-nearest-neighbour
    rounds, ties and NaN / inf rules): D (K, K) float64 -> (K,) labels."""
    K = D.shape[0]
    S = D.copy()
    owner = np.arange(K)
    if K < 2:
        return number_by_first_member(owner)
    for i in range(K):
        S[i, i] = _NAN
    nn = np.empty(K, np.int64)
    d = np.empty(K)
    I = np.empty(K, np.int64)
    while True:
        for i in range(K):  # nearest neighbour; unknown (NaN) counts as +inf; ties: first
            best, bj = np.inf, 0
            for j in range(K):
                x = S[i, j]
                if x == x and x < best:
                    best, bj = x, j
            nn[i] = bj
            d[i] = best
        m = 0
        for i in range(K):
            j = nn[i]
            if nn[j] == i and i < j and d[i] < threshold:
                I[m] = i
                m += 1
        if m == 0:
            best, bi = d[0], 0
            for i in range(1, K):
                if d[i] < best:
                    best, bi = d[i], i
            if not best < threshold:
                break
            I[0] = bi
            m = 1
        for a in range(m):  # rows, then columns (fmax is order-independent)
            i, j = I[a], nn[I[a]]
            for q in range(K):
                S[i, q] = _fmax(S[i, q], S[j, q])
        for a in range(m):
            i, j = I[a], nn[I[a]]
            for q in range(K):
                S[q, i] = _fmax(S[q, i], S[q, j])
        for a in range(m):
            i, j = I[a], nn[I[a]]
            for q in range(K):
                S[j, q] = _NAN
                S[q, j] = _NAN
        for a in range(m):
            S[I[a], I[a]] = _NAN
        relabel = np.arange(K)
        for a in range(m):
            relabel[nn[I[a]]] = I[a]
        for q in range(K):
            owner[q] = relabel[owner[q]]
    return number_by_first_member(owner)


# ===================================================================== triangulation (III-B)
@njit(cache=True, inline="always")
def _solve3_sym(s0, s1, s2, s3, s4, s5, b0, b1, b2):
    """Adjugate solve of a symmetric 3x3 system ``[[s0 s1 s2] [s1 s3 s4] [s2 s4 s5]] x = b``
    (:func:`gymtrack.geometry.triangulation._solve3_sym`); NaN when singular."""
    c0 = s3 * s5 - s4 * s4
    c1 = s2 * s4 - s1 * s5
    c2 = s1 * s4 - s2 * s3
    c3 = s0 * s5 - s2 * s2
    c4 = s1 * s2 - s0 * s4
    c5 = s0 * s3 - s1 * s1
    det = s0 * c0 + s1 * c1 + s2 * c2
    if det == 0:
        return _NAN, _NAN, _NAN
    return ((c0 * b0 + c1 * b1) + c2 * b2) / det, ((c1 * b0 + c3 * b1) + c4 * b2) / det, \
        ((c2 * b0 + c4 * b1) + c5 * b2) / det


@njit(cache=True, error_model="numpy")
def _cost(P, u, v, w, n, X0, X1, X2, px, py, iz, rx, ry):
    """Reprojection residuals of point n at X over the views (written into px, py, iz, rx, ry
    (V,)); returns the summed squared residual."""
    V = P.shape[0]
    total = 0.0
    for c in range(V):
        x = P[c, 0, 0] * X0 + P[c, 0, 1] * X1 + P[c, 0, 2] * X2 + P[c, 0, 3]
        y = P[c, 1, 0] * X0 + P[c, 1, 1] * X1 + P[c, 1, 2] * X2 + P[c, 1, 3]
        z = P[c, 2, 0] * X0 + P[c, 2, 1] * X1 + P[c, 2, 2] * X2 + P[c, 2, 3]
        if w[c, n] == 0.0:
            z = 1.0  # missing view: any finite value, weight 0
        px[c], py[c], iz[c] = x / z, y / z, w[c, n] / z
        rx[c], ry[c] = (px[c] - u[c, n]) * w[c, n], (py[c] - v[c, n]) * w[c, n]
        total += rx[c] * rx[c] + ry[c] * ry[c]
    return total


@njit(cache=True, error_model="numpy")
def triangulate_views(P, u, v, mask, iterations):
    """Eq. 3, :func:`gymtrack.geometry.triangulation.triangulate_views` (DLT with normalised
    rows, then ``iterations`` damped Gauss-Newton steps), one point at a time.

    P: (V, 3, 4); u, v: (V, N) undistorted pixels; mask: (V, N) bool, the views to use (also
    required finite). Returns X (3, N) (NaN with fewer than 2 views) and the RMS reprojection
    error (N,).
    """
    V, N = u.shape
    X = np.full((3, N), _NAN)
    err = np.full(N, _NAN)
    w = np.zeros((V, N))
    uu = np.zeros((V, N))
    vv = np.zeros((V, N))
    px, py, iz = np.empty(V), np.empty(V), np.empty(V)
    rx, ry = np.empty(V), np.empty(V)
    cpx, cpy, ciz = np.empty(V), np.empty(V), np.empty(V)
    crx, cry = np.empty(V), np.empty(V)
    for n in range(N):
        nv = 0.0
        for c in range(V):
            if mask[c, n] and np.isfinite(u[c, n]) and np.isfinite(v[c, n]):
                w[c, n] = 1.0
                uu[c, n], vv[c, n] = u[c, n], v[c, n]
                nv += 1.0
        if nv < 2:
            continue
        # DLT: rows r = t P3 - Pk (t = u, v), weighted by 1 / |r|^2, least squares with X_h = [X, 1]
        a00 = a01 = a02 = a11 = a12 = a22 = 0.0
        b0 = b1 = b2 = 0.0
        for c in range(V):
            if w[c, n] == 0.0:
                continue
            for k in range(2):
                t = uu[c, n] if k == 0 else vv[c, n]
                r0 = t * P[c, 2, 0] - P[c, k, 0]
                r1 = t * P[c, 2, 1] - P[c, k, 1]
                r2 = t * P[c, 2, 2] - P[c, k, 2]
                r3 = t * P[c, 2, 3] - P[c, k, 3]
                norm2 = r0 * r0 + r1 * r1 + r2 * r2 + r3 * r3
                s = 1.0 / (norm2 if norm2 > 0 else 1.0)
                a00 += s * r0 * r0
                a01 += s * r0 * r1
                a02 += s * r0 * r2
                a11 += s * r1 * r1
                a12 += s * r1 * r2
                a22 += s * r2 * r2
                b0 += s * r0 * r3
                b1 += s * r1 * r3
                b2 += s * r2 * r3
        X0, X1, X2 = _solve3_sym(a00, a01, a02, a11, a12, a22, -b0, -b1, -b2)
        old = _cost(P, uu, vv, w, n, X0, X1, X2, px, py, iz, rx, ry)
        lam = 1e-3
        for it in range(iterations):
            j00 = j01 = j02 = j11 = j12 = j22 = 0.0
            g0 = g1 = g2 = 0.0
            for c in range(V):
                A00, A01, A02 = P[c, 0, 0], P[c, 0, 1], P[c, 0, 2]
                A10, A11, A12 = P[c, 1, 0], P[c, 1, 1], P[c, 1, 2]
                A20, A21, A22 = P[c, 2, 0], P[c, 2, 1], P[c, 2, 2]
                # Jacobian rows iz (A0 - px A2) and iz (A1 - py A2)
                e0, e1, e2 = A00 - px[c] * A20, A01 - px[c] * A21, A02 - px[c] * A22
                f0, f1, f2 = A10 - py[c] * A20, A11 - py[c] * A21, A12 - py[c] * A22
                i2 = iz[c] * iz[c]
                j00 += i2 * (e0 * e0 + f0 * f0)
                j01 += i2 * (e0 * e1 + f0 * f1)
                j02 += i2 * (e0 * e2 + f0 * f2)
                j11 += i2 * (e1 * e1 + f1 * f1)
                j12 += i2 * (e1 * e2 + f1 * f2)
                j22 += i2 * (e2 * e2 + f2 * f2)
                g0 += iz[c] * (rx[c] * e0 + ry[c] * f0)
                g1 += iz[c] * (rx[c] * e1 + ry[c] * f1)
                g2 += iz[c] * (rx[c] * e2 + ry[c] * f2)
            damp = lam * (j00 + j11 + j22) / 3
            s0, s1, s2 = _solve3_sym(j00 + damp, j01, j02, j11 + damp, j12, j22 + damp, -g0, -g1, -g2)
            c0 = X0 + (s0 if np.isfinite(s0) else 0.0)
            c1 = X1 + (s1 if np.isfinite(s1) else 0.0)
            c2 = X2 + (s2 if np.isfinite(s2) else 0.0)
            new = _cost(P, uu, vv, w, n, c0, c1, c2, cpx, cpy, ciz, crx, cry)
            if np.isfinite(new) and new <= old:
                X0, X1, X2, old = c0, c1, c2, new
                px, cpx = cpx, px
                py, cpy = cpy, py
                iz, ciz = ciz, iz
                rx, crx = crx, rx
                ry, cry = cry, ry
                lam *= 0.3
            else:
                lam *= 10.0
        X[0, n], X[1, n], X[2, n] = X0, X1, X2
        err[n] = np.sqrt(old / nv)
    return X, err


@njit(cache=True)
def cluster_points(box, observed, members):
    """The pixels :func:`~.reconstruct.triangulate_clusters` triangulates and its observed-view
    counts: box (K, W, 4) segment boxes (NaN where not valid), observed (K, W), members (M, C)
    segment per cluster and camera (-1: none).

    Returns u, v (C, 3 M W) centre, top-centre and bottom-centre pixels, views-major (NaN
    where the camera has no member or the box is not valid), and n_views (M, W) int8.
    """
    M, C = members.shape
    W = box.shape[1]
    u = np.full((C, 3 * M * W), _NAN)
    v = np.full((C, 3 * M * W), _NAN)
    n_views = np.zeros((M, W), np.int8)
    for m in range(M):
        for c in range(C):
            k = members[m, c]
            if k < 0:
                continue
            for t in range(W):
                x, y, half = box[k, t, 0], box[k, t, 1], box[k, t, 3] / 2
                q = m * W + t
                for p in range(3):
                    u[c, p * M * W + q] = x
                v[c, q] = y
                v[c, M * W + q] = y - half
                v[c, 2 * M * W + q] = y + half
                if observed[k, t]:
                    n_views[m, t] += 1
    return u, v, n_views


@njit(cache=True)
def outliers(xyz, valid, space, max_speed):
    """Eq. 4, :func:`~.reconstruct.outliers`: xyz (M, W, 3), valid (M, W), space (6,),
    max_speed (metres per frame) -> (M,) bool, True = outlier."""
    M, W = valid.shape
    bad = np.zeros(M, np.bool_)
    for m in range(M):
        any_valid = False
        p = -1
        for t in range(W):
            if not valid[m, t]:
                continue
            any_valid = True
            for q in range(3):
                x = xyz[m, t, q]
                if not (x >= space[q] and x <= space[3 + q]):
                    bad[m] = True
            if p >= 0:
                d0 = xyz[m, t, 0] - xyz[m, p, 0]
                d1 = xyz[m, t, 1] - xyz[m, p, 1]
                d2 = xyz[m, t, 2] - xyz[m, p, 2]
                if np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) > max_speed * (t - p):
                    bad[m] = True
            p = t
        if not any_valid:
            bad[m] = True
    return bad


# ===================================================================== linking (III-B) and plane (III-C)
@njit(cache=True, error_model="numpy")
def link_distances(prev_xyz, prev_valid, new_xyz, new_valid, offset):
    """Eq. 10, :func:`~.linking.link_distances`: (Mp, W, 3), (Mp, W), (Mn, W, 3), (Mn, W) and
    the step -> (Mp, Mn) metres, NaN where no valid frame is shared."""
    Mp, W = prev_valid.shape
    Mn = new_valid.shape[0]
    Wo = W - offset
    D = np.empty((Mp, Mn))
    for i in range(Mp):
        for j in range(Mn):
            s = 0.0
            n = 0
            for t in range(Wo):
                if prev_valid[i, offset + t] and new_valid[j, t]:
                    d0 = prev_xyz[i, offset + t, 0] - new_xyz[j, t, 0]
                    d1 = prev_xyz[i, offset + t, 1] - new_xyz[j, t, 1]
                    d2 = prev_xyz[i, offset + t, 2] - new_xyz[j, t, 2]
                    s += np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                    n += 1
            D[i, j] = s / n if n > 0 else _NAN
    return D


@njit(cache=True, error_model="numpy")
def candidate_distances(X, observed, camera, exists):
    """Eq. 8 on every plane, :func:`~.plane_fallback.candidate_distances`: X (P, K, W, 3),
    observed (K, W), camera (K,), exists (P, K, W) -> (P, K, K) (NaN: no shared frame; inf:
    same camera)."""
    P, K, W = exists.shape
    D = np.empty((P, K, K))
    for p in range(P):
        for i in range(K):
            D[p, i, i] = np.inf
            for j in range(i + 1, K):
                if camera[i] == camera[j]:
                    D[p, i, j] = np.inf
                    D[p, j, i] = np.inf
                    continue
                s = 0.0
                n = 0
                for t in range(W):
                    if observed[i, t] and observed[j, t] and exists[p, i, t] and exists[p, j, t]:
                        d0 = X[p, i, t, 0] - X[p, j, t, 0]
                        d1 = X[p, i, t, 1] - X[p, j, t, 1]
                        d2 = X[p, i, t, 2] - X[p, j, t, 2]
                        s += np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                        n += 1
                v = s / n if n > 0 else _NAN
                D[p, i, j] = v
                D[p, j, i] = v
    return D



@njit(cache=True, error_model="numpy")
def plane_candidates(box, camera, back, centres, ppoint, pnormal, min_cos):
    """Eq. 5-7 for the box centre, top-centre and bottom-centre of every segment, frame and plane
    (:func:`~.plane_fallback.plane_candidates`, the arithmetic of
    :func:`gymtrack.geometry.plane.intersect_rays_plane`).

    box: (K, W, 4) centre-form undistorted boxes (NaN where not valid); camera: (K,) int64;
    back: (C, 3, 3) ``R^T K^-1``; centres: (C, 3) camera centres; ppoint, pnormal: (P, 3) plane
    points and unit normals; min_cos: rays with ``|cos|`` to the normal below it are parallel.
    Returns X (3, P, K, W, 3) (centre, top, bottom; NaN where there is no intersection) and
    ok (3, P, K, W) bool: the ray is not parallel (nor NaN / zero) and the plane is in front.
    """
    K, W = box.shape[0], box.shape[1]
    P = ppoint.shape[0]
    X = np.full((3, P, K, W, 3), _NAN)
    ok = np.zeros((3, P, K, W), np.bool_)
    num = np.empty(P)
    for k in range(K):
        c = camera[k]
        o0, o1, o2 = centres[c, 0], centres[c, 1], centres[c, 2]
        for p in range(P):  # n . (X^p - X^o), one per segment and plane
            num[p] = (ppoint[p, 0] - o0) * pnormal[p, 0] + (ppoint[p, 1] - o1) * pnormal[p, 1] \
                + (ppoint[p, 2] - o2) * pnormal[p, 2]
        for q in range(3):
            sign = 0.0 if q == 0 else (-0.5 if q == 1 else 0.5)
            for t in range(W):
                u = box[k, t, 0]
                v = box[k, t, 1] if q == 0 else box[k, t, 1] + sign * box[k, t, 3]
                d0 = back[c, 0, 0] * u + back[c, 0, 1] * v + back[c, 0, 2]
                d1 = back[c, 1, 0] * u + back[c, 1, 1] * v + back[c, 1, 2]
                d2 = back[c, 2, 0] * u + back[c, 2, 1] * v + back[c, 2, 2]
                dlen = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                for p in range(P):
                    dn = d0 * pnormal[p, 0] + d1 * pnormal[p, 1] + d2 * pnormal[p, 2]
                    # written negated so that zero-length and NaN directions count as parallel
                    if not (abs(dn) >= min_cos * dlen) or not (dlen > 0):
                        continue
                    lam = num[p] / dn
                    if not lam > 0:  # the plane is behind the camera
                        continue
                    ok[q, p, k, t] = True
                    X[q, p, k, t, 0] = o0 + lam * d0
                    X[q, p, k, t, 1] = o1 + lam * d1
                    X[q, p, k, t, 2] = o2 + lam * d2
    return X, ok


@njit(cache=True)
def best_plane_distance(Dp):
    """:func:`~.plane_fallback.best_plane_distance`: (P, K, K) -> (K, K), the smallest known
    (not NaN) distance over the planes, NaN where none is known."""
    P, K = Dp.shape[0], Dp.shape[1]
    D = np.empty((K, K))
    for i in range(K):
        for j in range(K):
            best = np.inf
            known = False
            for p in range(P):
                x = Dp[p, i, j]
                if x == x:
                    known = True
                    if x < best:
                        best = x
            D[i, j] = best if known else _NAN
    return D


@njit(cache=True, error_model="numpy")
def fuse_on_planes(X, ok, Dp, labels, camera, observed, n_cameras, single, code, interpolated):
    """Eq. 9, :func:`~.plane_fallback.fuse_on_planes`: the members of each cluster of two or more
    views (or a permitted single) averaged on the plane that minimises their mean Eq. 8 distance.

    X: (3, P, K, W, 3) centre / top / bottom candidates; ok: (3, P, K, W) where they exist;
    Dp: (P, K, K) Eq. 8 distances; labels: (K,) int64 clusters (at most one segment per camera);
    camera: (K,) int64; observed: (K, W) bool; single: (K,) bool segments that may stand alone
    (or (0,): none); code / interpolated: the source codes of a point with / without an
    observed view. Returns xyz (M, W, 3), top_z, bottom_z (M, W), valid (M, W), source (M, W)
    int8, n_views (M, W) int8 and members (M, C) int64, in cluster order.
    """
    P = X.shape[1]
    K, W = observed.shape
    C = n_cameras
    n_clusters = 0
    for k in range(K):
        if labels[k] + 1 > n_clusters:
            n_clusters = labels[k] + 1
    every = np.full((n_clusters, C), -1, np.int64)
    for k in range(K):
        every[labels[k], camera[k]] = k
    keep = np.zeros(n_clusters, np.bool_)
    M = 0
    for m in range(n_clusters):
        count, last = 0, -1
        for c in range(C):
            if every[m, c] >= 0:
                count += 1
                last = every[m, c] if every[m, c] > last else last
        keep[m] = count >= 2 or (count == 1 and single.shape[0] > 0 and single[last])
        if keep[m]:
            M += 1
    members = np.empty((M, C), np.int64)
    a = 0
    for m in range(n_clusters):
        if keep[m]:
            members[a] = every[m]
            a += 1
    xyz = np.full((M, W, 3), _NAN)
    top = np.full((M, W), _NAN)
    bottom = np.full((M, W), _NAN)
    valid = np.zeros((M, W), np.bool_)
    source = np.empty((M, W), np.int8)
    n_views = np.zeros((M, W), np.int8)
    for m in range(M):
        plane = 0
        if P > 1:  # the plane minimising the mean pairwise distance of the cluster's members
            best = np.inf
            for p in range(P):
                s, n = 0.0, 0
                for ca in range(C):
                    i = members[m, ca]
                    if i < 0:
                        continue
                    for cb in range(C):
                        j = members[m, cb]
                        if cb == ca or j < 0:
                            continue
                        d = Dp[p, i, j]
                        if np.isfinite(d):
                            s += d
                            n += 1
                mean = s / n if n > 0 else np.inf
                if mean < best:
                    best, plane = mean, p
        for t in range(W):
            for q in range(3):
                s0, s1, s2, n = 0.0, 0.0, 0.0, 0
                for c in range(C):
                    k = members[m, c]
                    if k >= 0 and ok[q, plane, k, t]:
                        s0 += X[q, plane, k, t, 0]
                        s1 += X[q, plane, k, t, 1]
                        s2 += X[q, plane, k, t, 2]
                        n += 1
                if q == 0:
                    if n == 0:
                        break  # no centre: the frame is not valid, top and bottom stay NaN
                    valid[m, t] = True
                    xyz[m, t, 0], xyz[m, t, 1], xyz[m, t, 2] = s0 / n, s1 / n, s2 / n
                elif n > 0:
                    if q == 1:
                        top[m, t] = s2 / n
                    else:
                        bottom[m, t] = s2 / n
            nv = 0
            for c in range(C):
                k = members[m, c]
                if k >= 0 and observed[k, t] and ok[0, plane, k, t]:
                    nv += 1
            n_views[m, t] = nv
            source[m, t] = code if nv > 0 else interpolated
    return xyz, top, bottom, valid, source, n_views, members


@njit(cache=True, error_model="numpy")
def plane_stage(box, observed, camera, back, centres, ppoint, pnormal, min_cos, threshold, group, apart, single,
                n_cameras, code, interpolated):
    """The whole plane fallback of one window, :func:`~.plane_fallback.plane_stage`: candidates
    (:func:`plane_candidates`), Eq. 8 (:func:`candidate_distances`, :func:`best_plane_distance`),
    Algorithm 1 (:func:`complete_linkage`) and Eq. 9 (:func:`fuse_on_planes`) in one call.

    box (K, W, 4), observed (K, W), camera (K,) int64: the segments; back, centres, ppoint,
    pnormal, min_cos: as :func:`plane_candidates`; threshold: Algorithm 1 threshold (metres);
    group: (K,) int64 oracle person ids (pairs of different ids never match) or (0,): none;
    apart: (K, K) bool pairs that never match, or (0, 0): none; single: (K,) bool or (0,);
    n_cameras, code, interpolated: as :func:`fuse_on_planes`. Returns what
    :func:`fuse_on_planes` returns (M = 0 when nothing is fused).
    """
    K, W = observed.shape
    P = ppoint.shape[0]
    any_single = False
    for k in range(single.shape[0]):
        if single[k]:
            any_single = True
    if (K < 2 and not any_single) or P == 0:
        X = np.full((3, P, K, W, 3), _NAN)
        ok = np.zeros((3, P, K, W), np.bool_)
        return fuse_on_planes(X, ok, np.zeros((P, K, K)), np.zeros(0, np.int64), camera[:0], observed[:0],
                              n_cameras, single, code, interpolated)
    X, ok = plane_candidates(box, camera, back, centres, ppoint, pnormal, min_cos)
    Dp = candidate_distances(X[0], observed, camera, ok[0])
    D = best_plane_distance(Dp)
    agree = False
    for i in range(K):
        for j in range(K):
            if group.shape[0] > 0 and group[i] != group[j]:
                D[i, j] = np.inf
            if apart.shape[0] > 0 and apart[i, j]:
                D[i, j] = np.inf
            if D[i, j] < threshold:
                agree = True
    if not agree and not any_single:  # no two views agree: every candidate is discarded
        return fuse_on_planes(X, ok, Dp, np.zeros(0, np.int64), camera[:0], observed[:0], n_cameras, single,
                              code, interpolated)
    labels = complete_linkage(D, threshold) if agree else np.arange(K)
    return fuse_on_planes(X, ok, Dp, labels, camera, observed, n_cameras, single, code, interpolated)


# ----------------------------------------------------------------------------- Eq. 14 (target stage)
@njit(cache=True, inline="always")
def _project_one(X0, X1, X2, R, t, K, dist, c):
    """One world point into camera ``c``: (u, v, depth), raw pixels with OpenCV's 8-coefficient
    distortion (NaN u, v behind the camera); the model of :meth:`Camera.project`."""
    xc = R[c, 0, 0] * X0 + R[c, 0, 1] * X1 + R[c, 0, 2] * X2 + t[c, 0]
    yc = R[c, 1, 0] * X0 + R[c, 1, 1] * X1 + R[c, 1, 2] * X2 + t[c, 1]
    zc = R[c, 2, 0] * X0 + R[c, 2, 1] * X1 + R[c, 2, 2] * X2 + t[c, 2]
    if not zc > 1e-12:
        return _NAN, _NAN, zc
    x = xc / zc
    y = yc / zc
    k1, k2, p1, p2, k3, k4, k5, k6 = dist[c, 0], dist[c, 1], dist[c, 2], dist[c, 3], dist[c, 4], dist[c, 5], \
        dist[c, 6], dist[c, 7]
    r2 = x * x + y * y
    radial = (1 + k1 * r2 + k2 * r2 ** 2 + k3 * r2 ** 3) / (1 + k4 * r2 + k5 * r2 ** 2 + k6 * r2 ** 3)
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return K[c, 0, 0] * xd + K[c, 0, 1] * yd + K[c, 0, 2], K[c, 1, 1] * yd + K[c, 1, 2], zc


@njit(cache=True, error_model="numpy")
def buffered_boxes(xyz, top_z, bottom_z, wh, box_scale, across, half_depth, tied, prior, R, t, K, dist, sizes,
                   min_cos, min_half_length, default_half_height):
    """Eq. 14 boxes with the body box where a view has no detection (``target.buffered_boxes``).

    xyz (N, 3), top_z, bottom_z (N,), wh (N, C, 2), across (N, 3) unit horizontal normals of the
    plane, half_depth (metres), tied (no plane: half-depth = half-length), prior (the last
    half-length measured before these rows); R, t, K, dist (C, 8), sizes (C, 2): the rig.
    Returns (box (N, C, 4), ok (N, C), the last half-length).
    """
    N, C = wh.shape[0], wh.shape[1]
    box = np.empty((N, C, 4))
    ok = np.zeros((N, C), np.bool_)
    u = np.empty(C)
    v = np.empty(C)
    z = np.empty(C)
    size = np.empty(C)
    lo_u = np.empty(C)
    hi_u = np.empty(C)
    lo_v = np.empty(C)
    hi_v = np.empty(C)
    a_last = prior
    for n in range(N):
        X0, X1, X2 = xyz[n, 0], xyz[n, 1], xyz[n, 2]
        b0, b1 = across[n, 0], across[n, 1]
        g0, g1 = -b1, b0  # along the plane
        missing = False
        best = -np.inf
        for c in range(C):
            u[c], v[c], z[c] = _project_one(X0, X1, X2, R, t, K, dist, c)
            w, h = wh[n, c, 0], wh[n, c, 1]
            size[c] = max(w, h) if (w == w and h == h) else _NAN
            if size[c] != size[c]:
                missing = True
                continue
            if not z[c] > 0:
                continue
            metres = w * z[c] / K[c, 0, 0]  # the box width at the centre's depth
            ca = abs(R[c, 0, 0] * g0 + R[c, 0, 1] * g1)
            cb = abs(R[c, 0, 0] * b0 + R[c, 0, 1] * b1)
            if tied:
                a = metres / (2 * (ca + cb))
            elif ca >= min_cos:
                a = (metres / 2 - half_depth * cb) / ca
            else:
                continue
            if a == a and abs(a) != np.inf and a > best:
                best = a
        if best > -np.inf:
            a_last = max(best, min_half_length)
        if missing:
            a = a_last
            b = a if tied else half_depth
            top = top_z[n] if top_z[n] == top_z[n] else X2 + default_half_height
            bot = bottom_z[n] if bottom_z[n] == bottom_z[n] else X2 - default_half_height
            for c in range(C):
                lo_u[c] = np.inf
                hi_u[c] = -np.inf
                lo_v[c] = np.inf
                hi_v[c] = -np.inf
            for sa in (-1.0, 1.0):
                for sb in (-1.0, 1.0):
                    cx = X0 + sa * a * g0 + sb * b * b0
                    cy = X1 + sa * a * g1 + sb * b * b1
                    for cz in (bot, top):
                        for c in range(C):
                            if size[c] == size[c]:
                                continue
                            pu, pv, _ = _project_one(cx, cy, cz, R, t, K, dist, c)
                            if pu == pu:
                                lo_u[c] = min(lo_u[c], pu)
                                hi_u[c] = max(hi_u[c], pu)
                                lo_v[c] = min(lo_v[c], pv)
                                hi_v[c] = max(hi_v[c], pv)
            for c in range(C):
                if size[c] != size[c] and hi_u[c] >= lo_u[c]:
                    size[c] = max(hi_u[c] - lo_u[c], hi_v[c] - lo_v[c])
        for c in range(C):
            s = box_scale * size[c]
            box[n, c, 0] = u[c]
            box[n, c, 1] = v[c]
            box[n, c, 2] = s
            box[n, c, 3] = s
            ok[n, c] = z[c] > 0 and size[c] > 0 and 0 <= u[c] <= sizes[c, 0] and 0 <= v[c] <= sizes[c, 1]
    return box, ok, a_last



_WARM = False


def warm_up() -> None:
    """Compile (or load from numba's cache) every kernel with the argument types the tracker
    uses; once per process, a few milliseconds when cached."""
    global _WARM
    if _WARM:
        return
    f8, i8 = np.float64, np.int64
    box = np.array([[[10.0, 20.0, 4.0, 8.0], [11.0, 21.0, 4.0, 8.0]]] * 2)  # (2, 2, 4)
    obs = np.ones((2, 2), bool)
    cam = np.array([0, 1], i8)
    tb, tc, tl, ti, cb, r, c = iou_frame(np.zeros((5, 0)), np.zeros(0, i8), np.zeros(0, i8), np.zeros(0, i8), 0, 2,
                                         cam, box[0], 0.1)[:7]
    iou_commit(tb, tc, tl, ti, 0, 0, cam, cb, r, c)
    fill_missing(box, obs, 2)
    F = np.zeros((2, 2, 3, 3))
    D = tracklet_distances(cam, box, obs, F)
    complete_linkage(D, 0.3)
    P = np.zeros((2, 3, 4))
    u, v, _ = cluster_points(box, obs, np.array([[0, 1]], i8))
    triangulate_views(P, u, v, np.isfinite(u), 1)
    xyz = np.zeros((2, 2, 3), f8)
    outliers(xyz, obs, np.zeros(6), 0.1)
    link_distances(xyz, obs, xyz, obs, 1)
    candidate_distances(np.zeros((1, 2, 2, 3)), obs, cam, np.ones((1, 2, 2), bool))
    back, centres = np.tile(np.eye(3), (2, 1, 1)), np.zeros((2, 3))
    pp, pn = np.array([[0.0, 0.0, 1.0]]), np.array([[0.0, 0.0, 1.0]])
    X, ok = plane_candidates(box, cam, back, centres, pp, pn, 1e-3)
    Dp = candidate_distances(X[0], obs, cam, ok[0])
    best_plane_distance(Dp)
    fuse_on_planes(X, ok, Dp, np.zeros(2, i8), cam, obs, 2, np.ones(2, bool), 1, 0)
    plane_stage(box, obs, cam, back, centres, pp, pn, 1e-3, 0.5, np.zeros(0, i8), np.zeros((0, 0), bool),
                np.zeros(0, bool), 2, 1, 0)
    R3 = np.tile(np.eye(3), (2, 1, 1))
    buffered_boxes(np.zeros((2, 3)), np.ones(2), np.zeros(2), np.full((2, 2, 2), np.nan), 1.3, np.tile([0.0, 1.0, 0.0], (2, 1)),
                   0.25, False, 0.25, R3, np.ones((2, 3)), R3, np.zeros((2, 8)), np.ones((2, 2)), 0.3, 0.1, 0.9)
    _WARM = True
