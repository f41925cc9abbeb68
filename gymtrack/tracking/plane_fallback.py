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

Speed: a window hands this stage a few segments, where numpy's per-call overhead dominated,
so :func:`plane_stage` is one compiled call (:func:`._compiled.plane_stage`: candidates of all
segments, points and planes, Eq. 8, Algorithm 1, Eq. 9); the other functions here are the same
kernels one step at a time. Their numpy references are in ``tests/test_plane_compiled.py``.
"""

from __future__ import annotations

import numpy as np

from ..geometry.camera import Rig
from ..geometry.plane import Plane
from . import _compiled
from .types import INTERPOLATED, PLANE, WindowTracklets, WindowTracklets3D


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
    c = np.ascontiguousarray
    value = (c(np.swapaxes(Rs, 1, 2) @ np.linalg.inv(Ks), dtype=np.float64), c(rig.centres, dtype=np.float64))
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
    X = _candidates(segs, rig, planes)[0]
    return X[[_POINTS.index(w) for w in which]]


_POINTS = ("centre", "top", "bottom")
MIN_COS = 1e-3  #: rays with |cos| to the plane normal below this are parallel (as intersect_rays_plane)


def _candidates(segs: WindowTracklets, rig: Rig, planes: list[Plane]) -> tuple:
    """(3, P, K, W, 3) centre, top and bottom candidates of :func:`plane_candidates` and
    (3, P, K, W) bool, where the intersection exists: one compiled call
    (:func:`._compiled.plane_candidates`, the arithmetic of
    :func:`gymtrack.geometry.plane.intersect_rays_plane`)."""
    back, centres = _back_projection(rig)
    point, normal = _plane_arrays(planes)
    c = np.ascontiguousarray
    return _compiled.plane_candidates(c(segs.box, dtype=np.float64), c(segs.camera, dtype=np.int64), back, centres,
                                      point, normal, MIN_COS)


_PLANES: dict[int, tuple] = {}


def _plane_arrays(planes: list[Plane]) -> tuple[np.ndarray, np.ndarray]:
    """(P, 3) points and (P, 3) unit normals of the planes, cached per list of plane objects."""
    key = tuple(planes)
    hit = _PLANES.get(id(planes))
    if hit is not None and hit[0] == key:  # Plane compares by identity
        return hit[1]
    value = (np.array([pl.point for pl in planes], np.float64).reshape(-1, 3),
             np.array([pl.normal for pl in planes], np.float64).reshape(-1, 3))
    if len(_PLANES) > 16:
        _PLANES.clear()
    _PLANES[id(planes)] = (key, value)
    return value


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
    return _compiled.best_plane_distance(np.ascontiguousarray(Dp, dtype=np.float64))


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
    out = _compiled.fuse_on_planes(
        c(cand, dtype=np.float64), c(exists, dtype=bool), c(Dp, dtype=np.float64), c(labels, dtype=np.int64),
        c(segs.camera, dtype=np.int64), c(segs.observed, dtype=bool), int(n_cameras),
        _NO_SINGLE if single is None else c(single, dtype=bool), PLANE, INTERPOLATED)
    return _result(segs.start, W, out)


def _result(start: int, W: int, out: tuple) -> WindowTracklets3D:
    """A kernel's (xyz, top_z, bottom_z, valid, source, n_views, members) as 3D tracklets."""
    xyz, top, bottom, valid, source, n_views, members = out
    return WindowTracklets3D(start, xyz, top, bottom, valid, source, n_views, members,
                             np.full(len(members), -1, np.int64))


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
    if not planes or K == 0 or (K == 1 and (single is None or not single[0])):
        return WindowTracklets3D.empty(segs.start, W, C)
    # candidates, Eq. 8 on every plane, Algorithm 1 and Eq. 9 in one compiled call: a window
    # hands a few segments here, where numpy's per-call overhead would dominate
    back, centres = _back_projection(rig)
    point, normal = _plane_arrays(planes)
    c = np.ascontiguousarray
    out = _compiled.plane_stage(
        c(segs.box, dtype=np.float64), c(segs.observed, dtype=bool), c(segs.camera, dtype=np.int64), back, centres,
        point, normal, MIN_COS, float(threshold), _NO_GROUP if labels is None else c(labels, dtype=np.int64),
        _NO_APART if apart is None else c(apart, dtype=bool), _NO_SINGLE if single is None else c(single, dtype=bool),
        C, PLANE, INTERPOLATED)
    return _result(segs.start, W, out)


_NO_GROUP = np.zeros(0, np.int64)
_NO_APART = np.zeros((0, 0), bool)
_NO_SINGLE = np.zeros(0, bool)
