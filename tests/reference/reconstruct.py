"""Numpy references of the triangulation stage's kernels (paper Section III-B, Eq. 3-4):
the outlier test and the gathering of a window's cluster pixels, triangulated with the public
:func:`gymtrack.geometry.triangulation.triangulate_views` (itself checked against OpenCV and scipy)."""

from __future__ import annotations

import numpy as np

from gymtrack.geometry.triangulation import triangulate_views as triangulate_views_numpy
from gymtrack.tracking.reconstruct import GN_ITERATIONS



def outliers_numpy(xyz, valid, space, max_speed):
    M, W = valid.shape
    if M == 0:
        return np.zeros(0, bool)
    flat = xyz.reshape(M * W, 3)
    pts = flat.T
    inside = ((pts >= space[:3, None]) & (pts <= space[3:, None])).all(axis=0).reshape(M, W)
    bad = (valid & ~inside).any(axis=1) | ~valid.any(axis=1)
    t = np.arange(W)
    prev = np.maximum.accumulate(np.where(valid, t, -1), axis=1)
    later = np.flatnonzero(valid[:, 1:] & (prev[:, :-1] >= 0))
    if len(later):
        row = later // (W - 1)
        tt = later - row * (W - 1) + 1
        p = prev[row, tt - 1]
        d = flat[row * W + tt] - flat[row * W + p]
        bad[row[np.linalg.norm(d, axis=1) > max_speed * (tt - p)]] = True
    return bad


def outliers_at_mean_numpy(xyz, valid, space, max_speed):
    """cascade+'s Eq. 4 before compilation: Eq. 4's speed test, the space test on the mean."""
    M, W = valid.shape
    if M == 0:
        return np.zeros(0, bool)
    anywhere = np.array([-np.inf] * 3 + [np.inf] * 3)
    bad = outliers_numpy(xyz, valid, anywhere, max_speed)
    n = valid.sum(axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(valid[..., None], xyz, 0.0).sum(axis=1) / n[:, None]
    inside = ((mean >= space[:3]) & (mean <= space[3:])).all(axis=1)
    return bad | ~inside


def triangulate_clusters_numpy(segs, members, P):
    """(centre (M, W, 3), top_z, bottom_z, valid, n_views) as before compilation."""
    M, C = members.shape
    W = segs.width
    has = members >= 0
    b = segs.box[np.where(has, members, 0)].transpose(3, 1, 0, 2)
    x, y, half = np.where(has.T[:, :, None], b[0], np.nan), b[1], b[3] / 2
    u = np.empty((C, 3, M, W))
    v = np.empty((C, 3, M, W))
    u[:] = x[:, None]
    v[:, 0] = y
    v[:, 1] = y - half
    v[:, 2] = y + half
    X, _ = triangulate_views_numpy(P, u.reshape(C, -1), v.reshape(C, -1), iterations=GN_ITERATIONS)
    X = X.reshape(3, 3, M, W)
    centre = X[:, 0].transpose(1, 2, 0)
    valid = np.isfinite(centre).all(axis=2)
    obs = segs.observed[np.where(has, members, 0)] & has[..., None]
    return centre, X[2, 1], X[2, 2], valid, obs.sum(axis=1).astype(np.int8)


def opposite_clusters_numpy(members, opposite):
    """The cascade's opposite two-view clusters as a bit-mask table lookup (what the kernel replaced)."""
    C = members.shape[1]
    table = np.zeros(1 << C, bool)
    i, j = np.nonzero(np.asarray(opposite, bool))
    keep = i != j
    table[(1 << i[keep]) | (1 << j[keep])] = True
    return table[(members >= 0) @ (1 << np.arange(C))]


def fallback_segments_numpy(members, fallback):
    back = members[fallback].ravel()
    return np.sort(back[back >= 0])
