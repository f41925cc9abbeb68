"""The cascade's second stage: 3D candidates on the vertical plane (paper Section III-C, Eq. 5-9).

Segments the triangulation stage could not use -- clusters of a single tracklet, or of just
two tracklets from opposite views -- are each projected onto the scene's vertical plane: the
ray through every box centre (Eq. 5-6, :func:`gymtrack.geometry.primitives.ray_direction`, the
rays of :meth:`Camera.rays`) is intersected with the plane (Eq. 7,
:func:`gymtrack.geometry.primitives.ray_plane`, as in :func:`gymtrack.geometry.plane.intersect_rays_plane`),
giving one 3D tracklet candidate per segment. Candidates of different views are matched with Algorithm 1 on their
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

The tracker runs this stage through :func:`plane_split`: the same stage with its tracker-side
steps (Eq. 2's separations, the one-view continuation, Eq. 4; beyond the paper, as the recipe
says: Eq. 4's space test on the mean and the one-view tracklets' performance-space test) in the same
compiled call.

Speed: a window hands this stage a few segments, where numpy's per-call overhead dominated,
so :func:`plane_stage` is one compiled call (:func:`._kernels.plane.plane_stage`: candidates of
all segments, points and planes, Eq. 8, Algorithm 1, Eq. 9). The kernel's steps one at a time
and their numpy references are in ``tests/reference/plane.py``.
"""

from __future__ import annotations

from functools import lru_cache
from typing import Sequence

import numpy as np

from ..geometry.arrays import PlaneArrays, RigArrays
from ..geometry.camera import Rig
from ..geometry.plane import Plane
from ._kernels.plane import NO_APART, NO_GROUP, NO_SINGLE, PlaneConstraints, PlaneRules
from ._kernels.plane import plane_split as plane_split_kernel
from ._kernels.plane import plane_stage as plane_stage_kernel
from .types import INTERPOLATED, PLANE, WindowTracklets, WindowTracklets3D

MIN_COS = 1e-3  #: rays with |cos| to the plane normal below this are parallel (as intersect_rays_plane)


def plane_stage(
    segs: WindowTracklets,
    rig: Rig | RigArrays,
    planes: Sequence[Plane] | PlaneArrays,
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
    arrays = rig if isinstance(rig, RigArrays) else rig.arrays
    planes = PlaneArrays.from_planes(planes)
    C = len(arrays.K)
    if not len(planes.point) or K == 0 or (K == 1 and (single is None or not single[0])):
        return WindowTracklets3D.empty(segs.start, W, C)
    # candidates, Eq. 8 on every plane, Algorithm 1 and Eq. 9 in one compiled call: a window
    # hands a few segments here, where numpy's per-call overhead would dominate
    c = np.ascontiguousarray
    constraints = PlaneConstraints(NO_GROUP if labels is None else c(labels, dtype=np.int64),
                                   NO_APART if apart is None else c(apart, dtype=bool),
                                   NO_SINGLE if single is None else c(single, dtype=bool))
    xyz, top, bottom, valid, source, n_views, members = plane_stage_kernel(
        c(segs.box, dtype=np.float64), c(segs.observed, dtype=bool), c(segs.camera, dtype=np.int64), arrays, planes,
        constraints, PlaneRules(MIN_COS, float(threshold), PLANE, INTERPOLATED))
    return WindowTracklets3D(segs.start, xyz, top, bottom, valid, source, n_views, members,
                             np.full(len(members), -1, np.int64))


_NO_D2 = np.zeros((0, 0))


_NO_SPACE = np.zeros(0)  # plane_split without the one-view S_perf test (the paper's cascade)


@lru_cache(maxsize=8)
def _rules(threshold: float) -> PlaneRules:  # (one per threshold: built once, not per window)
    return PlaneRules(MIN_COS, threshold, PLANE, INTERPOLATED)


def plane_split(segs: WindowTracklets, to_plane: np.ndarray, D2: np.ndarray | None, rig: RigArrays,
                planes: PlaneArrays, params, oracle: bool, prev_2d: np.ndarray, prev_seen: np.ndarray,
                tracking_space: np.ndarray, performance_space: np.ndarray | None, counts: dict,
                at_mean: bool = True, groups: np.ndarray | None = None) -> WindowTracklets3D | None:
    """The tracker's plane stage for the segments ``to_plane`` (indices into ``segs``), one
    kernel call (:func:`._kernels.plane.plane_split`) doing what the tracker did around
    :func:`plane_stage`: segments Eq. 2 separates (``D2 >= cluster_2d``) or an oracle's ids
    (``oracle``: ``track2d // C``) tell apart are not fused; a view left alone may continue its 2D
    track's 3D track when that 2D track was a member of the previous window's tracklets
    (``prev_2d``) or is new (not among ``prev_seen``); Eq. 4 in ``tracking_space``
    (:func:`.reconstruct.outliers`; ``at_mean``: the space test on the mean, :func:`.reconstruct.outliers_at_mean`);
    ``performance_space`` given (the recipe's ``solo_inside``): a one-view tracklet is kept only while its points
    stay inside it. Returns the plane tracklets (``members`` index
    ``segs``), None when the stage fused nothing; counts as the numpy path counts them."""
    C = len(rig.K)
    xyz, top, bottom, valid, source, n_views, members, stats = plane_split_kernel(
        segs.box, segs.observed, segs.camera, segs.track2d, to_plane, _NO_D2 if D2 is None else D2,
        float(params.cluster_2d), segs.track2d // C if oracle else (NO_GROUP if groups is None else groups), prev_2d, prev_seen, rig, planes,
        _rules(float(params.cluster_plane)), tracking_space, float(params.max_speed), bool(at_mean),
        _NO_SPACE if performance_space is None else performance_space)
    fused, n_outliers, n_outside = stats.tolist()
    counts["segments_to_plane"] += len(to_plane)
    if not fused:
        return None
    if n_outliers:
        counts["tracklets_outliers"] += n_outliers
    if n_outside:
        counts["plane_single_view_outside"] += n_outside
    counts["plane_tracklets"] += len(members)
    return WindowTracklets3D(segs.start, xyz, top, bottom, valid, source, n_views, members,
                             np.full(len(members), -1, np.int64))
