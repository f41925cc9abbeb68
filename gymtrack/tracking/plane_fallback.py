"""The cascade's second stage: 3D candidates on the vertical plane (paper Section III-C, Eq. 5-9).

Segments the triangulation stage could not use -- clusters of a single tracklet, or of just
two tracklets from opposite views -- are each projected onto the scene's vertical plane: the
ray through every box centre (Eq. 5-6, :func:`ray_directions`, the rays of :meth:`Camera.rays`
for all segments of a window in one product) is intersected with the plane
(Eq. 7, :func:`gymtrack.geometry.plane.intersect_rays_plane`), giving one 3D tracklet
candidate per segment. Candidates of different views are matched with Algorithm 1 on their
mean 3D distance over shared frames (Eq. 8, threshold ``cluster_plane``); matched candidates
are fused by averaging (Eq. 9); a candidate without a partner from another view is discarded.
The box top-centre and bottom-centre rays, intersected with the same plane, give the heights
of the body's top and bottom.

Several planes: every segment gets a candidate on every plane. Two candidates' distance is the
smallest Eq. 8 distance over the planes; a cluster is fused on the plane that minimises the
mean Eq. 8 distance between its members, so each person goes to the plane that explains the
views best.

Shared frames are frames where both segments were observed (as for Eq. 2, see
:mod:`.clustering`); the fused tracklet covers every frame where a member is valid.
"""

from __future__ import annotations

import numpy as np

from ..geometry.camera import Rig
from ..geometry.plane import Plane
from . import _compiled
from .clustering import complete_linkage
from .reconstruct import cluster_members, source_for
from .types import PLANE, WindowTracklets, WindowTracklets3D


