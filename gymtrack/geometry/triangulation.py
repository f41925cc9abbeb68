"""Triangulation of points seen in N >= 2 views, paper Eq. 3.

Paper: Section III-B, Eq. 3: ``X = argmin_X sum_c || x_c - pi(P_c, X) ||^2``. Solved as in
Hartley & Zisserman (Sec. 12.2 and 12.5): a linear DLT estimate (the stacked constraints, each
row normalised, solved in least squares for the inhomogeneous point), then a few Gauss-Newton
(Levenberg-Marquardt damped) steps on the reprojection error.

One implementation: the compiled per-point solver :func:`gymtrack.geometry.primitives.triangulate_points`
(the tracker's kernels call it directly); this module is its array API (shapes checked, masks
and NaN handled, points-major or views-major). A compiled loop over points beats batched numpy
here: every 3x3 normal system is solved in closed form in registers, with no temporaries.

Inputs are pixels of the undistorted images (undistort raw pixels first with
:meth:`Camera.undistort`, or call :func:`triangulate_rig`). Fewer than two views gives NaN,
never a made-up number.
"""

from __future__ import annotations

import numpy as np

from .camera import Rig
from .primitives import triangulate_points


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
    P = np.ascontiguousarray(P, dtype=np.float64)
    u = np.ascontiguousarray(u, dtype=np.float64)
    v = np.ascontiguousarray(v, dtype=np.float64)
    if u.shape != v.shape or u.ndim != 2 or P.shape != (u.shape[0], 3, 4):
        raise ValueError(f"need P (V, 3, 4) and u, v (V, N) with the same V, got P {P.shape}, u {u.shape}, v {v.shape}")
    finite = np.isfinite(u) & np.isfinite(v)
    mask = finite if mask is None else (np.asarray(mask, dtype=bool) & finite)
    return triangulate_points(P, u, v, np.ascontiguousarray(mask), int(iterations))


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
