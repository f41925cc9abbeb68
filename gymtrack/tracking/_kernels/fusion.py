"""Compiled kernel of ``cascade+``'s ray-plane fusion of two-view clusters (beyond the paper).

Paper: Eq. 5-7 (rays, ray-plane candidates), Eq. 8 (the candidates' mean distance) and the
weighted least squares of :mod:`gymtrack.tracking.fusion`, whose docstring derives the weights.
One call per window does every cluster, frame and point (centre, top-centre, bottom-centre):
a window hands a few clusters of 10 frames here, where numpy's per-call overhead dominated
(the vectorised version, ``tests/reference/fusion.py``, is compared with this on random input).

Per cluster (two views) and frame, for each of the three points:

1. each valid box gives a ray (Eq. 5-6, :func:`~gymtrack.geometry.primitives.ray_direction`)
   with sigma ``s = depth * sigma_px / f`` across it; the depth is first the camera's distance to
   the scene's focus, then the distance to the first solution (one refinement);
2. the two-ray point (no prior) where both rays are valid: its information ``A_t`` gives the
   plane's Mahalanobis distance squared ``(n . X_t - n . X^p)^2 / (n^T A_t^-1 n + sigma_n^2)``
   for every plane (centre point); the cluster's plane is the one with the smallest median over
   frames, and that median is returned;
3. the point fused with that plane (``plane_sigma``), also where only one ray is valid, and the
   chi-square of its residuals where both are (2 degrees of freedom: 2 x 2 across the rays + 1
   along the normal - 3 unknowns); the largest over frames and points is returned;
4. Eq. 8 on that plane: the mean distance of the two views' Eq. 7 centre candidates over the
   frames both observed (inf: none).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from ...geometry.primitives import plane_offset, ray_direction, ray_plane, solve3_sym

TINY = 1e-9  #: information of a direction no ray constrains (keeps the normal equations solvable)
OFFSETS = (0.0, -0.5, 0.5)  #: centre, top-centre, bottom-centre: v = cy + offset * h


@njit(cache=True, inline="always")
def _solve(o, d, s, ok, n0, n1, n2, c, lam):
    """The weighted least-squares point of the valid rays of one frame (``o`` (2, 3), unit
    ``d`` (2, 3), sigmas ``s`` (2,), ``ok`` (2,) bool) and the plane ``n . X = c`` with
    information ``lam`` (0: none) -> (X0, X1, X2, A00, A01, A02, A11, A12, A22)."""
    a0 = TINY + lam * n0 * n0
    a1 = lam * n0 * n1
    a2 = lam * n0 * n2
    a3 = TINY + lam * n1 * n1
    a4 = lam * n1 * n2
    a5 = TINY + lam * n2 * n2
    b0 = lam * n0 * c
    b1 = lam * n1 * c
    b2 = lam * n2 * c
    for j in range(2):
        if not ok[j]:
            continue
        w = 1.0 / (s[j] * s[j])
        dx, dy, dz = d[j, 0], d[j, 1], d[j, 2]
        q0, q1, q2, q3, q4, q5 = 1 - dx * dx, -dx * dy, -dx * dz, 1 - dy * dy, -dy * dz, 1 - dz * dz
        a0 += w * q0
        a1 += w * q1
        a2 += w * q2
        a3 += w * q3
        a4 += w * q4
        a5 += w * q5
        ox, oy, oz = o[j, 0], o[j, 1], o[j, 2]
        b0 += w * (q0 * ox + q1 * oy + q2 * oz)
        b1 += w * (q1 * ox + q3 * oy + q4 * oz)
        b2 += w * (q2 * ox + q4 * oy + q5 * oz)
    x0, x1, x2 = solve3_sym(a0, a1, a2, a3, a4, a5, b0, b1, b2)
    return x0, x1, x2, a0, a1, a2, a3, a4, a5


@njit(cache=True, inline="always")
def _refined(o, d, sp, z0, ok, n0, n1, n2, c, lam, s):
    """:func:`_solve` with ``s = z0 * sp``, then once more with the depths of that solution
    (the sigmas used are left in ``s``)."""
    for j in range(2):
        s[j] = z0[j] * sp[j]
    x0, x1, x2, a0, a1, a2, a3, a4, a5 = _solve(o, d, s, ok, n0, n1, n2, c, lam)
    for j in range(2):
        if ok[j]:
            s[j] = math.sqrt((x0 - o[j, 0]) ** 2 + (x1 - o[j, 1]) ** 2 + (x2 - o[j, 2]) ** 2) * sp[j]
    return _solve(o, d, s, ok, n0, n1, n2, c, lam)


@njit(cache=True, inline="always")
def _chi2(x0, x1, x2, o, d, s, ok, n0, n1, n2, c, lam):
    """The weighted squared residuals of X: across each valid ray, along the plane's normal."""
    out = lam * (n0 * x0 + n1 * x1 + n2 * x2 - c) ** 2
    for j in range(2):
        if ok[j]:
            r0, r1, r2 = x0 - o[j, 0], x1 - o[j, 1], x2 - o[j, 2]
            t = r0 * d[j, 0] + r1 * d[j, 1] + r2 * d[j, 2]
            r0, r1, r2 = r0 - t * d[j, 0], r1 - t * d[j, 1], r2 - t * d[j, 2]
            out += (r0 * r0 + r1 * r1 + r2 * r2) / (s[j] * s[j])
    return out


