"""Numpy references of Eq. 1 and Eq. 7 (paper Sections III-B, III-C): the vectorised code the
public :func:`gymtrack.geometry.epipolar.epipolar_distance` and
:func:`gymtrack.geometry.plane.intersect_rays_plane` ran before they were written once, on the
compiled primitives of :mod:`gymtrack.geometry.primitives`."""

from __future__ import annotations

import numpy as np

from gymtrack.geometry.epipolar import epipolar_lines, point_line_distance
from gymtrack.geometry.plane import Plane, RayPlaneStatus


def epipolar_distance_numpy(box_i: np.ndarray, box_j: np.ndarray, F_ij: np.ndarray) -> np.ndarray:
    """Eq. 1 in numpy: the contract of :func:`gymtrack.geometry.epipolar.epipolar_distance`."""
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
    """Eq. 7 in numpy: the contract of :func:`gymtrack.geometry.plane.intersect_rays_plane`."""
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
