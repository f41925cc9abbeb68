"""Batched, confidence-weighted triangulation of keypoints: the linear algebra of the lifting.

Paper: Section III-B, Eq. 3 (``X = argmin_X sum_c || x_c - pi(P_c, X) ||^2``), here with a
weight per view and point (a pose model's confidence over its pixel noise). The plain,
unweighted Eq. 3 is :func:`gymtrack.geometry.triangulation.triangulate_views`; this module adds
the weights the robust lifting needs, and the ray geometry of the plane anchoring.

Layout: batch-last ("views-major") like :mod:`gymtrack.geometry.triangulation`: pixels ``u, v``
and weights ``w`` are (C, N) -- one row per view, one column per point (frames x joints
flattened) -- and points are (3, N). Per-view constants then broadcast along long rows, where
numpy is fastest; every 3x3 system is solved in closed form (Cramer), NaN where singular.
"""

from __future__ import annotations

import numpy as np


def solve3(M: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Solve N 3x3 systems batch-last: M (3, 3, N), b (3, N) -> x (3, N); NaN where singular."""
    a0, a1, a2 = M[:, 0], M[:, 1], M[:, 2]  # columns, (3, N) each
    c12 = np.cross(a1, a2, axis=0)
    det = np.sum(a0 * c12, axis=0)
    scale = np.sqrt(np.sum(a0 * a0, axis=0) * np.sum(a1 * a1, axis=0) * np.sum(a2 * a2, axis=0))
    ok = np.abs(det) > 1e-13 * scale
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = np.where(ok, 1.0 / np.where(ok, det, 1.0), np.nan)
        x = np.stack([
            np.sum(b * c12, axis=0),
            np.sum(a0 * np.cross(b, a2, axis=0), axis=0),
            np.sum(a0 * np.cross(a1, b, axis=0), axis=0),
        ])
    return x * inv


def to_views(P: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(C, 3, N) camera-frame homogeneous pixels ``P_c [X, 1]`` for P (C, 3, 4), X (3, N)."""
    C = P.shape[0]
    # einsum: several times faster than a BLAS product of these thin shapes
    return (np.einsum("ik,kn->in", P[:, :, :3].reshape(3 * C, 3), X) + P[:, :, 3].reshape(3 * C, 1)).reshape(C, 3, -1)


def project(P: np.ndarray, X: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Pixels (u, v), each (C, N), of points X (3, N) in undistorted views P (C, 3, 4); NaN behind."""
    Xc = to_views(P, X)
    with np.errstate(divide="ignore", invalid="ignore"):
        z = np.where(Xc[:, 2] > 1e-9, Xc[:, 2], np.nan)
        return Xc[:, 0] / z, Xc[:, 1] / z


def residuals(P: np.ndarray, X: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(C, N) reprojection distance in pixels of X (3, N) to the pixels u, v (C, N)."""
    pu, pv = project(P, X)
    return np.hypot(pu - u, pv - v)


def weighted_dlt(P: np.ndarray, u: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Linear (DLT) estimate with a weight per view and point.

    P (C, 3, 4); u, v, w (C, N), ``w = 0`` where a view does not count (its pixels may be NaN).
    Each constraint row ``u P3 - P1``, ``v P3 - P2`` is normalised to unit length (Hartley &
    Zisserman 12.2), scaled by ``w`` and the inhomogeneous point solved in least squares.
    Returns X (3, N); NaN where fewer than two views carry weight.
    """
    u = np.where(w > 0, u, 0.0)
    v = np.where(w > 0, v, 0.0)
    P3 = P[:, 2][:, :, None]  # (C, 4, 1)
    rows = []
    for t, k in ((u, 0), (v, 1)):
        r = t[:, None, :] * P3 - P[:, k][:, :, None]  # (C, 4, N)
        norm = np.sqrt(np.sum(r * r, axis=1))
        rows.append(r * (w / np.where(norm > 0, norm, 1.0))[:, None, :])
    A = np.concatenate(rows, axis=0)  # (2C, 4, N)
    M = np.einsum("kin,kjn->ijn", A[:, :3], A)  # (3, 4, N): the normal matrix's first 3 rows
    X = solve3(M[:, :3], -M[:, 3])
    X[:, np.sum(w > 0, axis=0) < 2] = np.nan
    return X


def gauss_newton(P: np.ndarray, X: np.ndarray, u: np.ndarray, v: np.ndarray, w: np.ndarray,
                 iterations: int = 2) -> np.ndarray:
    """Refine X (3, N) on the weighted reprojection error ``sum_c w^2 |pi(P_c, X) - (u, v)|^2``.

    A step is kept only where it lowers the cost (no damping needed for a few steps from the
    DLT). P (C, 3, 4); u, v, w (C, N). Returns the refined X (3, N).
    """
    if iterations <= 0 or X.shape[1] == 0:
        return X
    W = np.where(w > 0, w * w, 0.0)
    u = np.where(W > 0, u, 0.0)
    v = np.where(W > 0, v, 0.0)
    A = P[:, :, :3]  # (C, 3, 3): rows A0, A1, A2 of each view

    def cost(Xq):
        Xc = to_views(P, Xq)
        z = np.where(W > 0, Xc[:, 2], 1.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            pu, pv = Xc[:, 0] / z, Xc[:, 1] / z
        ru, rv = pu - u, pv - v
        return pu, pv, z, ru, rv, np.sum(W * (ru * ru + rv * rv), axis=0)

    pu, pv, z, ru, rv, old = cost(X)
    for it in range(iterations):
        Ju = (A[:, 0][:, :, None] - pu[:, None] * A[:, 2][:, :, None]) / z[:, None]  # (C, 3, N)
        Jv = (A[:, 1][:, :, None] - pv[:, None] * A[:, 2][:, :, None]) / z[:, None]
        WJu, WJv = Ju * W[:, None], Jv * W[:, None]
        JtJ = np.einsum("cin,cjn->ijn", WJu, Ju) + np.einsum("cin,cjn->ijn", WJv, Jv)
        Jtr = np.sum(WJu * ru[:, None] + WJv * rv[:, None], axis=0)
        step = solve3(JtJ, -Jtr)
        cand = X + np.where(np.isfinite(step), step, 0.0)
        state = cost(cand)
        better = np.isfinite(state[-1]) & (state[-1] <= old)
        X = np.where(better, cand, X)
        if it + 1 < iterations:
            pu, pv, z, ru, rv, old = (np.where(better, s, o) for s, o in zip(state, (pu, pv, z, ru, rv, old)))
    return X


def rays(K: np.ndarray, R: np.ndarray, u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """World unit ray directions (C, 3, N) through undistorted pixels u, v (C, N) (paper Eq. 6).

    K, R: (C, 3, 3) intrinsics and world-to-camera rotations.
    """
    y = (v - K[:, 1, 2][:, None]) / K[:, 1, 1][:, None]
    x = (u - K[:, 0, 2][:, None] - K[:, 0, 1][:, None] * y) / K[:, 0, 0][:, None]
    d = np.einsum("cji,cjn->cin", R, np.stack([x, y, np.ones_like(x)], axis=1))  # R^T [x, y, 1]
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def fuse_rays_plane(origins: np.ndarray, d: np.ndarray, w: np.ndarray, point: np.ndarray,
                    normal: np.ndarray, sigma_plane: float | np.ndarray) -> np.ndarray:
    """Information-form fusion of lines of sight with a plane prior.

    Each view's ray (origin ``o_c`` (C, 3), unit direction ``d`` (C, 3, N)) says the point lies on
    it with lateral standard deviation ``1 / sqrt(w)`` metres (w (C, N), 0 = not seen): information
    ``w (I - d d^T)``. The plane through ``point`` (3, N) with unit ``normal`` (3,) adds
    ``n n^T / sigma_plane^2`` along its normal only (sigma_plane: a scalar or (N,) per point). The fused point solves
    ``(sum Lambda) X = sum Lambda X_0``. One view: exactly the ray-plane intersection (Eq. 7);
    two near-opposite views: their depth along the baseline comes from the plane, the rest
    from the rays. Returns X (3, N), NaN where singular (a lone ray parallel to the plane).
    """
    dd = np.einsum("cin,cjn->ijcn", d, d)  # (3, 3, C, N)
    info_c = (np.eye(3)[:, :, None, None] - dd) * w[None, None]  # (3, 3, C, N)
    L = info_c.sum(axis=2)
    eta = np.einsum("ijcn,cj->in", info_c, origins)
    nn = np.outer(normal, normal)[:, :, None] / np.broadcast_to(np.asarray(sigma_plane, np.float64), L.shape[2:])**2
    L = L + nn
    eta = eta + np.einsum("ijn,jn->in", nn, point)
    return solve3(L, eta)