@njit(cache=True, error_model="numpy")
def fuse_pairs(box, observed, cams, centres, back, focal, depth0, pixel_sigma, box_sigma, normal, point,
               plane_sigma, min_cos):
    """Every two-view cluster of a window (see the module docstring).

    box: (m, 2, W, 4) undistorted centre-form boxes of the two views (NaN: none); observed:
    (m, 2, W) bool; cams: (m, 2) int64; centres (C, 3), back (C, 3, 3) (``RigArrays``); focal,
    depth0: (C,); normal, point: (P, 3) planes (P >= 1). Returns ``X`` (m, 3, W, 3) the fused
    centre / top / bottom (NaN where no ray), ``plane`` (m,) int64, ``m2`` (m,) the median
    Mahalanobis distance squared of that plane (inf: no frame with two rays), ``chi2`` (m,)
    the largest chi-square over frames with two rays, ``eq8`` (m,) metres (inf: no shared frame).
    """
    m, _, W, _ = box.shape
    P = len(normal)
    lam = 1.0 / plane_sigma ** 2
    X = np.full((m, 3, W, 3), np.nan)
    plane = np.zeros(m, np.int64)
    m2 = np.full(m, np.inf)
    chi2 = np.zeros(m)
    eq8 = np.full(m, np.inf)
    o = np.empty((2, 3))
    d = np.empty((2, 3))
    sp = np.empty(2)
    s = np.empty(2)
    z0 = np.empty(2)
    ok = np.empty(2, np.bool_)
    maha = np.empty((P, W))
    for k in range(m):
        for j in range(2):
            c = cams[k, j]
            z0[j] = depth0[c]
            for i in range(3):
                o[j, i] = centres[c, i]
        # pass 1: the two-ray centres and the planes' Mahalanobis distances
        nb = 0
        for w in range(W):
            both = _rays(box, cams, back, focal, pixel_sigma, box_sigma, k, w, 0, d, sp, ok)
            if not both:
                continue
            x0, x1, x2, a0, a1, a2, a3, a4, a5 = _refined(o, d, sp, z0, ok, 0.0, 0.0, 1.0, 0.0, 0.0, s)
            for p in range(P):
                n0, n1, n2 = normal[p, 0], normal[p, 1], normal[p, 2]
                y0, y1, y2 = solve3_sym(a0, a1, a2, a3, a4, a5, n0, n1, n2)  # A_t^-1 n
                r = n0 * (x0 - point[p, 0]) + n1 * (x1 - point[p, 1]) + n2 * (x2 - point[p, 2])
                maha[p, nb] = r * r / (n0 * y0 + n1 * y1 + n2 * y2 + plane_sigma ** 2)
            nb += 1
        if nb:
            for p in range(P):
                med = np.median(maha[p, :nb])
                if med < m2[k]:
                    m2[k] = med
                    plane[k] = p
        pl = plane[k]
        n0, n1, n2 = normal[pl, 0], normal[pl, 1], normal[pl, 2]
        cpl = n0 * point[pl, 0] + n1 * point[pl, 1] + n2 * point[pl, 2]
        # pass 2: the points fused with that plane, their chi-square; Eq. 8 of the centres
        e_sum, e_n = 0.0, 0
        for w in range(W):
            for q in range(3):
                both = _rays(box, cams, back, focal, pixel_sigma, box_sigma, k, w, q, d, sp, ok)
                if not (ok[0] or ok[1]):
                    continue
                x0, x1, x2, _, _, _, _, _, _ = _refined(o, d, sp, z0, ok, n0, n1, n2, cpl, lam, s)
                X[k, q, w, 0], X[k, q, w, 1], X[k, q, w, 2] = x0, x1, x2
                if both:
                    chi2[k] = max(chi2[k], _chi2(x0, x1, x2, o, d, s, ok, n0, n1, n2, cpl, lam))
                if q == 0 and both and observed[k, 0, w] and observed[k, 1, w]:
                    st0, c00, c01, c02 = ray_plane(o[0, 0], o[0, 1], o[0, 2], d[0, 0], d[0, 1], d[0, 2], 1.0,
                                                   plane_offset(point[pl, 0], point[pl, 1], point[pl, 2], n0, n1, n2,
                                                                o[0, 0], o[0, 1], o[0, 2]), n0, n1, n2, min_cos)
                    st1, c10, c11, c12 = ray_plane(o[1, 0], o[1, 1], o[1, 2], d[1, 0], d[1, 1], d[1, 2], 1.0,
                                                   plane_offset(point[pl, 0], point[pl, 1], point[pl, 2], n0, n1, n2,
                                                                o[1, 0], o[1, 1], o[1, 2]), n0, n1, n2, min_cos)
                    if st0 == 0 and st1 == 0:
                        e_sum += math.sqrt((c00 - c10) ** 2 + (c01 - c11) ** 2 + (c02 - c12) ** 2)
                        e_n += 1
        if e_n:
            eq8[k] = e_sum / e_n
    return X, plane, m2, chi2, eq8


