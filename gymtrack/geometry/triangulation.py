"""Triangulation of points seen in N >= 2 views, paper Eq. 3.

Paper: Section III-B, Eq. 3: ``X = argmin_X sum_c || x_c - pi(P_c, X) ||^2``. Solved as in
Hartley & Zisserman (Sec. 12.2 and 12.5): a linear DLT estimate from the SVD of the stacked
constraints, then a few Gauss-Newton (Levenberg-Marquardt damped) steps on the reprojection
error. Everything is batched over points: no Python loop per point.

Inputs are pixels of the undistorted images (undistort raw pixels first with
:meth:`Camera.undistort`, or call :func:`triangulate_rig`). Fewer than two views gives NaN,
never a made-up number.
"""

from __future__ import annotations

import numpy as np

from .camera import Rig


def _dlt(P: np.ndarray, uv: np.ndarray, w: np.ndarray) -> np.ndarray:
    """Batched DLT. P (V,3,4), uv (N,V,2), w (N,V) 0/1 weights -> homogeneous X (N,4)."""
    # Rows u*P3 - P1 and v*P3 - P2, each normalised for conditioning, zeroed for missing views.
    r1 = uv[..., 0:1] * P[None, :, 2, :] - P[None, :, 0, :]
    r2 = uv[..., 1:2] * P[None, :, 2, :] - P[None, :, 1, :]
    A = np.concatenate([r1, r2], axis=1)  # (N, 2V, 4)
    A /= np.linalg.norm(A, axis=-1, keepdims=True) + 1e-300
    A *= np.concatenate([w, w], axis=1)[..., None]
    _, _, vt = np.linalg.svd(A)
    return vt[:, -1, :]


def reprojection_residuals(P: np.ndarray, uv: np.ndarray, X: np.ndarray) -> np.ndarray:
    """(N, V, 2) reprojection residuals ``pi(P_v, X_n) - uv_nv`` for P (V,3,4), uv (N,V,2), X (N,3)."""
    Xc = np.einsum("vij,nj->nvi", P[:, :, :3], X) + P[None, :, :, 3]
    return Xc[..., :2] / Xc[..., 2:3] - uv


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
    Xh = _dlt(P, u, w)
    with np.errstate(divide="ignore", invalid="ignore"):
        Xk = Xh[:, :3] / Xh[:, 3:4]
    lam = np.full(len(Xk), 1e-3)
    Pr = P[:, :, :3]
    for _ in range(iterations):
        Xc = np.einsum("vij,nj->nvi", Pr, Xk) + P[None, :, :, 3]
        z = Xc[..., 2:3]
        r = (Xc[..., :2] / z - u) * w[..., None]  # (n, V, 2)
        # d(x/z)/dX = (P_row * z - x * P3) / z^2
        J = (Pr[None, :, :2, :] * z[..., None] - Xc[..., :2, None] * Pr[None, :, 2:3, :]) / (z[..., None] ** 2)
        J *= w[..., None, None]
        JtJ = np.einsum("nvai,nvaj->nij", J, J)
        Jtr = np.einsum("nvai,nva->ni", J, r)
        damp = JtJ + lam[:, None, None] * np.eye(3) * np.trace(JtJ, axis1=1, axis2=2)[:, None, None] / 3
        good = np.all(np.isfinite(damp), axis=(1, 2)) & np.all(np.isfinite(Jtr), axis=1)
        step = np.zeros_like(Xk)
        if good.any():
            try:
                step[good] = np.linalg.solve(damp[good], -Jtr[good][..., None])[..., 0]
            except np.linalg.LinAlgError:
                pass
        cand = Xk + step
        old = np.sum(r**2, axis=(1, 2))
        rc = reprojection_residuals(P, u, cand) * w[..., None]
        new = np.sum(rc**2, axis=(1, 2))
        better = np.isfinite(new) & (new <= old)
        Xk = np.where(better[:, None], cand, Xk)
        lam = np.where(better, lam * 0.3, lam * 10.0)
    res = reprojection_residuals(P, u, Xk) * w[..., None]
    X[ok] = Xk
    err[ok] = np.sqrt(np.sum(res**2, axis=(1, 2)) / w.sum(axis=1))
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
