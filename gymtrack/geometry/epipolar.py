"""Epipolar geometry between two views and the box distance of paper Eq. 1.

Paper: Section III-B, Eq. 1 (the symmetric point-to-epipolar-line distance of two box centres,
each term normalised by its box's scale ``|w + h|``). Pixels here are pixels of the
undistorted image (see :meth:`Camera.undistort`): the epipolar constraint only holds there.

Convention: ``F = fundamental_matrix(cam_i, cam_j)`` satisfies ``x_j^T F x_i = 0``, so
``F @ x_i`` is the epipolar line of ``x_i`` in view ``j`` and ``F.T @ x_j`` the line of
``x_j`` in view ``i`` (the paper's ``F_{c_i,c_j}`` and ``F_{c_j,c_i} = F_{c_i,c_j}^T``).
"""

from __future__ import annotations

import numpy as np

from .camera import Camera, Rig
from .primitives import box_distances


def skew(v: np.ndarray) -> np.ndarray:
    """(3,) -> (3, 3) cross-product matrix ``[v]_x``."""
    x, y, z = np.asarray(v, dtype=np.float64)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def fundamental_matrix(cam_i: Camera, cam_j: Camera) -> np.ndarray:
    """(3, 3) fundamental matrix ``F`` with ``x_j^T F x_i = 0``, scaled to unit Frobenius norm.

    From the relative pose ``R = R_j R_i^T``, ``t = t_j - R t_i``:
    ``F = K_j^{-T} [t]_x R K_i^{-1}`` (Hartley & Zisserman, eq. 9.2).
    """
    R = cam_j.R @ cam_i.R.T
    t = cam_j.t - R @ cam_i.t
    F = np.linalg.inv(cam_j.K).T @ skew(t) @ R @ np.linalg.inv(cam_i.K)
    n = np.linalg.norm(F)
    return F / n if n > 0 else F


def fundamental_matrices(rig: Rig) -> np.ndarray:
    """(C, C, 3, 3): ``F[i, j]`` maps points of view ``i`` to epipolar lines in view ``j``.

    The diagonal is zero (no epipolar geometry of a view with itself).
    """
    C = len(rig)
    out = np.zeros((C, C, 3, 3))
    for i in range(C):
        for j in range(i + 1, C):
            F = fundamental_matrix(rig[i], rig[j])
            out[i, j] = F
            out[j, i] = F.T
    return out


def _homogeneous(pts: np.ndarray) -> np.ndarray:
    pts = np.asarray(pts, dtype=np.float64)
    return np.concatenate([pts, np.ones(pts.shape[:-1] + (1,))], axis=-1)


def epipolar_lines(F: np.ndarray, pts: np.ndarray) -> np.ndarray:
    """Epipolar lines ``l = F x`` of points.

    Parameters
    ----------
    F: (..., 3, 3) fundamental matrices (broadcast against the points).
    pts: (..., 2) pixels in the source view.

    Returns
    -------
    (..., 3) lines ``(l1, l2, l3)`` in the other view, scaled so that ``l1^2 + l2^2 = 1``.
    """
    lines = np.einsum("...ij,...j->...i", F, _homogeneous(pts))
    norm = np.hypot(lines[..., 0], lines[..., 1])
    with np.errstate(invalid="ignore", divide="ignore"):
        return lines / norm[..., None]


def point_line_distance(pts: np.ndarray, lines: np.ndarray) -> np.ndarray:
    """``|l1 x + l2 y + l3| / sqrt(l1^2 + l2^2)`` for (..., 2) points and (..., 3) lines -> (...)."""
    pts = np.asarray(pts, dtype=np.float64)
    lines = np.asarray(lines, dtype=np.float64)
    num = np.abs(lines[..., 0] * pts[..., 0] + lines[..., 1] * pts[..., 1] + lines[..., 2])
    with np.errstate(invalid="ignore", divide="ignore"):
        return num / np.hypot(lines[..., 0], lines[..., 1])


def epipolar_distance(box_i: np.ndarray, box_j: np.ndarray, F_ij: np.ndarray) -> np.ndarray:
    """Normalised symmetric epipolar distance of two boxes, paper Eq. 1.

    ``d = d(x_i, F_ij^T x_j) / |w_i + h_i| + d(x_j, F_ij x_i) / |w_j + h_j|``

    Parameters
    ----------
    box_i: (..., 4) centre-form boxes ``[x, y, w, h]`` in view i (undistorted pixels).
    box_j: (..., 4) boxes in view j; broadcast against ``box_i`` (e.g. ``(N, 1, 4)`` and
        ``(1, M, 4)`` give the (N, M) matrix of every pair).
    F_ij: (..., 3, 3) fundamental matrix with ``x_j^T F_ij x_i = 0``.

    Returns
    -------
    (...) dimensionless distances: 0 for a perfect correspondence; about 0.1-0.3 for the same
    person's box centres under real detector noise (the paper's threshold is 0.3); NaN where a
    line is undefined (F zero, a centre on the epipole).

    One compiled loop over the pairs on the primitives the tracker's Eq. 2 kernel runs
    (:func:`gymtrack.geometry.primitives.box_distances`): Eq. 1 is written once.
    """
    box_i, box_j = np.asarray(box_i, dtype=np.float64), np.asarray(box_j, dtype=np.float64)
    F_ij = np.asarray(F_ij, dtype=np.float64)
    shape = np.broadcast_shapes(box_i.shape[:-1], box_j.shape[:-1], F_ij.shape[:-2])
    c = np.ascontiguousarray
    bi = c(np.broadcast_to(box_i, shape + (4,)).reshape(-1, 4))
    bj = c(np.broadcast_to(box_j, shape + (4,)).reshape(-1, 4))
    F = np.broadcast_to(F_ij, shape + (3, 3)).reshape(-1, 1, 3, 3)
    return box_distances(bi, bj, c(F), c(np.swapaxes(F, -1, -2))).reshape(shape)
