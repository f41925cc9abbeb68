"""Triangulation of points seen in N >= 2 views, paper Eq. 3.

Paper: Section III-B, Eq. 3: ``X = argmin_X sum_c || x_c - pi(P_c, X) ||^2``. Solved as in
Hartley & Zisserman (Sec. 12.2 and 12.5): a linear DLT estimate (the stacked constraints, each
row normalised, solved in least squares for the inhomogeneous point), then a few Gauss-Newton
(Levenberg-Marquardt damped) steps on the reprojection error. Everything is batched over
points: no Python loop per point.

Speed (the tracker triangulates every cluster and frame of a window in one call): the DLT's
normal matrices are built for all points with one matrix product against a per-view table,
and every 3x3 system is solved in closed form (adjugate) with elementwise numpy, rather than
a batched SVD / LAPACK call per point, which costs microseconds per point.

Inputs are pixels of the undistorted images (undistort raw pixels first with
:meth:`Camera.undistort`, or call :func:`triangulate_rig`). Fewer than two views gives NaN,
never a made-up number.
"""

from __future__ import annotations

import numpy as np

from .camera import Rig


# adjugate of a 3x3 matrix stored row-major as a[0..8]: adj[k] = a[I1] a[I2] - a[I3] a[I4]
_I1 = np.array([4, 2, 1, 5, 0, 2, 3, 1, 0])
_I2 = np.array([8, 7, 5, 6, 8, 3, 7, 6, 4])
_I3 = np.array([5, 1, 2, 3, 2, 0, 4, 0, 1])
_I4 = np.array([7, 8, 4, 8, 6, 5, 6, 7, 3])


def _solve3(A: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Closed-form (adjugate) solve of (n, 3, 3) ``A x = b``, b (n, 3); NaN rows where A is singular."""
    a = A.reshape(-1, 9).T
    adj = a[_I1] * a[_I2] - a[_I3] * a[_I4]  # (9, n)
    det = (a[:3] * adj[[0, 3, 6]]).sum(axis=0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return ((adj.reshape(3, 3, -1) * b.T[None]).sum(axis=1) / np.where(det != 0, det, np.nan)).T


_TABLES: dict[bytes, tuple] = {}


def _tables(P: np.ndarray) -> tuple:
    """Per-view constant tables of the DLT and Gauss-Newton normal equations, cached per ``P``.

    DLT: a normalised row ``r = t P3 - Pk`` (``k`` = 1, 2 for the pixel's u, v) gives
    ``r r^T = t^2 P3P3^T - t (P3Pk^T + PkP3^T) + PkPk^T`` and ``|r|^2 = t^2 |P3|^2 - 2 t P3.Pk
    + |Pk|^2``: the (N, 4, 4) normal matrices are per-point coefficients times a table.

    Gauss-Newton: with ``A0, A1, A2`` the rows of ``P_v[:, :3]``, pixel ``(px, py)``,
    ``iz = w / depth`` and residual ``(rx, ry)``, the Jacobian rows are ``iz (A0 - px A2)`` and
    ``iz (A1 - py A2)``, so per view
    ``J^T J = iz^2 [A0A0' + A1A1' - px (A0A2' + A2A0') - py (A1A2' + A2A1') + (px^2 + py^2) A2A2']``
    and ``J^T r = iz [rx A0 + ry A1 - (px rx + py ry) A2]``.

    Returns (dlt_table (6V, 16), norms (3, V, 2): |P3|^2, P3.Pk, |Pk|^2, jj_table (4V, 9), jr_table (3V, 3)).
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
    out = (dlt.reshape(6 * V, 16), norms, jj.reshape(4 * V, 9), jr.reshape(3 * V, 3))
    if len(_TABLES) > 32:
        _TABLES.clear()
    _TABLES[key] = out
    return out


def _dlt(P: np.ndarray, uv: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Batched linear estimate. P (V,3,4), uv (N,V,2), w (N,V) 0/1 weights -> X (N,3).

    Rows ``u*P3 - P1`` and ``v*P3 - P2`` (each normalised, zero for missing views) in least
    squares with ``X_h = [X, 1]`` (see :func:`_tables`).
    """
    table, (n33, n3k, nkk) = _tables(P)[:2]
    t = uv  # (N, V, 2)
    norm2 = t * t * n33 - 2 * t * n3k + nkk
    s = w[..., None] / np.where(norm2 > 0, norm2, 1.0)
    st = s * t
    coef = np.stack([st * t, st, s], axis=3).reshape(len(uv), -1)  # (N, V*2*3), table order
    M = (coef @ table).reshape(-1, 4, 4)
    return _solve3(M[:, :3, :3], -M[:, :3, 3])


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
    finite = np.all(np.isfinite(uv), axis=-1)
    mask = finite if mask is None else (np.asarray(mask, dtype=bool) & finite)
    X = np.full((N, 3), np.nan)
    err = np.full(N, np.nan)
    ok = mask.sum(axis=1) >= 2
    if not ok.any():
        return X, err
    u, m = np.where(mask[ok, :, None], uv[ok], 0.0), mask[ok]
    w = m.astype(np.float64)
    Xk = _dlt(P, u, w)
    # J^T J and J^T r as products of per-point coefficients with per-view tables (see _tables)
    tab_jj, tab_jr = _tables(P)[2:]

    def cost(Xq):
        Xc = _to_views(P, Xq)
        z = np.where(w > 0, Xc[..., 2], 1.0)  # missing views: any finite value, weight 0
        with np.errstate(divide="ignore", invalid="ignore"):
            px, py, iz = Xc[..., 0] / z, Xc[..., 1] / z, w / z
        rx, ry = (px - u[..., 0]) * w, (py - u[..., 1]) * w
        return (px, py, iz, rx, ry), np.sum(rx * rx + ry * ry, axis=1)

    state, old = cost(Xk)
    lam = np.full(len(Xk), 1e-3)
    n = len(Xk)
    for it in range(iterations):
        px, py, iz, rx, ry = state
        iz2 = iz * iz
        JtJ = (np.stack([iz2, iz2 * px, iz2 * py, iz2 * (px * px + py * py)], axis=2).reshape(n, 4 * V) @ tab_jj)
        Jtr = np.stack([iz * rx, iz * ry, iz * (px * rx + py * ry)], axis=2).reshape(n, 3 * V) @ tab_jr
        JtJ[:, ::4] += (lam * (JtJ[:, 0] + JtJ[:, 4] + JtJ[:, 8]) / 3)[:, None]  # LM damping of the diagonal
        step = _solve3(JtJ.reshape(n, 3, 3), -Jtr)
        cand = Xk + np.where(np.isfinite(step), step, 0.0)
        state_c, new = cost(cand)
        better = np.isfinite(new) & (new <= old)
        Xk = np.where(better[:, None], cand, Xk)
        old = np.where(better, new, old)
        if it + 1 < iterations:  # the next step needs the accepted residuals and damping
            state = tuple(np.where(better[:, None], c, s) for c, s in zip(state_c, state))
            lam = np.where(better, lam * 0.3, lam * 10.0)
    X[ok] = Xk
    err[ok] = np.sqrt(old / w.sum(axis=1))
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
