"""Planes fitted to 3D points: the apparatus plane (vertical) and the floor (beyond the paper).

Paper: the vertical plane of Section III-C (Eq. 7) is domain knowledge typed in by hand; here it
is estimated from points known to lie near it -- the target gymnast's well-triangulated centres --
and the floor from the box bottoms of standing people. Both fits are RANSAC (minimal samples,
inliers within ``threshold``) followed by total least squares on the inliers, so that people
off the apparatus and bad triangulations do not pull the plane.

* :func:`fit_vertical_plane`: a plane whose normal is horizontal (``n_z = 0``): a line fitted to
  the points' (x, y); a vertical plane is what Eq. 7 uses.
* :func:`fit_apparatus_plane` : the vertical plane by a scan over its direction,
  each point weighted by its own covariance (:func:`triangulation_covariances`: an opposite
  pair's point is precise across the cameras' axis and poor along it) and each stretch of the
  plane counted once however long the gymnast dwells there; it says when the data do not
  determine the direction (too few stretches, a cloud not elongated along any vertical plane --
  the gymnast circling the pommel horse -- or an angle too uncertain) and then keeps a preset's
  direction, fitting only the offset.
* :func:`fit_plane`: a general plane (the floor: normal near +z).
* :func:`plane_difference`: how far one plane is from another near a point (offset along the
  normal, metres, and the angle between the normals, degrees).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .plane import Plane

__all__ = ["PlaneFitResult", "fit_vertical_plane", "fit_apparatus_plane", "triangulation_covariances", "fit_plane",
           "plane_difference"]


@dataclass(frozen=True)
class PlaneFitResult:
    """plane: the fitted plane; inliers: (N,) bool over the input points; rms: metres, the
    inliers' RMS distance from the plane."""

    plane: Plane
    inliers: np.ndarray
    rms: float
    #: (fit_apparatus_plane) whether the data determined the direction; why not; the angle's
    #: standard deviation (degrees); the stretches of the plane the points covered
    determined: bool = True
    reason: str = ""
    angle_sigma_deg: float = float("nan")
    n_cells: int = 0

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


def triangulation_covariances(P: np.ndarray, X: np.ndarray, views: np.ndarray, sigma_px: np.ndarray) -> np.ndarray:
    """First-order covariance (N, 3, 3) of triangulated points (Eq. 3) from their views.

    P: (C, 3, 4) projections; X: (N, 3) points; views: (N, C) bool, the views that saw each
    point; sigma_px: (N, C) or scalar pixel noise. Covariance = (sum_c J_c^T J_c / sigma_c^2)^-1
    with J_c the 2x3 Jacobian of camera c's projection at X. Points of fewer than two views get
    NaN. An opposite pair's covariance is long along the cameras' axis (its rays nearly agree).
    """
    X = np.asarray(X, dtype=np.float64).reshape(-1, 3)
    Xh = np.concatenate([X, np.ones((len(X), 1))], axis=1)
    x = np.einsum("cij,nj->nci", P, Xh)  # (N, C, 3)
    uv = x[..., :2] / x[..., 2:3]
    J = (P[None, :, :2, :3] - uv[..., None] * P[None, :, 2:3, :3]) / x[..., 2, None, None]  # (N, C, 2, 3)
    w = np.where(views, 1.0 / np.broadcast_to(np.asarray(sigma_px, dtype=np.float64), views.shape) ** 2, 0.0)
    info = np.einsum("nc,ncki,nckj->nij", w, J, J)
    out = np.full((len(X), 3, 3), np.nan)
    ok = (views.sum(axis=1) >= 2) & np.isfinite(info).all(axis=(1, 2))
    out[ok] = np.linalg.inv(info[ok] + 1e-12 * np.eye(3))
    return out


