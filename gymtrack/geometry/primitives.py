"""Compiled (numba) scalar primitives of the camera geometry: each equation written once.

Paper: Eq. 1 (:func:`scaled_centre`, :func:`epipolar_line`, :func:`line_distance`), Eq. 3
(:func:`solve3_sym`, :func:`triangulate_points`), Eq. 5-7 (:func:`ray_direction`,
:func:`plane_offset`, :func:`ray_plane`) and the pinhole projection with OpenCV's distortion
of Section III-B / Eq. 14 (:func:`project_point`).

Plain scalar functions (``inline="always"``): the tracker's kernels call them inside their
loops, and the public API of :mod:`gymtrack.geometry` runs the same code through the small
loops at the end of this module (:func:`.plane.intersect_rays_plane` for Eq. 7,
:func:`.epipolar.epipolar_distance` for Eq. 1) and :func:`.triangulation.triangulate` (Eq. 3,
:func:`triangulate_points`). Not :meth:`.camera.Camera.project`, which the simulator uses (``r2 ** 3`` rounds
differently from numpy's ``pow``). Cameras are indexed in the stacked
arrays of :class:`~.arrays.RigArrays` (``R[c]``...), so a kernel never slices per call.
"""

from __future__ import annotations

import numpy as np
from numba import njit

_NAN = np.nan

#: :class:`~.plane.RayPlaneStatus` codes returned by :func:`ray_plane`
RAY_OK, RAY_PARALLEL, RAY_BEHIND = 0, 1, 2


@njit(cache=True, inline="always")
def solve3_sym(s0, s1, s2, s3, s4, s5, b0, b1, b2):
    """Adjugate solve of the symmetric system ``[[s0 s1 s2] [s1 s3 s4] [s2 s4 s5]] x = b``
    -> (x0, x1, x2); NaN when singular (the DLT and Gauss-Newton normal equations of Eq. 3)."""
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


@njit(cache=True, inline="always")
def project_point(R, t, K, dist, c, X0, X1, X2):
    """World point ``(X0, X1, X2)`` into camera ``c`` of stacked R (C,3,3), t (C,3), K (C,3,3),
    dist (C,8): (u, v, depth), raw pixels with OpenCV's 8-coefficient distortion; u, v NaN on
    or behind the camera plane (the model of :meth:`.camera.Camera.project`)."""
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


@njit(cache=True, inline="always")
def scaled_centre(x, y, w, h):
    """Eq. 1's normalisation: the homogeneous box centre divided by the box scale ``|w + h|``,
    so that a point-line distance of it is already the normalised term of Eq. 1."""
    s = abs(w + h)
    return x / s, y / s, 1.0 / s


@njit(cache=True, inline="always")
def epipolar_line(F, i, j, x0, x1, x2):
    """The epipolar line ``F[i, j] x`` in view j of the homogeneous point x of view i, scaled
    to a unit normal (a zero normal is left unscaled). F: (C, C, 3, 3)."""
    l0 = F[i, j, 0, 0] * x0 + F[i, j, 0, 1] * x1 + F[i, j, 0, 2] * x2
    l1 = F[i, j, 1, 0] * x0 + F[i, j, 1, 1] * x1 + F[i, j, 1, 2] * x2
    l2 = F[i, j, 2, 0] * x0 + F[i, j, 2, 1] * x1 + F[i, j, 2, 2] * x2
    norm = np.sqrt(l0 * l0 + l1 * l1)
    if norm == 0:
        norm = 1.0
    return l0 / norm, l1 / norm, l2 / norm


@njit(cache=True, inline="always")
def line_distance(x0, x1, x2, l0, l1, l2):
    """Distance of the homogeneous point x from the unit-normal line l (``|x . l|``)."""
    return abs(x0 * l0 + x1 * l1 + x2 * l2)


@njit(cache=True, inline="always")
def ray_direction(back, c, u, v):
    """Eq. 6: the world direction ``R^T K^-1 [u, v, 1]`` of undistorted pixel (u, v) of camera c
    (back: (C, 3, 3) ``R^T K^-1``); not unit length."""
    d0 = back[c, 0, 0] * u + back[c, 0, 1] * v + back[c, 0, 2]
    d1 = back[c, 1, 0] * u + back[c, 1, 1] * v + back[c, 1, 2]
    d2 = back[c, 2, 0] * u + back[c, 2, 1] * v + back[c, 2, 2]
    return d0, d1, d2


@njit(cache=True, inline="always")
def plane_offset(p0, p1, p2, n0, n1, n2, o0, o1, o2):
    """``n . (X^p - X^o)``, the numerator of Eq. 7 (one per ray origin and plane)."""
    return (p0 - o0) * n0 + (p1 - o1) * n1 + (p2 - o2) * n2