def ray_directions(rig: Rig, camera: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Eq. 6 for many segments at once: world ray directions ``R^T K^-1 [u, v, 1]``.

    camera: (K,); uv: (K, n, 2) undistorted pixels of segment k (any n points). Returns (K, n, 3)
    directions (not unit length; the same rays as :meth:`Camera.rays` with ``undistort=False``).
    """
    back = _back_projection(rig)[0]
    h = np.concatenate([uv, np.ones(uv.shape[:-1] + (1,))], axis=-1)  # (K, n, 3)
    return h @ np.swapaxes(back[camera], 1, 2)


_BACK: dict[int, tuple] = {}


def _back_projection(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """(C, 3, 3) ``R^T K^-1`` and (C, 3) camera centres of a rig, cached per rig object."""
    hit = _BACK.get(id(rig))
    if hit is not None and hit[0] is rig:
        return hit[1]
    Ks = np.stack([c.K for c in rig])
    Rs = np.stack([c.R for c in rig])
    value = (np.swapaxes(Rs, 1, 2) @ np.linalg.inv(Ks), rig.centres)
    if len(_BACK) > 16:
        _BACK.clear()
    _BACK[id(rig)] = (rig, value)
    return value


def plane_candidates(
    segs: WindowTracklets, rig: Rig, planes: list[Plane], which: tuple[str, ...] = ("centre", "top", "bottom")
) -> np.ndarray:
    """Eq. 5-7 for every segment, frame and plane.

    which: the box points whose rays are used (``centre``, ``top``-centre, ``bottom``-centre).
    Returns (len(which), P, K, W, 3): the intersections of the rays through those points with
    each plane; NaN where the segment is not valid or the ray misses the plane (parallel, or
    the plane behind the camera).
    """
    return _candidates(segs, rig, planes, which)[0]


def _candidates(segs: WindowTracklets, rig: Rig, planes: list[Plane], which: tuple[str, ...]) -> tuple:
    """:func:`plane_candidates` and (len(which), P, K, W) bool: where the intersection exists."""
    K, W = segs.valid.shape
    P, n = len(planes), len(which)
    out = np.empty((n, P, K, W, 3))
    ok = np.zeros((n, P, K, W), bool)
    if K == 0:
        return out, ok
    pts = np.concatenate([segs.points(w) for w in which], axis=1) if n > 1 else segs.points(which[0])  # (K, nW, 2)
    dirs = ray_directions(rig, segs.camera, pts)
    origins = _back_projection(rig)[1][segs.camera][:, None, :]  # (K, 1, 3) camera centres X^o
    for p, plane in enumerate(planes):
        X, hit = _intersect(origins, dirs, plane)  # (K, nW, 3), (K, nW)
        out[:, p] = X.reshape(K, n, W, 3).transpose(1, 0, 2, 3)
        ok[:, p] = hit.reshape(K, n, W).transpose(1, 0, 2)
    return out, ok


def _intersect(origins: np.ndarray, directions: np.ndarray, plane: Plane, min_cos: float = 1e-3) -> tuple:
    """The points of :func:`gymtrack.geometry.plane.intersect_rays_plane` (NaN where its status is
    not OK) and where they exist, without the status codes: the same arithmetic, so the same
    bits, in fewer numpy calls on these small arrays.

    origins: (K, 1, 3), one per segment; directions: (K, n, 3). Returns (X (K, n, 3), ok (K, n)).
    """
    d = directions
    dn = (d.reshape(-1, 3) @ plane.normal).reshape(d.shape[:-1])  # one product, not one per segment
    dlen = np.linalg.norm(d, axis=-1)
    # written negated so that zero-length and NaN directions count as parallel (no intersection)
    parallel = ~(np.abs(dn) >= min_cos * dlen) | ~(dlen > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        lam = ((plane.point - origins[:, 0]) @ plane.normal)[:, None] / dn  # one origin per segment
        X = origins + lam[..., None] * d  # inf * 0 for exactly parallel rays: masked below
    ok = ~(parallel | ~(lam > 0))  # not parallel, plane in front of the camera
    X[~ok] = np.nan
    return X, ok


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
    return _compiled.candidate_distances(c(X, dtype=np.float64), c(observed), c(camera, dtype=np.int64),
                                         c(exists))  # pairs x frames x planes: a compiled loop


def best_plane_distance(Dp: np.ndarray) -> np.ndarray:
    """(P, K, K) -> (K, K): the smallest known distance over the planes (NaN if none known)."""
    if Dp.shape[0] == 1:
        return Dp[0]
    with np.errstate(all="ignore"):
        known = ~np.isnan(Dp)
        D = np.where(known, Dp, np.inf).min(axis=0)
    D[~known.any(axis=0)] = np.nan
    return D


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
    K, W = segs.valid.shape
    members = cluster_members(labels, segs.camera, n_cameras)
    count = (members >= 0).sum(axis=1)
    keep = count >= 2
    if single is not None:
        keep |= (count == 1) & single[np.max(members, axis=1)]
    members = members[keep]
    M = len(members)
    if M == 0:
        return WindowTracklets3D.empty(segs.start, W, n_cameras)
    has = members >= 0
    idx = np.where(has, members, 0)
    if Dp.shape[0] == 1:  # one plane: nothing to choose
        plane = np.zeros(M, np.int64)
    else:  # the plane minimising the mean pairwise distance of the cluster's members
        pair = has[:, :, None] & has[:, None, :] & ~np.eye(n_cameras, dtype=bool)  # (M, C, C)
        d = Dp[:, idx[:, :, None], idx[:, None, :]]  # (P, M, C, C)
        use = pair[None] & np.isfinite(d)
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(use, d, 0.0).sum(axis=(2, 3)) / use.sum(axis=(2, 3))
        mean[np.isnan(mean)] = np.inf
        plane = np.argmin(mean, axis=0)  # (M,)
    c = cand[:, plane[:, None], idx]  # (3, M, C, W, 3)
    exists = np.all(np.isfinite(c), axis=-1) if exists is None else exists[:, plane[:, None], idx]
    ok = has[None, :, :, None] & exists  # (3, M, C, W)
    with np.errstate(invalid="ignore", divide="ignore"):
        fused = np.where(ok[..., None], c, 0.0).sum(axis=2) / ok.sum(axis=2)[..., None]  # (3, M, W, 3)
    valid = ok[0].any(axis=1)
    fused[:, ~valid] = np.nan
    n_views = (segs.observed[idx] & has[..., None] & ok[0]).sum(axis=1).astype(np.int8)
    return WindowTracklets3D(
        segs.start, fused[0], fused[1][..., 2], fused[2][..., 2], valid, source_for(n_views, PLANE), n_views,
        members, np.full(M, -1, np.int64),
    )


def plane_stage(
    segs: WindowTracklets,
    rig: Rig,
    planes: list[Plane],
    threshold: float,
    labels: np.ndarray | None = None,
    apart: np.ndarray | None = None,
    single: np.ndarray | None = None,
) -> WindowTracklets3D:
    """The whole plane fallback for the segments handed to it.

    threshold: Algorithm 1 threshold on Eq. 8 (metres, paper: 0.5): higher fuses people who
    stand off the plane (their candidates from two views disagree by about their distance to
    the plane times a geometry factor), lower splits the gymnast when detections are noisy.
    labels: (K,) person ids given by an oracle: candidates of different ids are never matched
        (the plane's own test, Eq. 8 below ``threshold``, still applies); None = no constraint.
    apart: (K, K) bool, pairs known to be different people (e.g. their Eq. 2 epipolar distance
        is at least the 2D clustering threshold): never matched; None = no constraint.
    single: (K,) bool, segments kept as one-view plane tracklets when no other view matches
        them (the paper discards every unmatched candidate; the tracker allows it only for a
        2D track that already belongs to a 3D track, and keeps the result only if it links).
    Returns the fused 3D tracklets (before the outlier test); ``members`` index ``segs``.
    """
    K, W = segs.valid.shape
    C = len(rig)
    any_single = single is not None and bool(single.any())
    if (K < 2 and not any_single) or not planes:
        return WindowTracklets3D.empty(segs.start, W, C)
    if not any_single:
        # the pairs Eq. 8 could match: other view, not known apart (nor of different oracle
        # ids), a frame both observed; without any, nothing is fused: skip the geometry
        obs = segs.observed.astype(np.float64)
        possible = (segs.camera[:, None] != segs.camera[None, :]) & ((obs @ obs.T) > 0)
        if labels is not None:
            possible &= labels[:, None] == labels[None, :]
        if apart is not None:
            possible &= ~apart
        if not possible.any():
            return WindowTracklets3D.empty(segs.start, W, C)
    # the centre candidates decide whether anything is fused; the top and bottom ones only then
    centre, exists = _candidates(segs, rig, planes, ("centre",))
    Dp = candidate_distances(centre[0], segs.observed, segs.camera, exists[0])
    D = best_plane_distance(Dp)
    if labels is not None:
        D = np.where(labels[:, None] == labels[None, :], D, np.inf)
    if apart is not None:
        D = np.where(apart, np.inf, D)
    with np.errstate(invalid="ignore"):
        agree = bool(np.any(D < threshold))
    if not agree and not any_single:  # no two views agree: every candidate is discarded
        return WindowTracklets3D.empty(segs.start, W, C)
    labels = complete_linkage(D, threshold) if agree else np.arange(K)
    rest, rest_exists = _candidates(segs, rig, planes, ("top", "bottom"))
    cand, exists = np.concatenate([centre, rest]), np.concatenate([exists, rest_exists])
    return fuse_on_planes(segs, cand, Dp, labels, C, single, exists)