def fit_apparatus_plane(points: np.ndarray, cov: np.ndarray | None = None, preset: Plane | None = None,
                        point_sigma: float = 0.05, stray: float = 0.25, cell: float = 0.25, min_cells: int = 8,
                        min_ratio: float = 1.5, max_angle_sigma: float = 5.0, step_deg: float = 0.5,
                        max_turn: float = 30.0, cell_cap: float = 5.0) -> PlaneFitResult:
    """The apparatus' vertical plane through the gymnast's (N, 3) centres (beyond the paper).

    cov: (N, 2, 2) or (N, 3, 3) covariances (only the horizontal block is used; default
    ``point_sigma``^2 I); ``stray``: metres the body's centre strays from the plane. For every
    direction on a ``step_deg`` grid the offset is the weighted centre of the points along the
    normal and the cost their robust Gaussian misfit, ``min(r^2 / v, 9) + log v`` with ``v =
    stray^2 + n^T Sigma n``, each point weighted by ``min(1, cell_cap / points in its cell-metre
    square of the floor)``: dwell time (standing on the landing mat) does not outvote the ground
    the gymnast covered. Trade: a small ``cell_cap`` discards more of the (independent) pixel
    noise averaging, a large one lets dwell time decide (measured on the suite's n_cam = 2
    routines: 1 tilted the beam's fit 2 deg, 20 let the landing mat pull the vault's); a larger
    ``min_ratio`` keeps the preset's direction more often.

    The direction is *not determined* (``determined`` False, ``reason`` says why) with inliers in
    fewer than ``min_cells`` cells, a cloud whose spread along the plane is under ``min_ratio`` x its
    spread across it (the pommel horse: the gymnast circles it), or an angle standard deviation
    over ``max_angle_sigma`` degrees, or (with a ``preset``, whose direction is searched only
    within ``max_turn`` degrees: a plane typed in by hand is roughly right) a best direction at
    the edge of that search; the plane then keeps ``preset``'s (horizontal) direction and only
    its offset is fitted (without a preset the best direction is returned, still flagged;
    ``max_turn=0`` with a preset fits the offset only).
    """
    p = _checked(points, 2, 3)
    finite = np.isfinite(np.asarray(points, dtype=np.float64).reshape(-1, 3)).all(axis=1)
    xy = p[:, :2]
    S = np.broadcast_to(point_sigma ** 2 * np.eye(2), (len(p), 2, 2)) if cov is None else \
        np.asarray(cov, dtype=np.float64)[finite][:, :2, :2]
    S = np.where(np.isfinite(S), S, 1e6)  # (an unknown covariance: the point counts for nothing)
    # each occupied cell of the floor counts once: dwell time does not outvote the ground covered
    _, inv, cnt = np.unique(np.floor(xy / cell).astype(np.int64), axis=0, return_inverse=True, return_counts=True)
    w = 1.0 / np.maximum(1.0, cnt[inv.ravel()] / cell_cap)
    if preset is not None:  # a preset typed in by hand is roughly right: search within max_turn of it
        pn = np.asarray(preset.normal[:2], dtype=np.float64)
        if np.linalg.norm(pn) < 1e-6:
            raise ValueError("the preset plane is horizontal; an apparatus plane is vertical")
        a0 = np.arctan2(pn[1], pn[0])
        angles = a0 + np.radians(np.arange(-max_turn, max_turn + step_deg / 2, step_deg))
    else:
        angles = np.radians(np.arange(0.0, 180.0, step_deg))
    # coarse to fine: the grid at 4 x step, then step about its best (the refit must stay cheap online)
    coarse = angles[::4]
    a = coarse[np.argmin(_costs(xy, S, coarse, stray, w))]
    fine = a + np.radians(step_deg) * np.arange(-4, 5)
    if preset is not None:
        fine = fine[np.abs(fine - a0) <= np.radians(max_turn) + 1e-9]
    a = fine[np.argmin(_costs(xy, S, fine, stray, w))]
    n = np.array([np.cos(a), np.sin(a)])
    _, d, w, v, inl = _offset_cost(xy, S, n, stray, w)
    t = xy @ np.array([-n[1], n[0]])
    wi = w * inl
    tm = (wi @ t) / wi.sum()
    along = float(np.sqrt((wi @ (t - tm) ** 2) / wi.sum()))
    r = xy @ n - d
    # the spread across the plane that the points' own noise does not explain (an opposite pair's
    # scatter along the cameras' axis is noise, not the gymnast leaving the plane)
    noise = np.einsum("i,nij,j->n", n, S, n)
    across = float(np.sqrt(max((wi @ (r ** 2 - noise)) / wi.sum(), 0.0)))
    fisher = float((wi * (t - tm) ** 2 / v).sum())  # each stretch one observation: the angle's information
    sigma_deg = float(np.degrees(1.0 / np.sqrt(fisher))) if fisher > 0 else float("inf")
    cells = len(np.unique(inv.ravel()[inl]))
    reason = ""
    if cells < min_cells:
        reason = f"the points cover {cells} cells of {cell} m, under {min_cells}"
    elif preset is not None and abs(np.degrees(a - a0)) > max_turn - 2 * step_deg:
        reason = (f"the best direction lies at the edge of the {max_turn:g} deg searched about the preset's: "
                  "the points favour another plane (as when the gymnast circles the apparatus)")
    elif along < min_ratio * across:
        reason = (f"the points are not elongated along a vertical plane (spread {along:.2f} m along, "
                  f"{across:.2f} m across beyond their noise)")
    elif sigma_deg > max_angle_sigma:
        reason = f"the direction is uncertain ({sigma_deg:.1f} deg standard deviation)"
    if reason and preset is not None:
        n = pn / np.linalg.norm(pn)
        _, d, w, v, inl = _offset_cost(xy, S, n, stray, w)
        r = xy @ n - d
    rms = float(np.sqrt(np.mean(r[inl] ** 2))) if inl.any() else float("nan")
    inliers = np.zeros(len(finite), bool)
    inliers[finite] = inl
    return PlaneFitResult(Plane(np.array([d * n[0], d * n[1], 0.0]), np.array([n[0], n[1], 0.0])), inliers, rms,
                          not reason, reason, sigma_deg, cells)