@njit(cache=True, inline="always")
def ray_plane(o0, o1, o2, d0, d1, d2, dlen, num, n0, n1, n2, min_cos):
    """Eq. 7: the ray ``X^o + lambda d`` (``dlen = |d|``) meets the plane of unit normal n with
    numerator ``num`` (:func:`plane_offset`) -> (status, X0, X1, X2), NaN unless RAY_OK.
    Parallel: ``|cos| < min_cos`` (also zero / NaN directions); behind: ``lambda <= 0``."""
    dn = d0 * n0 + d1 * n1 + d2 * n2
    # written negated so that zero-length and NaN directions count as parallel
    if not (abs(dn) >= min_cos * dlen) or not (dlen > 0):
        return RAY_PARALLEL, _NAN, _NAN, _NAN
    lam = num / dn
    if not lam > 0:  # the plane is behind the camera
        return RAY_BEHIND, _NAN, _NAN, _NAN
    return RAY_OK, o0 + lam * d0, o1 + lam * d1, o2 + lam * d2


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
def triangulate_points(P, u, v, mask, iterations):
    """Eq. 3, one point at a time: DLT with normalised rows, then ``iterations`` damped
    Gauss-Newton steps on the reprojection error.

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
        X0, X1, X2 = solve3_sym(a00, a01, a02, a11, a12, a22, -b0, -b1, -b2)
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
            s0, s1, s2 = solve3_sym(j00 + damp, j01, j02, j11 + damp, j12, j22 + damp, -g0, -g1, -g2)
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


# ----------------------------------------------------------------------------- loops of the public API
@njit(cache=True)
def rays_plane(o, d, point, normal, min_cos):
    """Eq. 7 for N rays (:func:`.plane.intersect_rays_plane`): origins o (N, 3), directions
    d (N, 3), the plane's point and unit normal (3,) -> X (N, 3) (NaN unless hit), status (N,) int8."""
    N = o.shape[0]
    X = np.empty((N, 3))
    status = np.empty(N, np.int8)
    for i in range(N):
        d0, d1, d2 = d[i, 0], d[i, 1], d[i, 2]
        num = plane_offset(point[0], point[1], point[2], normal[0], normal[1], normal[2], o[i, 0], o[i, 1], o[i, 2])
        status[i], X[i, 0], X[i, 1], X[i, 2] = ray_plane(o[i, 0], o[i, 1], o[i, 2], d0, d1, d2,
                                                         np.sqrt(d0 * d0 + d1 * d1 + d2 * d2), num, normal[0],
                                                         normal[1], normal[2], min_cos)
    return X, status


@njit(cache=True, error_model="numpy")
def box_distances(box_i, box_j, F, Ft):
    """Eq. 1 for N pairs of boxes (:func:`.epipolar.epipolar_distance`): box_i, box_j (N, 4)
    centre-form, F (N, 1, 3, 3) mapping view i to view j and Ft (N, 1, 3, 3) its transposes
    -> (N,); NaN where an epipolar line is undefined (zero F, or a point on the epipole)."""
    N = box_i.shape[0]
    out = np.empty(N)
    for n in range(N):
        xi0, xi1, xi2 = scaled_centre(box_i[n, 0], box_i[n, 1], box_i[n, 2], box_i[n, 3])
        xj0, xj1, xj2 = scaled_centre(box_j[n, 0], box_j[n, 1], box_j[n, 2], box_j[n, 3])
        a0, a1, a2 = epipolar_line(F, n, 0, xi0, xi1, xi2)  # of x_i, in view j
        b0, b1, b2 = epipolar_line(Ft, n, 0, xj0, xj1, xj2)  # of x_j, in view i
        if (a0 == 0 and a1 == 0) or (b0 == 0 and b1 == 0):
            out[n] = _NAN
        else:
            out[n] = line_distance(xi0, xi1, xi2, b0, b1, b2) + line_distance(xj0, xj1, xj2, a0, a1, a2)
    return out


def warm_up() -> None:
    """Compile (or load from numba's cache) the loops of the public API (the tracker's kernels
    compile the scalar primitives with themselves)."""
    box = np.array([[960.0, 540.0, 60.0, 150.0]])
    F = np.array([[[[0.0, -1e-6, 1e-3], [1e-6, 0.0, -2e-3], [-1e-3, 2e-3, 1.0]]]])
    box_distances(box, box, F, np.ascontiguousarray(np.swapaxes(F, -1, -2)))
    rays_plane(np.zeros((1, 3)), np.ones((1, 3)), np.ones(3), np.array([1.0, 0.0, 0.0]), 1e-3)
