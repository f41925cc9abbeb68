"""3D tracklets by triangulation, and the outlier test (paper Section III-B, Eq. 3-4).

A cluster of 2D segments (at most one per view) is triangulated frame by frame from the views
whose segment is valid at that frame (Eq. 3, the arithmetic of
:func:`gymtrack.geometry.triangulation.triangulate_views` compiled per point as
:func:`gymtrack.geometry.primitives.triangulate_points`: one call for the centres, box tops and
box bottoms of every cluster and frame of a window). The box top-centre and bottom-centre
points give the heights of the body's top and bottom (used to identify the target, Eq. 13).

The cascade (Section III-C) needs to know which two-view clusters are "opposite": their lines
of sight meet at more than ``opposite_angle_deg``. The angle is judged once per camera pair at
the centre of the performance space (:func:`gymtrack.geometry.views.opposite_pairs`), where the
target gymnast is: a table lookup per cluster, decided before anything is triangulated, so the
cascade never triangulates a pair it then discards. (At a person far from the centre the
real angle differs, but such people are not the target, and a wrong call only moves them
between two estimates of their position.)

Eq. 4: a 3D tracklet is an outlier, and removed whole, when any of its points lies outside
the tracking space or it moves more than ``max_speed`` metres per frame between consecutive
valid points (over a gap of g frames the allowance is g x max_speed).
"""

from __future__ import annotations

import numpy as np

from ..geometry.primitives import triangulate_points
from ._kernels import reconstruct as kernels
from .types import INTERPOLATED, PLANE, TRIANGULATION, WindowTracklets, WindowTracklets3D


#: Gauss-Newton steps after the DLT (Eq. 3). The DLT with normalised rows is already close to
#: the reprojection optimum; one step brings it to within about a millimetre (two: about a
#: micrometre), far below what detector noise allows, at half the cost of two steps.
GN_ITERATIONS = 1


def cluster_members(labels: np.ndarray, camera: np.ndarray, n_cameras: int) -> np.ndarray:
    """(K,) cluster labels (0..M-1, at most one segment per camera per cluster), (K,) cameras
    -> (M, C) segment index per cluster and camera, -1 where the camera has none."""
    labels = np.asarray(labels)
    M = int(labels.max()) + 1 if len(labels) else 0
    members = np.full((M, n_cameras), -1, np.int64)
    members[labels, camera] = np.arange(len(labels))
    return members


def observed_views(segs: WindowTracklets, members: np.ndarray) -> np.ndarray:
    """(M, W) int8: how many members of each cluster were observed at each frame."""
    has = members >= 0
    obs = segs.observed[np.where(has, members, 0)] & has[..., None]  # (M, C, W)
    return obs.sum(axis=1).astype(np.int8)


def triangulate_clusters(segs: WindowTracklets, members: np.ndarray, P: np.ndarray) -> WindowTracklets3D:
    """Eq. 3 for every cluster and frame of a window, in one batched call.

    segs: the window's segments; members: (M, C) from :func:`cluster_members`; P: (C, 3, 4)
    projection matrices (undistorted pixels). Frames with fewer than two valid views are not
    valid. Returns M 3D tracklets (``track_id`` -1), source triangulation (interpolated where
    no member was observed).
    """
    M, C = members.shape
    W = segs.width
    if M == 0:
        return WindowTracklets3D.empty(segs.start, W, C)
    # pixels and observed-view counts gathered, then every point triangulated, in compiled loops
    # (the same Eq. 3 arithmetic as geometry.triangulation.triangulate_views, one point at a time)
    u, v, n_views = kernels.cluster_points(_contiguous(segs.box), np.ascontiguousarray(segs.observed),
                                          np.ascontiguousarray(members, dtype=np.int64))
    X, _ = triangulate_points(_contiguous(P), u, v, np.isfinite(u), GN_ITERATIONS)  # NaN = view absent
    X = X.reshape(3, 3, M, W)  # (xyz, point, M, W)
    centre = np.ascontiguousarray(X[:, 0].transpose(1, 2, 0))  # (M, W, 3)
    valid = np.isfinite(centre).all(axis=2)
    source = np.where(n_views > 0, TRIANGULATION, INTERPOLATED).astype(np.int8)
    return WindowTracklets3D(
        segs.start, centre, X[2, 1], X[2, 2], valid, source, n_views, members, np.full(M, -1, np.int64)
    )