def _costs(xy: np.ndarray, S: np.ndarray, angles: np.ndarray, stray: float, w: np.ndarray) -> np.ndarray:
    """(A,) the cost of :func:`_offset_cost` for every direction ``angles`` (radians) at once
    (arrays (A, N): each direction's points contiguous for the sort)."""
    c, s_ = np.cos(angles)[:, None], np.sin(angles)[:, None]
    v = stray ** 2 + S[:, 0, 0] * c ** 2 + 2 * S[:, 0, 1] * c * s_ + S[:, 1, 1] * s_ ** 2  # (A, N)
    s = c * xy[:, 0] + s_ * xy[:, 1]
    wv = w / v
    o = np.argsort(s, axis=1)
    rows = np.arange(len(angles))[:, None]
    cw = np.cumsum(wv[rows, o], axis=1)
    k = np.minimum((cw < 0.5 * cw[:, -1:]).sum(axis=1), s.shape[1] - 1)
    d = s[np.arange(len(angles)), o[np.arange(len(angles)), k]][:, None]  # weighted medians
    for _ in range(3):
        m = wv * ((s - d) ** 2 < 9.0 * v)
        tot = m.sum(axis=1, keepdims=True)
        d = np.where(tot > 0, (m * s).sum(axis=1, keepdims=True) / np.where(tot > 0, tot, 1.0), d)
    z = np.minimum((s - d) ** 2 / v, 9.0)
    return (z + np.log(v)) @ w / w.sum()


def _offset_cost(xy: np.ndarray, S: np.ndarray, n: np.ndarray, stray: float, w: np.ndarray):
    """One direction ``n`` (2,), point weights ``w``: (cost, offset d, w, variances v, inliers)
    of the robust weighted fit ``n . x = d`` (three reweighted rounds from the weighted median)."""
    v = stray ** 2 + np.einsum("i,nij,j->n", n, S, n)
    s = xy @ n
    wv = w / v
    o = np.argsort(s)
    cw = np.cumsum(wv[o])
    d = s[o][np.searchsorted(cw, 0.5 * cw[-1])]  # weighted median: outliers do not pull the start
    for _ in range(3):
        inl = (s - d) ** 2 < 9.0 * v
        if not inl.any():
            break
        d = (wv[inl] @ s[inl]) / wv[inl].sum()
    z = np.minimum((s - d) ** 2 / v, 9.0)
    inl = (s - d) ** 2 < 9.0 * v
    cost = float((w @ (z + np.log(v))) / w.sum())
    return cost, d, w, v, inl
