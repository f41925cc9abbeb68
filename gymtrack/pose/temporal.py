"""The temporal prior of a track's joints: where a joint's views disagree, or one view alone sees
it, the views that agree with the track's neighbouring frames decide.

Rule (beyond the paper; several close people): in a crowd a view's crop may hold a neighbour, a
joint may be misread in one view (a forearm taken from the person beside), and where only two
views see a joint, or one, the views themselves cannot tell which is right. A person's joint
moves little from one frame to the next (a gesturing hand ~1-2 m/s, 4-7 cm per frame at 25-30
fps), so the track's own frames around ``t`` say where the joint should be:

1. the prior ``R_t`` of each joint: the median of its well-observed positions (triangulated from
   2+ views) in the ``half_window`` frames each side of ``t``, ``t`` itself left out, where at
   least ``min_samples`` exist;
2. a joint is doubtful where its depth is itself a prior (one view, the plane: how plane /
   fused), or where a view found it but the estimate has none, or where it lies farther than
   ``tol_m`` from ``R_t`` *and* its views disagree: a view that found it was left out, or a view
   it was lifted from reprojects beyond the lifting's gate. Views that agree are never overruled
   by the prior (a salto's joints move faster than any window follows);
3. each view that found a doubtful joint agrees with the prior when its line of sight passes
   within ``tol_m`` of ``R_t``; two or more agreeing views are triangulated again (how =
   triangulated; the prior only chose the views), one agreeing view gives the point of its ray
   nearest ``R_t`` (its direction measured, its depth from the prior: how = fused). A new point
   farther than ``tol_m`` from ``R_t``, or no agreeing view, leaves the joint as it was.

Off with ``LiftOptions(temporal=None)``. Shapes like :mod:`.lift`: X3 (T, J, 3); u, v, found, use,
sc (C, J, T); how (T, J).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..poses import HOW_FUSED, HOW_NONE, HOW_PLANE, HOW_TRIANGULATED
from .dlt import gauss_newton, residuals, weighted_dlt


@dataclass(frozen=True)
class TemporalPrior:
    """half_window: frames each side the prior is taken from; min_samples: well-observed
    positions the prior needs; tol_m: how far (metres) a joint or a line of sight may lie from
    the prior and still agree with it (a wrist's motion over the window plus the prior's own
    error: larger accepts a neighbour's joint, smaller rejects fast but right motion);
    refine_iterations: Gauss-Newton steps of a re-triangulated joint."""

    half_window: int = 3
    min_samples: int = 2
    tol_m: float = 0.15
    refine_iterations: int = 2


def nan_median_window(X: np.ndarray, valid: np.ndarray, half_window: int, min_samples: int) -> np.ndarray:
    """(T, J, 3) per-coordinate median of X (T, J, 3) where valid (T, J), over the ``half_window``
    frames each side of each frame, the frame itself left out; NaN with fewer than ``min_samples``."""
    T = len(X)
    h = half_window
    Xv = np.where(valid[..., None], X, np.nan)
    pad = np.full((T + 2 * h,) + X.shape[1:], np.nan)
    pad[h:h + T] = Xv
    win = np.stack([pad[k:k + T] for k in range(2 * h + 1) if k != h], axis=-1)  # (T, J, 3, 2h)
    win = np.sort(win, axis=-1)  # NaN last
    n = np.isfinite(win[..., 0, :]).sum(axis=-1)  # (T, J)
    lo = np.clip((n - 1) // 2, 0, None)[..., None, None]
    hi = np.clip(n // 2, 0, None)[..., None, None]
    lo, hi = np.broadcast_to(lo, win.shape[:-1] + (1,)), np.broadcast_to(hi, win.shape[:-1] + (1,))
    med = 0.5 * (np.take_along_axis(win, lo, -1) + np.take_along_axis(win, hi, -1))[..., 0]
    med[n < max(min_samples, 1)] = np.nan
    return med


def ray_foot(o: np.ndarray, d: np.ndarray, R: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The point of each ray (origin o, unit direction d, both (..., 3)) nearest R (..., 3), in
    front of the camera, and its distance to R."""
    s = np.maximum(np.sum((R - o) * d, axis=-1), 0.0)
    foot = o + s[..., None] * d
    return foot, np.linalg.norm(foot - R, axis=-1)


def apply_prior(P: np.ndarray, X3: np.ndarray, how: np.ndarray, u: np.ndarray, v: np.ndarray, found: np.ndarray,
                use: np.ndarray, sc: np.ndarray, gate: np.ndarray, prior: TemporalPrior | None = TemporalPrior(),
                trusted: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
    """Re-decide the doubtful joints by the track's neighbouring frames (module doc).

    P (C, 3, 4) undistorted projections; found: the views that found each joint (candidates);
    use: the views it was lifted from; gate (C, J, T) the lifting's reprojection gate, pixels; trusted (T,) the frames whose triangulations may form the
    prior (default all; the lifting leaves out frames where no two views agreed). Returns X3, how, use updated and counts
    ``joints_prior_views`` (re-triangulated from the views that agree with the prior) and
    ``joints_prior_ray`` (one agreeing view, depth from the prior).
    """
    counts = {"joints_prior_views": 0, "joints_prior_ray": 0}
    C, J, T = u.shape
    if prior is None or T < 2:
        return X3, how, use, counts
    n_use = use.sum(axis=0).T  # (T, J)
    strong = (how == HOW_TRIANGULATED) & (n_use >= 2) & np.isfinite(X3).all(axis=2)
    if trusted is not None:
        strong &= np.asarray(trusted, bool)[:, None]
    R = nan_median_window(X3, strong, prior.half_window, prior.min_samples)
    has = np.isfinite(R).all(axis=2)
    with np.errstate(invalid="ignore"):
        far = np.linalg.norm(X3 - R, axis=2) > prior.tol_m
    n_found = found.sum(axis=0).T
    weak = (how == HOW_PLANE) | (how == HOW_FUSED) | ((how == HOW_NONE) & (n_found > 0))
    ft, fj = np.nonzero(far & ~weak & has)
    if ft.size:  # far from the prior: doubtful only where its views disagree
        r = residuals(P, X3[ft, fj].T, u[:, fj, ft], v[:, fj, ft])
        split = (n_found[ft, fj] > n_use[ft, fj]) | (use[:, fj, ft] & (r > gate[:, fj, ft])).any(axis=0)
        far = np.zeros_like(far)
        far[ft[split], fj[split]] = True
    doubt = has & (n_found > 0) & (far | weak)
    t, j = np.nonzero(doubt)
    if not t.size:
        return X3, how, use, counts
    X3, how, use = X3.copy(), how.copy(), use.copy()
    # each finding view's line of sight at the doubtful joint
    M = P[:, :, :3]
    Minv = np.linalg.inv(M)  # (C, 3, 3)
    o = -np.einsum("cij,cj->ci", Minv, P[:, :, 3])  # (C, 3) camera centres
    uu, vv = u[:, j, t], v[:, j, t]  # (C, n)
    fnd = found[:, j, t]
    pix = np.stack([np.where(fnd, uu, 0.0), np.where(fnd, vv, 0.0), np.ones_like(uu)], axis=1)  # (C, 3, n)
    d = np.einsum("cij,cjn->cin", Minv, pix)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    foot, dist = ray_foot(o[:, None, :], d.transpose(0, 2, 1), R[t, j][None])  # (C, n, 3), (C, n)
    agree = fnd & (dist <= prior.tol_m)
    n_agree = agree.sum(axis=0)
    # two or more agreeing views: triangulated again from them
    k = np.flatnonzero(n_agree >= 2)
    Xn = np.full((3, t.size), np.nan)
    if k.size:
        w = np.where(agree[:, k], sc[:, j[k], t[k]], 0.0)
        Xk = weighted_dlt(P, uu[:, k], vv[:, k], w)
        Xn[:, k] = gauss_newton(P, Xk, uu[:, k], vv[:, k], w, prior.refine_iterations)
    tri = (n_agree >= 2) & np.isfinite(Xn).all(axis=0)
    with np.errstate(invalid="ignore"):
        tri &= np.linalg.norm(Xn.T - R[t, j], axis=1) <= prior.tol_m
    # one agreeing view (or the agreeing ones would not triangulate): its ray's point nearest the prior
    best = np.argmin(np.where(agree, dist, np.inf), axis=0)
    ray = ~tri & (n_agree >= 1)
    idx = np.arange(t.size)
    Xn[:, ray] = foot[best[ray], idx[ray]].T
    change = tri | ray
    tc, jc = t[change], j[change]
    X3[tc, jc] = Xn[:, change].T
    how[tc, jc] = np.where(tri[change], HOW_TRIANGULATED, HOW_FUSED)
    one = np.zeros((C, ray.sum()), bool)
    one[best[ray], np.arange(ray.sum())] = True
    use[:, j[tri], t[tri]] = agree[:, tri]
    use[:, j[ray], t[ray]] = one
    counts["joints_prior_views"] = int(tri.sum())
    counts["joints_prior_ray"] = int(ray.sum())
    return X3, how, use, counts
