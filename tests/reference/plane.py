"""The plane kernels one step at a time, and their numpy references (paper Section III-C, Eq. 5-9).

Production runs only :func:`gymtrack.tracking.plane_fallback.plane_stage` (one kernel call);
the tests check its steps -- candidates (Eq. 5-7), Eq. 8 distances, the best plane, Eq. 9 --
through the wrappers here, each against the vectorised numpy version it replaced (``*_numpy``),
which builds the candidates with :func:`gymtrack.geometry.plane.intersect_rays_plane`.
"""

from __future__ import annotations

import numpy as np

from gymtrack.geometry.arrays import PlaneArrays
from gymtrack.geometry.camera import Rig
from gymtrack.geometry.plane import Plane, RayPlaneStatus, intersect_rays_plane
from gymtrack.tracking._kernels import plane as kernels
from gymtrack.tracking._kernels.plane import NO_SINGLE, PlaneRules
from gymtrack.tracking.plane_fallback import MIN_COS
from gymtrack.tracking.reconstruct import cluster_members, source_for
from gymtrack.tracking.types import INTERPOLATED, PLANE, WindowTracklets, WindowTracklets3D

from .clustering import complete_linkage_sequential


# ============================================================ the kernel's steps
def ray_directions(rig: Rig, camera: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Eq. 6 for many segments at once: world ray directions ``R^T K^-1 [u, v, 1]``.

    camera: (K,); uv: (K, n, 2) undistorted pixels of segment k (any n points). Returns (K, n, 3)
    directions (not unit length; the same rays as :meth:`Camera.rays` with ``undistort=False``).
    """
    back = rig.arrays.back
    h = np.concatenate([uv, np.ones(uv.shape[:-1] + (1,))], axis=-1)  # (K, n, 3)
    return h @ np.swapaxes(back[camera], 1, 2)


def plane_candidates(
    segs: WindowTracklets, rig: Rig, planes: list[Plane], which: tuple[str, ...] = ("centre", "top", "bottom")
) -> np.ndarray:
    """Eq. 5-7 for every segment, frame and plane.

    which: the box points whose rays are used (``centre``, ``top``-centre, ``bottom``-centre).
    Returns (len(which), P, K, W, 3): the intersections of the rays through those points with
    each plane; NaN where the segment is not valid or the ray misses the plane (parallel, or
    the plane behind the camera).
    """
    X = candidates(segs, rig, planes)[0]
    return X[[_POINTS.index(w) for w in which]]


_POINTS = ("centre", "top", "bottom")


def candidates(segs: WindowTracklets, rig: Rig, planes: list[Plane]) -> tuple:
    """(3, P, K, W, 3) centre, top and bottom candidates and (3, P, K, W) bool, where they exist:
    the kernel :func:`gymtrack.tracking._kernels.plane.plane_candidates`."""
    c = np.ascontiguousarray
    return kernels.plane_candidates(c(segs.box, dtype=np.float64), c(segs.camera, dtype=np.int64), rig.arrays,
                                    PlaneArrays.from_planes(planes), MIN_COS)


def candidate_distances(X: np.ndarray, observed: np.ndarray, camera: np.ndarray, exists: np.ndarray | None = None
                        ) -> np.ndarray:
    """Eq. 8 on every plane.

    X: (P, K, W, 3) centre candidates; observed: (K, W) bool; camera: (K,); exists: (P, K, W)
    bool, where the candidate exists (default: where X is finite).
    Returns (P, K, K): mean distance (metres) over frames where both were observed and both
    intersections exist; NaN with no such frame; inf for two segments of one camera.
    """
    if exists is None:
        exists = np.all(np.isfinite(X), axis=-1)
    c = np.ascontiguousarray
    return kernels.candidate_distances(c(X, dtype=np.float64), c(observed), c(camera, dtype=np.int64), c(exists))


def best_plane_distance(Dp: np.ndarray) -> np.ndarray:
    """(P, K, K) -> (K, K): the smallest known distance over the planes (NaN if none known)."""
    return kernels.best_plane_distance(np.ascontiguousarray(Dp, dtype=np.float64))


def fuse_on_planes(
    segs: WindowTracklets,
    cand: np.ndarray,
    Dp: np.ndarray,
    labels: np.ndarray,
    n_cameras: int,
    single: np.ndarray | None = None,
    exists: np.ndarray | None = None,
) -> WindowTracklets3D:
    """Eq. 9: average the matched candidates of each cluster with members from two or more views.

    segs: the K segments of the plane stage; cand: (3, P, K, W, 3) from :func:`plane_candidates`;
    Dp: (P, K, K) Eq. 8 distances (to pick each cluster's plane); labels: (K,) clusters with
    at most one segment per camera; single: (K,) bool, segments that may stand alone (a
    one-member cluster, on the first plane) -- see :func:`plane_stage`; exists: (3, P, K, W)
    bool, where the candidates exist (default: where they are finite). Returns one 3D
    tracklet per cluster of >= 2 members (or a permitted single), source plane; ``members``
    index ``segs``.
    """
    W = segs.width
    if exists is None:
        exists = np.all(np.isfinite(cand), axis=-1)
    c = np.ascontiguousarray
    out = kernels.fuse_on_planes(
        c(cand, dtype=np.float64), c(exists, dtype=bool), c(Dp, dtype=np.float64), c(labels, dtype=np.int64),
        c(segs.camera, dtype=np.int64), c(segs.observed, dtype=bool), int(n_cameras),
        NO_SINGLE if single is None else c(single, dtype=bool), PlaneRules(MIN_COS, 0.0, PLANE, INTERPOLATED))
    return result(segs.start, W, out)


def result(start: int, W: int, out: tuple) -> WindowTracklets3D:
    """A kernel's (xyz, top_z, bottom_z, valid, source, n_views, members) as 3D tracklets."""
    xyz, top, bottom, valid, source, n_views, members = out
    return WindowTracklets3D(start, xyz, top, bottom, valid, source, n_views, members,
                             np.full(len(members), -1, np.int64))


# ============================================================ numpy references (the replaced code)
def candidates_numpy(segs, rig, planes):
    """(3, P, K, W, 3) centre / top / bottom candidates and (3, P, K, W) status codes, with the
    geometry module's intersect_rays_plane (Eq. 7) on the rays of ray_directions (Eq. 5-6)."""
    K = len(segs)
    P = len(planes)
    X = np.empty((3, P, K, segs.width, 3))
    status = np.empty((3, P, K, segs.width), np.int8)
    origins = rig.centres[segs.camera][:, None, :]
    centre_dirs = ray_directions(rig, segs.camera, segs.points("centre"))
    for q, which in enumerate(("centre", "top", "bottom")):
        dirs = ray_directions(rig, segs.camera, segs.points(which))
        for p, plane in enumerate(planes):
            if q == 0 or abs(plane.normal[2]) < 0.5:
                X[q, p], status[q, p] = intersect_rays_plane(origins, dirs, plane)
                continue
            # a support surface: top / bottom on the vertical plane through the centre candidate,
            # facing the camera (normal: the centre ray's horizontal part), one plane per point
            for k in range(K):
                for t in range(segs.width):
                    h = centre_dirs[k, t] * [1.0, 1.0, 0.0]
                    if not (np.isfinite(X[0, p, k, t]).all() and np.linalg.norm(h) > 0):
                        X[q, p, k, t], status[q, p, k, t] = np.nan, RayPlaneStatus.PARALLEL
                        continue
                    X[q, p, k, t], status[q, p, k, t] = intersect_rays_plane(origins[k, 0], dirs[k, t],
                                                                             Plane(X[0, p, k, t], h))
    return X, status


def candidate_distances_numpy(X, observed, camera, exists):
    ok = observed[None] & exists
    shared = ok[:, :, None] & ok[:, None, :]
    diff = X[:, :, None] - X[:, None, :]
    d = np.sqrt(np.einsum("pijtk,pijtk->pijt", diff, diff))
    with np.errstate(invalid="ignore", divide="ignore"):
        D = np.where(shared, d, 0.0).sum(axis=-1) / shared.sum(axis=-1)
    D[:, camera[:, None] == camera[None, :]] = np.inf
    return D


def best_plane_distance_numpy(Dp):
    if Dp.shape[0] == 1:
        return Dp[0].copy()
    with np.errstate(all="ignore"):
        known = ~np.isnan(Dp)
        D = np.where(known, Dp, np.inf).min(axis=0)
    D[~known.any(axis=0)] = np.nan
    return D


def fuse_on_planes_numpy(segs, cand, Dp, labels, n_cameras, single=None, exists=None):
    members = cluster_members(labels, segs.camera, n_cameras)
    count = (members >= 0).sum(axis=1)
    keep = count >= 2
    if single is not None:
        keep |= (count == 1) & single[np.max(members, axis=1)]
    members = members[keep]
    M = len(members)
    if M == 0:
        return WindowTracklets3D.empty(segs.start, segs.width, n_cameras)
    has = members >= 0
    idx = np.where(has, members, 0)
    if Dp.shape[0] == 1:
        plane = np.zeros(M, np.int64)
    else:
        pair = has[:, :, None] & has[:, None, :] & ~np.eye(n_cameras, dtype=bool)
        d = Dp[:, idx[:, :, None], idx[:, None, :]]
        use = pair[None] & np.isfinite(d)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(use, d, 0.0).sum(axis=(2, 3)) / use.sum(axis=(2, 3))
        mean[np.isnan(mean)] = np.inf
        plane = np.argmin(mean, axis=0)
    c = cand[:, plane[:, None], idx]
    exists = np.all(np.isfinite(c), axis=-1) if exists is None else exists[:, plane[:, None], idx]
    ok = has[None, :, :, None] & exists
    with np.errstate(invalid="ignore", divide="ignore"):
        fused = np.where(ok[..., None], c, 0.0).sum(axis=2) / ok.sum(axis=2)[..., None]
    valid = ok[0].any(axis=1)
    fused[:, ~valid] = np.nan
    n_views = (segs.observed[idx] & has[..., None] & ok[0]).sum(axis=1).astype(np.int8)
    return WindowTracklets3D(segs.start, fused[0], fused[1][..., 2], fused[2][..., 2], valid,
                             source_for(n_views, PLANE), n_views, members, np.full(M, -1, np.int64))


def plane_stage_numpy(segs, rig, planes, threshold, labels=None, apart=None, single=None):
    K = len(segs)
    C = len(rig)
    any_single = single is not None and bool(single.any())
    if (K < 2 and not any_single) or not planes:
        return WindowTracklets3D.empty(segs.start, segs.width, C)
    cand, status = candidates_numpy(segs, rig, planes)
    exists = status == RayPlaneStatus.OK
    Dp = candidate_distances_numpy(cand[0], segs.observed, segs.camera, exists[0])
    D = best_plane_distance_numpy(Dp)
    if labels is not None:
        D = np.where(labels[:, None] == labels[None, :], D, np.inf)
    if apart is not None:
        D = np.where(apart, np.inf, D)
    with np.errstate(invalid="ignore"):
        agree = bool(np.any(D < threshold))
    if not agree and not any_single:
        return WindowTracklets3D.empty(segs.start, segs.width, C)
    labels = complete_linkage_sequential(D, threshold) if agree else np.arange(K)
    return fuse_on_planes_numpy(segs, cand, Dp, labels, C, single, exists)


def plane_split_numpy(segs, to_plane, D2, rig, planes, params, oracle, prev_2d, prev_seen, tracking_space,
                      performance_space, counts, at_mean=True):
    """The plane stage as the tracker ran it around the stage: segments taken out, Eq. 2's
    separations, oracle ids, the one-view continuation, the stage, Eq. 4 (cascade+: by place),
    members to the window's segments, one-view tracklets only inside S_perf (cascade+: when
    ``performance_space`` is given)."""
    from reference.reconstruct import outliers_at_mean_numpy, outliers_numpy

    sub = segs.subset(to_plane)
    labels = np.unique(sub.track2d // len(rig), return_inverse=True)[1] if oracle else None
    apart = None if D2 is None else D2[np.ix_(to_plane, to_plane)] >= params.cluster_2d
    single = np.isin(sub.track2d, prev_2d) | ~np.isin(sub.track2d, prev_seen)
    pl = plane_stage_numpy(sub, rig, planes, params.cluster_plane, labels, apart, single)
    counts["segments_to_plane"] += len(to_plane)
    if not len(pl):
        return None
    bad = (outliers_at_mean_numpy if at_mean else outliers_numpy)(pl.xyz, pl.valid, tracking_space, params.max_speed)
    if bad.any():
        counts["tracklets_outliers"] += int(bad.sum())
        pl = pl.subset(~bad)
    pl = pl.with_members(np.where(pl.members >= 0, to_plane[np.maximum(pl.members, 0)], -1))
    if performance_space is None:  # the paper's cascade: no one-view S_perf test
        counts["plane_tracklets"] += len(pl)
        return pl
    s = performance_space
    with np.errstate(invalid="ignore"):
        x, y = pl.xyz[..., 0], pl.xyz[..., 1]
        out = pl.valid & ~((x >= s[0]) & (x <= s[3]) & (y >= s[1]) & (y <= s[4]))
    drop = ((pl.members >= 0).sum(1) == 1) & out.any(1)
    if drop.any():
        counts["plane_single_view_outside"] += int(drop.sum())
        pl = pl.subset(~drop)
    counts["plane_tracklets"] += len(pl)
    return pl
