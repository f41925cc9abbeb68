"""Planes fitted to 3D points: the apparatus plane (vertical) and the floor (beyond the paper).

Paper: the vertical plane of Section III-C (Eq. 7) is domain knowledge typed in by hand; here it
is estimated from points known to lie near it -- the target gymnast's well-triangulated centres --
and the floor from the box bottoms of standing people. Both fits are RANSAC (minimal samples,
inliers within ``threshold``) followed by total least squares on the inliers, so that people
off the apparatus and bad triangulations do not pull the plane.

* :func:`fit_vertical_plane`: a plane whose normal is horizontal (``n_z = 0``): a line fitted to
  the points' (x, y); a vertical plane is what Eq. 7 uses.
* :func:`fit_plane`: a general plane (the floor: normal near +z).
* :func:`plane_difference`: how far one plane is from another near a point (offset along the
  normal, metres, and the angle between the normals, degrees).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .plane import Plane

__all__ = ["PlaneFitResult", "fit_vertical_plane", "fit_plane", "plane_difference"]


@dataclass(frozen=True)
class PlaneFitResult:
    """plane: the fitted plane; inliers: (N,) bool over the input points; rms: metres, the
    inliers' RMS distance from the plane."""

    plane: Plane
    inliers: np.ndarray
    rms: float

    @property
    def n_inliers(self) -> int:
        return int(self.inliers.sum())


def _tls(points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Total least squares: (N, D) points -> centroid (D,) and unit normal (D,) (smallest
    principal direction)."""
    c = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - c, full_matrices=False)
    return c, vt[-1]


def _ransac(points: np.ndarray, sample: int, threshold: float, iterations: int, seed: int) -> np.ndarray:
    """(N, D) points -> (N,) bool inliers of the best hyperplane through ``sample`` points."""
    n = len(points)
    rng = np.random.default_rng(seed)
    idx = np.stack([rng.choice(n, sample, replace=False) for _ in range(iterations)])  # (I, sample)
    normals = np.empty((iterations, points.shape[1]))
    offsets = np.empty(iterations)
    for i, s in enumerate(idx):
        c, nrm = _tls(points[s])
        normals[i], offsets[i] = nrm, nrm @ c
    dist = np.abs(points @ normals.T - offsets)  # (N, I)
    best = np.argmax((dist < threshold).sum(axis=0))
    return dist[:, best] < threshold


def _checked(points: np.ndarray, dims: int, minimum: int) -> np.ndarray:
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    p = p[np.isfinite(p).all(axis=1)]
    if len(p) < minimum:
        raise ValueError(f"a plane fit needs at least {minimum} finite points, got {len(p)}")
    return p


def fit_vertical_plane(points: np.ndarray, threshold: float = 0.3, iterations: int = 200,
                       seed: int = 0) -> PlaneFitResult:
    """A vertical plane (horizontal normal) through (N, 3) points: RANSAC on their (x, y) with
    lines through two points, inliers within ``threshold`` metres, then total least squares.
    The plane's point is the inliers' centroid at z = 0. NaN rows are ignored."""
    p = _checked(points, 2, 3)
    xy = p[:, :2]
    inl = _ransac(xy, 2, threshold, iterations, seed) if len(p) > 3 else np.ones(len(p), bool)
    c, n2 = _tls(xy[inl])
    rms = float(np.sqrt(np.mean(((xy[inl] - c) @ n2) ** 2)))
    return PlaneFitResult(Plane(np.array([c[0], c[1], 0.0]), np.array([n2[0], n2[1], 0.0])),
                          _expand(points, inl), rms)


def fit_plane(points: np.ndarray, threshold: float = 0.1, iterations: int = 200, seed: int = 0,
              up: bool = True) -> PlaneFitResult:
    """A general plane through (N, 3) points (RANSAC with three-point planes, then total least
    squares); ``up``: the normal is turned to have ``n_z >= 0`` (the floor's). NaN rows ignored."""
    p = _checked(points, 3, 3)
    inl = _ransac(p, 3, threshold, iterations, seed) if len(p) > 3 else np.ones(len(p), bool)
    c, n = _tls(p[inl])
    if up and n[2] < 0:
        n = -n
    rms = float(np.sqrt(np.mean(((p[inl] - c) @ n) ** 2)))
    return PlaneFitResult(Plane(c, n), _expand(points, inl), rms)


def _expand(points: np.ndarray, inliers_of_finite: np.ndarray) -> np.ndarray:
    """Inliers over the finite rows -> (N,) over all input rows (NaN rows are not inliers)."""
    p = np.asarray(points, dtype=np.float64).reshape(-1, 3)
    out = np.zeros(len(p), bool)
    out[np.isfinite(p).all(axis=1)] = inliers_of_finite
    return out


def plane_difference(plane: Plane, reference: Plane, at: np.ndarray) -> tuple[float, float]:
    """How far ``plane`` is from ``reference`` near the point ``at`` (3,): (offset, angle).

    offset: metres, the distance from ``plane`` of ``at`` projected onto ``reference``; angle:
    degrees between the two planes (normals compared without their sign, 0..90).
    """
    on_ref = reference.project(np.asarray(at, dtype=np.float64))
    offset = float(abs(plane.signed_distance(on_ref)))
    cos = min(1.0, abs(float(plane.normal @ reference.normal)))
    return offset, float(np.degrees(np.arccos(cos)))