def opposite_clusters(members: np.ndarray, opposite: np.ndarray) -> np.ndarray:
    """Which clusters are exactly two views seeing the person from opposite sides.

    members: (M, C) segment per cluster and camera (-1: none); opposite: (C, C) bool table of
    opposite camera pairs (:func:`gymtrack.geometry.views.opposite_pairs`). Returns (M,) bool.
    One compiled pass (:func:`._kernels.reconstruct.opposite_clusters`; the numpy bit-mask
    table it replaced: ``tests/reference/reconstruct.py``).
    """
    return kernels.opposite_clusters(np.ascontiguousarray(members, np.int64), np.ascontiguousarray(opposite, bool))


def fallback_segments(members: np.ndarray, fallback: np.ndarray) -> np.ndarray:
    """The cascade's (III-C) segments for the plane: those of the clusters ``fallback`` (M,) bool
    (members (M, C), -1: none), sorted. One compiled pass."""
    return kernels.segments_of(np.ascontiguousarray(members, np.int64), np.ascontiguousarray(fallback, bool))


def outliers(xyz: np.ndarray, valid: np.ndarray, space: np.ndarray, max_speed: float) -> np.ndarray:
    """Eq. 4 for M 3D tracklets of a window.

    xyz: (M, W, 3); valid: (M, W); space: (6,) tracking space ``[xmin, ymin, zmin, xmax, ymax, zmax]``;
    max_speed: metres per frame. Returns (M,) bool, True = outlier (also when nothing is valid).
    """
    M, W = valid.shape
    if M == 0:
        return np.zeros(0, bool)
    return kernels.outliers(_contiguous(xyz), np.ascontiguousarray(valid), _contiguous(space), float(max_speed))


def outliers_at_mean(xyz: np.ndarray, valid: np.ndarray, space: np.ndarray, max_speed: float) -> np.ndarray:
    """``cascade+`` (beyond the paper): Eq. 4 with the tracking-space test on the
    tracklet's mean position over its valid frames instead of on every point.

    Eq. 4 drops a tracklet when any one point leaves ``S_track``; a person standing near its
    boundary (a coach beside the apparatus) then flickers in and out with the estimate's noise,
    and every flicker is a missed window and a broken track. The mean over the window is the
    tracklet's place; a point's noise does not decide it. Trade: a tracklet that really crosses
    the boundary within the window is kept (or dropped) whole by where it mostly is. The
    velocity test is Eq. 4's. Same arguments and result as :func:`outliers`.
    """
    M, W = valid.shape
    if M == 0:
        return np.zeros(0, bool)
    return kernels.outliers_at_mean(_contiguous(xyz), np.ascontiguousarray(valid), _contiguous(space),
                                     float(max_speed))  # one compiled loop (numpy: tests/reference)


def _contiguous(a: np.ndarray) -> np.ndarray:
    """float64, C order: the layout the compiled kernels are built for."""
    return np.ascontiguousarray(a, dtype=np.float64)


def source_for(n_views: np.ndarray, code: int) -> np.ndarray:
    """(M, W) observed-view counts -> (M, W) int8 source: ``code`` or interpolated when 0 views."""
    return np.where(n_views > 0, code, INTERPOLATED).astype(np.int8)


__all__ = [
    "cluster_members", "observed_views", "triangulate_clusters", "opposite_clusters", "fallback_segments", "outliers",
    "outliers_at_mean", "source_for", "PLANE", "TRIANGULATION",
]