@njit(cache=True, inline="always")
def _rays(box, cams, back, focal, pixel_sigma, box_sigma, k, w, q, d, sp, ok):
    """The unit rays of point ``q`` of cluster k at frame w into ``d`` (2, 3), their pixel sigma
    over the focal length into ``sp``, validity into ``ok``; returns whether both are valid."""
    off = 0.0 if q == 0 else (-0.5 if q == 1 else 0.5)
    for j in range(2):
        bx, by, bw, bh = box[k, j, w, 0], box[k, j, w, 1], box[k, j, w, 2], box[k, j, w, 3]
        ok[j] = math.isfinite(bx) and math.isfinite(by) and math.isfinite(bw) and math.isfinite(bh)
        if not ok[j]:
            continue
        c = cams[k, j]
        d0, d1, d2 = ray_direction(back, c, bx, by + off * bh)
        ln = math.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
        d[j, 0], d[j, 1], d[j, 2] = d0 / ln, d1 / ln, d2 / ln
        sp[j] = math.hypot(pixel_sigma, box_sigma * bh) / focal[c]
    return ok[0] and ok[1]


def warm_up() -> None:
    """Compile (or load) the kernel on the sample person's two views."""
    from ...geometry.arrays import PlaneArrays
    from .sample import sample

    s = sample()
    a = s.rig.arrays
    pl = PlaneArrays.from_planes(s.planes)
    box = np.ascontiguousarray(s.box[None, :2], dtype=np.float64)
    fuse_pairs(box, np.ascontiguousarray(s.observed[None, :2]), np.array([[0, 1]], np.int64), a.centres, a.back,
               np.ascontiguousarray((a.K[:, 0, 0] + a.K[:, 1, 1]) / 2), np.ones(len(a.K)), 2.0, 0.03,
               pl.normal, pl.point, 0.1, 1e-3)
