"""Numpy references of Eq. 1 and Eq. 7 (paper Sections III-B, III-C): the vectorised code the
public :func:`gymtrack.geometry.epipolar.epipolar_distance` and
:func:`gymtrack.geometry.plane.intersect_rays_plane` ran before they were written once, on the
compiled primitives of :mod:`gymtrack.geometry.primitives`."""

from __future__ import annotations

import numpy as np

from gymtrack.geometry.epipolar import epipolar_lines, point_line_distance
from gymtrack.geometry.plane import Plane, RayPlaneStatus


def epipolar_distance_numpy(box_i: np.ndarray, box_j: np.ndarray, F_ij: np.ndarray) -> np.ndarray:
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
    person's box centres under real detector noise (the paper's threshold is 0.3).
    """
    box_i = np.asarray(box_i, dtype=np.float64)
    box_j = np.asarray(box_j, dtype=np.float64)
    F_ij = np.asarray(F_ij, dtype=np.float64)
    xi, xj = box_i[..., :2], box_j[..., :2]
    line_in_j = epipolar_lines(F_ij, xi)
    line_in_i = epipolar_lines(np.swapaxes(F_ij, -1, -2), xj)
    d_i = point_line_distance(xi, line_in_i) / np.abs(box_i[..., 2] + box_i[..., 3])
    d_j = point_line_distance(xj, line_in_j) / np.abs(box_j[..., 2] + box_j[..., 3])
    return d_i + d_j


def intersect_rays_plane_numpy(
    origins: np.ndarray,
    directions: np.ndarray,
    plane: Plane,
    min_cos: float = 1e-3,
) -> tuple[np.ndarray, np.ndarray]:
    """Intersect rays with a plane (paper Eq. 7), vectorised.

    Parameters
    ----------
    origins: (..., 3) ray origins (camera centres ``X^o_c``), broadcast against ``directions``.
    directions: (..., 3) ray directions ``{}^w v`` (need not be unit length).
    plane: the plane.
    min_cos: rays whose direction makes ``|cos| < min_cos`` with the normal count as parallel.
        The default (about 0.06 degrees off the plane) keeps intersections within ~1000 x the
        camera's distance to the plane; raise it to refuse grazing rays whose intersection is
        too sensitive to pixel noise.

    Returns
    -------
    X: (..., 3) intersection points; NaN where the status is not OK.
    status: (...) int8 :class:`RayPlaneStatus` codes.
    """
    o = np.asarray(origins, dtype=np.float64)
    d = np.asarray(directions, dtype=np.float64)
    o, d = np.broadcast_arrays(o, d)
    dn = d @ plane.normal
    dlen = np.linalg.norm(d, axis=-1)
    # written negated so that zero-length and NaN directions count as parallel (no intersection)
    parallel = ~(np.abs(dn) >= min_cos * dlen) | ~(dlen > 0)
    with np.errstate(divide="ignore", invalid="ignore", over="ignore"):  # (denormal directions overflow)
        lam = ((plane.point - o) @ plane.normal) / dn
        X = o + lam[..., None] * d  # inf * 0 for exactly parallel rays: masked below
    behind = ~parallel & ~(lam > 0)
    status = np.where(parallel, RayPlaneStatus.PARALLEL, np.where(behind, RayPlaneStatus.BEHIND, RayPlaneStatus.OK)
    ).astype(np.int8)
    X[status != RayPlaneStatus.OK] = np.nan
    return X, status
