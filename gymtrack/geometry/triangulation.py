"""Triangulation of points seen in N >= 2 views, paper Eq. 3.

Paper: Section III-B, Eq. 3: ``X = argmin_X sum_c || x_c - pi(P_c, X) ||^2``. Solved as in
Hartley & Zisserman (Sec. 12.2 and 12.5): a linear DLT estimate (the stacked constraints, each
row normalised, solved in least squares for the inhomogeneous point), then a few Gauss-Newton
(Levenberg-Marquardt damped) steps on the reprojection error. Everything is batched over
points: no Python loop per point.

Speed (the tracker triangulates every cluster and frame of a window in one call): the DLT's
normal matrices are built for all points with one matrix product against a per-view table,
and every 3x3 system is solved in closed form (adjugate) with elementwise numpy, rather than
a batched SVD / LAPACK call per point, which costs microseconds per point. The work is done
views-major (:func:`triangulate_views`: one row per view and coordinate, one column per point):
per-view constants then broadcast along long rows, where numpy is several times faster than on
(N, V, 2) arrays whose inner loops are only V x 2 long.

Inputs are pixels of the undistorted images (undistort raw pixels first with
:meth:`Camera.undistort`, or call :func:`triangulate_rig`). Fewer than two views gives NaN,
never a made-up number.
"""

from __future__ import annotations

import numpy as np

from .camera import Rig


# cofactors of a symmetric 3x3 matrix stored as its 6 distinct entries
# s = [a00, a01, a02, a11, a12, a22]: c[k] = s[I1] s[I2] - s[I3] s[I4], c = [c00, c01, c02, c11, c12, c22]
_I1 = np.array([3, 2, 1, 0, 1, 0])
_I2 = np.array([5, 4, 4, 5, 2, 3])
_I3 = np.array([4, 1, 2, 2, 0, 1])
_I4 = np.array([4, 5, 3, 2, 4, 1])
_SYM = np.array([0, 1, 2, 1, 3, 4, 2, 4, 5])  # row-major 3x3 from the 6 distinct entries


def _solve3_sym(s: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Closed-form (adjugate) solve of n symmetric 3x3 systems, views-major: s (6, n) the
    distinct entries ``a00, a01, a02, a11, a12, a22`` (contiguous rows), b (3, n).
    Returns x (3, n); NaN columns where the matrix is singular.

    The normal matrices of the DLT and of Gauss-Newton are symmetric: 6 cofactors instead of 9,
    the same numbers as the general adjugate (products commute exactly)."""
    c = s[_I1] * s[_I2] - s[_I3] * s[_I4]  # (6, n)
    det = s[0] * c[0] + s[1] * c[1] + s[2] * c[2]
    with np.errstate(divide="ignore", invalid="ignore"):
        return (c[_SYM].reshape(3, 3, -1) * b[None]).sum(axis=1) / np.where(det != 0, det, np.nan)


_TABLES: dict[bytes, tuple] = {}


def _tables(P: np.ndarray) -> tuple:
    """Per-view constant tables of the DLT and Gauss-Newton normal equations, cached per ``P``.

    DLT: a normalised row ``r = t P3 - Pk`` (``k`` = 1, 2 for the pixel's u, v) gives
    ``r r^T = t^2 P3P3^T - t (P3Pk^T + PkP3^T) + PkPk^T`` and ``|r|^2 = t^2 |P3|^2 - 2 t P3.Pk
    + |Pk|^2``: the 4x4 normal matrices are a table times per-point coefficients.

    Gauss-Newton: with ``A0, A1, A2`` the rows of ``P_v[:, :3]``, pixel ``(px, py)``,
    ``iz = w / depth`` and residual ``(rx, ry)``, the Jacobian rows are ``iz (A0 - px A2)`` and
    ``iz (A1 - py A2)``, so per view
    ``J^T J = iz^2 [A0A0' + A1A1' - px (A0A2' + A2A0') - py (A1A2' + A2A1') + (px^2 + py^2) A2A2']``
    and ``J^T r = iz [rx A0 + ry A1 - (px rx + py ry) A2]``.

    All views-major (one column per coefficient row of :func:`triangulate_views`), symmetric
    matrices as their 6 distinct entries ``00, 01, 02, 11, 12, 22``. Returns
    (dlt (9, 6V): the 3x3 part of the normal matrix and its right-hand side (the 4th column),
    norms (3, V, 2, 1): |P3|^2, P3.Pk, |Pk|^2, jj (6, 4V), jr (3, 3V),
    ``P[:, :, :3]`` as (3V, 3) rows, ``P[:, :, 3]`` as a (3V, 1) column).
    """
    key = P.tobytes()
    hit = _TABLES.get(key)
    if hit is not None:
        return hit
    V = P.shape[0]
    o = lambda x, y: x[..., :, None] * y[..., None, :]  # noqa: E731  outer products, batched
    P3 = P[:, 2]
    Pk = P[:, :2]  # (V, 2, 4)
    dlt = np.stack([o(P3, P3)[:, None].repeat(2, axis=1), -(o(P3[:, None], Pk) + o(Pk, P3[:, None])), o(Pk, Pk)], axis=2)
    norms = np.stack([np.repeat(np.sum(P3 * P3, axis=1)[:, None], 2, axis=1), np.einsum("vi,vki->vk", P3, Pk),
                      np.sum(Pk * Pk, axis=2)])
    A = P[:, :, :3]
    A0, A1, A2 = A[:, 0], A[:, 1], A[:, 2]
    jj = np.stack([o(A0, A0) + o(A1, A1), -(o(A0, A2) + o(A2, A0)), -(o(A1, A2) + o(A2, A1)), o(A2, A2)], axis=1)
    jr = np.stack([A0, A1, -A2], axis=1)
    rows = np.ascontiguousarray
    out = (rows(dlt.reshape(6 * V, 16)[:, [0, 1, 2, 5, 6, 10, 3, 7, 11]].T), norms[..., None],
           rows(jj.reshape(4 * V, 9)[:, [0, 1, 2, 4, 5, 8]].T), rows(jr.reshape(3 * V, 3).T),
           rows(A.reshape(3 * V, 3)), P[:, :, 3].reshape(3 * V, 1).copy())
    if len(_TABLES) > 32:
        _TABLES.clear()
    _TABLES[key] = out
    return out


def _dlt(P: np.ndarray, u: np.ndarray, v: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Batched linear estimate, views-major: P (V,3,4), pixels u, v (V, N), w (V, N) 0/1 weights
    -> X (3, N).

    Rows ``u*P3 - P1`` and ``v*P3 - P2`` (each normalised, zero for missing views) in least
    squares with ``X_h = [X, 1]`` (see :func:`_tables`).
    """
    table, (n33, n3k, nkk) = _tables(P)[:2]
    V, N = u.shape
    t = np.stack([u, v], axis=1)  # (V, 2, N)
    norm2 = t * t * n33 - 2 * t * n3k + nkk
    s = w[:, None] / np.where(norm2 > 0, norm2, 1.0)
    st = s * t
    coef = np.stack([st * t, st, s], axis=2).reshape(6 * V, N)  # table order
    M = table @ coef  # (9, N): the normal matrix's 3x3 part (6 distinct entries), its right-hand side
    return _solve3_sym(M[:6], -M[6:])


def reprojection_residuals(P: np.ndarray, uv: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(N, V, 2) reprojection residuals ``pi(P_v, X_n) - uv_nv`` for P (V,3,4), uv (N,V,2), X (N,3)."""
    Xc = _to_views(P, X)
    return Xc[..., :2] / Xc[..., 2:3] - uv


def _to_views(P: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(N, V, 3) ``P_v [X_n, 1]`` for P (V,3,4), X (N,3): one matrix product."""
    V = P.shape[0]
    return (X @ P[:, :, :3].reshape(V * 3, 3).T + P[:, :, 3].reshape(-1)).reshape(len(X), V, 3)


def triangulate(
    P: np.ndarray,
    uv: np.ndarray,
    mask: np.ndarray | None = None,
    iterations: int = 5,
) -> tuple[np.ndarray, np.ndarray]:
    """Triangulate N points from V views (paper Eq. 3).

    Parameters
    ----------
    P: (V, 3, 4) projection matrices ``K [R | t]``.
    uv: (N, V, 2) pixels (undistorted); entries of masked-out views are ignored (may be NaN).
    mask: (N, V) bool, which views observe each point; default: every finite entry.
    iterations: Gauss-Newton refinement steps after the DLT (0 = DLT only).

    Returns
    -------
    X: (N, 3) world points; NaN where fewer than 2 views observe the point.
    error: (N,) RMS reprojection error in pixels over the observing views; NaN likewise.
    """
    P = np.asarray(P, dtype=np.float64)
    uv = np.asarray(uv, dtype=np.float64)
    N, V = uv.shape[:2]
    if P.shape != (V, 3, 4):
        raise ValueError(f"P must be ({V}, 3, 4) to match uv {uv.shape}, got {P.shape}")
    t = uv.transpose(2, 1, 0)  # (2, V, N)
    X, err = triangulate_views(P, t[0], t[1], None if mask is None else np.asarray(mask, dtype=bool).T, iterations)
    return X.T, err


def triangulate_views(
    P: np.ndarray,
    u: np.ndarray,
    v: np.ndarray,
    mask: np.ndarray | None = None,
    iterations: int = 5,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`triangulate` views-major: P (V, 3, 4); pixels u, v (V, N) (undistorted; NaN or
    masked = not seen); mask (V, N) bool or None (every finite pixel).

    Returns X (3, N) (NaN with fewer than 2 views) and the RMS reprojection error (N,).
    """
    P = np.asarray(P, dtype=np.float64)
    u = np.asarray(u, dtype=np.float64)
    v = np.asarray(v, dtype=np.float64)
    V, N = u.shape
    finite = np.isfinite(u) & np.isfinite(v)
    mask = finite if mask is None else (mask & finite)
    w = mask.astype(np.float64)
    nv = w.sum(axis=0)
    ok = nv >= 2
    X = np.full((3, N), np.nan)
    err = np.full(N, np.nan)
    if not ok.any():
        return X, err
    if not ok.all():  # (rare) points with fewer than 2 views are left out of the work
        u, v, mask, w, nv = u[:, ok], v[:, ok], mask[:, ok], w[:, ok], nv[ok]
    u, v = np.where(mask, u, 0.0), np.where(mask, v, 0.0)
    n = u.shape[1]
    Xk = _dlt(P, u, v, w)
    # J^T J and J^T r as products of per-point coefficients with per-view tables (see _tables)
    tab_jj, tab_jr, A_rows, a_col = _tables(P)[2:]

    def cost(Xq):
        Xc = (A_rows @ Xq + a_col).reshape(V, 3, n)  # P_v [X, 1]
        z = np.where(mask, Xc[:, 2], 1.0)  # missing views: any finite value, weight 0
        with np.errstate(divide="ignore", invalid="ignore"):
            px, py, iz = Xc[:, 0] / z, Xc[:, 1] / z, w / z
        rx, ry = (px - u) * w, (py - v) * w
        return (px, py, iz, rx, ry), np.sum(rx * rx + ry * ry, axis=0)

    state, old = cost(Xk)
    lam = np.full(n, 1e-3)
    for it in range(iterations):
        px, py, iz, rx, ry = state
        iz2 = iz * iz
        JtJ = tab_jj @ np.stack([iz2, iz2 * px, iz2 * py, iz2 * (px * px + py * py)], axis=1).reshape(4 * V, n)
        Jtr = tab_jr @ np.stack([iz * rx, iz * ry, iz * (px * rx + py * ry)], axis=1).reshape(3 * V, n)
        JtJ[[0, 3, 5]] += lam * (JtJ[0] + JtJ[3] + JtJ[5]) / 3  # LM damping of the diagonal
        step = _solve3_sym(JtJ, -Jtr)
        cand = Xk + np.where(np.isfinite(step), step, 0.0)
        state_c, new = cost(cand)
        better = np.isfinite(new) & (new <= old)
        Xk = np.where(better, cand, Xk)
        old = np.where(better, new, old)
        if it + 1 < iterations:  # the next step needs the accepted residuals and damping
            state = tuple(np.where(better, c, s) for c, s in zip(state_c, state))
            lam = np.where(better, lam * 0.3, lam * 10.0)
    if ok.all():
        X, err = Xk, np.sqrt(old / nv)
    else:
        X[:, ok] = Xk
        err[ok] = np.sqrt(old / nv)
    return X, err


def triangulate_rig(
    rig: Rig,
    uv: np.ndarray,
    mask: np.ndarray | None = None,
    undistort: bool = True,
    iterations: int = 5,
) -> tuple[np.ndarray, np.ndarray]:
    """:func:`triangulate` for raw-image pixels of a rig.

    uv: (N, C, 2) raw pixels, one column per camera of ``rig``; mask: (N, C) bool.
    Returns X (N, 3) and the RMS reprojection error (N,) in undistorted pixels.
    """
    uv = np.asarray(uv, dtype=np.float64)
    if undistort:
        uv = np.stack([cam.undistort(uv[:, c]) for c, cam in enumerate(rig)], axis=1)
    return triangulate(rig.projections, uv, mask, iterations)
