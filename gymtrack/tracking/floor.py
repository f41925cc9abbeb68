"""The floor hypothesis of ``cascade+``: people standing on the floor (beyond the paper).

The paper's cascade (Section III-C, Eq. 5-9) puts every segment triangulation could not use on
the apparatus' vertical plane, which is right for the gymnast but wrong for coaches, judges and
passers-by, who stand on the floor off that plane. Multi-view pedestrian tracking maps them by
the ground plane instead: the ray through a box's bottom-centre point (the feet, Eq. 5-6) meets
the floor z = 0 (Eq. 7 with the floor as the plane) at the person's ground position, and the
ray through the top-centre point, followed to that position's vertical line, gives the body's
height. Each segment gets such a *floor candidate*:

* ``foot`` (K, W, 2) ground position, ``height`` (K, W) body top, metres;
* a candidate is *plausible* where the bottom ray points down and the height is a body's
  (``MIN_HEIGHT`` .. ``MAX_HEIGHT``).

Candidates of different views are matched like the plane candidates: Eq. 8 on the ground
positions (mean horizontal distance over shared observed frames), Algorithm 1 with the plane
threshold, Eq. 9 averaging. A cluster of two or more views whose ground positions agree is a
person on the floor (views of someone whose feet leave the floor do not agree on the floor: the
bottom rays pass above it at different places). A segment no other view matches is on the floor
too when its ground position lies outside the performance space (nobody off the apparatus'
space has their feet in the air), else it stays for the apparatus plane. So a floor-standing
person is never put on the apparatus plane when the views, or the place, say so; the target,
inside the performance space and in the air, keeps the plane. Like a one-view plane tracklet,
a one-view floor tracklet may only continue a track, never start one (the tracker's link step):
one view cannot tell a person from a clutter box, whose foot ray meets the floor as well. Trade:
someone only one view ever sees (a spectator along the vault's runway at n_cam = 4) is not
tracked; a measured net gain of about 0.05 MOTA on the simulated suite.

Output: :class:`~.types.WindowTracklets3D` with ``xyz`` the body centre above the ground
position (half the height), ``top_z`` the height, ``bottom_z`` 0, source ``PLANE`` (a
ray-plane intersection) where observed.

:func:`floor_stage` and the ghost test of :func:`drop_floor_ghosts` are one compiled call each
(:mod:`._kernels.floor`; the numpy code they replaced is ``tests/reference/floor.py``).
"""

from __future__ import annotations

from functools import lru_cache

import numpy as np

from ..geometry.arrays import PlaneArrays, RigArrays
from ._kernels import floor as kernels
from .plane_fallback import MIN_COS
from .types import INTERPOLATED, PLANE, WindowTracklets, WindowTracklets3D

MIN_HEIGHT, MAX_HEIGHT = 0.7, 2.4  #: metres: a seated to a tall standing person's top (floor candidates)
MIN_DOWN = 1e-3  #: the bottom ray must point down at least this much (z of the unit direction)


def floor_candidates(segs: WindowTracklets, rig: RigArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Floor candidates of the segments: ``foot`` (K, W, 2), ``height`` (K, W) and
    ``plausible`` (K, W) bool (valid box, bottom ray down, height of a body)."""
    return kernels.floor_candidates(_f64(segs.box), _c(segs.valid), _c(segs.camera, np.int64), rig, _rules(0.0))


@lru_cache(maxsize=8)
def _rules(threshold: float) -> kernels.FloorRules:  # (one per threshold: built once, not per window)
    return kernels.FloorRules(MIN_DOWN, MIN_HEIGHT, MAX_HEIGHT, float(threshold), PLANE, INTERPOLATED)


def _c(a: np.ndarray, dtype=None) -> np.ndarray:
    return np.ascontiguousarray(a, dtype=dtype)


def _space(performance_space) -> np.ndarray:
    """(6,) float64 ``S_perf``, built once per scene (a tuple; any other sequence each call)
    instead of per window; shared: the kernels only read it (writeable, so numba sees the
    type its warm-up compiled)."""
    if isinstance(performance_space, tuple):
        return _space_of(performance_space)
    return np.asarray(performance_space, dtype=np.float64)


@lru_cache(maxsize=16)
def _space_of(performance_space: tuple, buffer: float = 0.0) -> np.ndarray:
    s = np.array(performance_space, dtype=np.float64)
    if buffer:  # S_track, computed as Scene.tracking_space computes it
        s = s + np.array([-buffer, -buffer, 0.0, buffer, buffer, 0.0])
    return s


def _tracking_space(scene) -> np.ndarray:
    """(6,) ``S_track`` of a scene (:attr:`~gymtrack.scene.Scene.tracking_space`), once per scene."""
    ps, buffer = scene.performance_space, getattr(scene, "buffer", None)
    if isinstance(ps, tuple) and isinstance(buffer, (int, float)):
        return _space_of(ps, float(buffer))
    return np.asarray(scene.tracking_space, dtype=np.float64)


def _f64(a: np.ndarray) -> np.ndarray:
    """float64, C order: the layout the compiled kernels are built for."""
    return np.ascontiguousarray(a, dtype=np.float64)


def floor_stage(segs: WindowTracklets, rig: RigArrays, threshold: float, space: np.ndarray,
                apart: np.ndarray | None = None, labels: np.ndarray | None = None,
                ) -> tuple[WindowTracklets3D, np.ndarray]:
    """The floor hypothesis for the segments handed to the plane stage.

    threshold: Algorithm 1 threshold on the floor's Eq. 8 (metres); space: (6,) the performance
    space (x0, y0, z0, x1, y1, z1): a lone segment standing outside it is on the floor.
    apart: (K, K) bool symmetric pairs known to be different people; labels: (K,) oracle person ids.
    Returns the floor tracklets (``members`` index ``segs``) and ``used`` (K,) bool, the
    segments they took (the rest go on to the apparatus plane). One kernel call
    (:func:`._kernels.floor.floor_stage`): candidates, Eq. 8 on the ground positions, Algorithm 1,
    the lone segments' place, Eq. 9.
    """
    return _floor_stage(segs.start, segs.box, segs.valid, segs.observed, segs.camera, rig, threshold, space, apart, labels)


def _floor_stage(start: int, box, valid, observed, camera, rig: RigArrays, threshold: float, space: np.ndarray,
                 apart: np.ndarray | None, labels: np.ndarray | None) -> tuple[WindowTracklets3D, np.ndarray]:
    """:func:`floor_stage` on the segments' arrays (box (K, W, 4), valid, observed (K, W), camera (K,))."""
    K, W = valid.shape
    C = len(rig.K)
    if K == 0:
        return WindowTracklets3D.empty(start, W, C), np.zeros(0, bool)
    xyz, top, bottom, fvalid, source, n_views, members, used = kernels.floor_stage(
        _f64(box), _c(valid), _c(observed), _c(camera, np.int64), rig, _f64(space),
        kernels.NO_APART if apart is None else _c(apart, bool),
        kernels.NO_GROUP if labels is None else _c(labels, np.int64), _rules(threshold))
    if not len(members):
        return WindowTracklets3D.empty(start, W, C), used
    return WindowTracklets3D(start, xyz, top, bottom, fvalid, source, n_views, members,
                             np.full(len(members), -1, np.int64)), used


def floor_split(segs: WindowTracklets, to_plane: np.ndarray, D2: np.ndarray | None, rig: RigArrays, params, scene,
                oracle: bool, counts: dict, floor_only: np.ndarray | None = None, at_mean: bool = True
                ) -> tuple[WindowTracklets3D | None, np.ndarray]:
    """The tracker's hook (the recipe's ``floor``): the floor hypothesis for the segments ``to_plane``
    (sorted indices into ``segs``); Eq. 2's separations (``D2`` (K, K) or None) and an oracle's
    ids (``oracle``: ``track2d // C``) hold here as on the plane. Returns the floor tracklets
    after the outlier test (``members`` index ``segs``; None when none) and the segments left
    for the apparatus plane. ``floor_only``: segments that may go to the floor only (the ghosts'
    of :func:`drop_floor_ghosts`; dropped, and counted, when the floor does not take them).
    ``at_mean``: Eq. 4's space test on the tracklet's mean (else on every point).

    One kernel call (:func:`._kernels.floor.floor_split`: the segments taken out of the
    window's arrays, Eq. 2's separations, :func:`floor_stage`'s kernel and Eq. 4):
    the Python around it cost more than the work (numpy reference: ``tests/reference/floor.py``)."""
    fo = _NO_INDEX if floor_only is None else floor_only
    if not len(to_plane) + len(fo):
        return None, to_plane
    xyz, top, bottom, valid, source, n_views, members, rest, stats = kernels.floor_split(
        segs.box, segs.valid, segs.observed, segs.camera, to_plane, fo, _NO_D2 if D2 is None else D2,
        float(params.cluster_2d), segs.track2d // len(rig.K) if oracle else kernels.NO_GROUP, rig,
        _space(scene.performance_space), _tracking_space(scene), float(params.max_speed), _rules(params.cluster_plane),
        bool(at_mean))
    taken, n_outliers, n_ghost = stats.tolist()
    counts["segments_to_floor"] += taken
    if n_outliers:  # Eq. 4, as for every 3D tracklet
        counts["tracklets_outliers"] += n_outliers
    fl = None
    if len(members):
        fl = WindowTracklets3D(segs.start, xyz, top, bottom, valid, source, n_views, members,
                               np.full(len(members), -1, np.int64))
        counts["floor_tracklets"] += len(fl)
    if n_ghost:
        counts["segments_dropped_ghost"] += n_ghost
    return fl, rest  # (in to_plane's order; the ghosts' are not kept)


_NO_INDEX = np.zeros(0, np.int64)
_NO_D2 = np.zeros((0, 0))


AIR = 0.25  #: metres: a body whose bottom is higher than this has left the floor


def drop_floor_ghosts(tri: WindowTracklets3D | None, segs: WindowTracklets, rig: RigArrays, planes, params, scene,
                      counts: dict, owner=None, outliers: tuple | None = None
                      ) -> tuple[WindowTracklets3D | None, np.ndarray]:
    """``cascade+``: the two-view triangulated clusters the floor says are ghosts (a wrong pair
    of two people's segments triangulates to a short body floating above the floor).

    A cluster of two views whose triangulated bottom is in the air (mean ``bottom_z`` > ``AIR``)
    is a ghost when it lies outside the performance space (off the apparatus nobody's feet leave
    the floor) or when both views' floor candidates are plausible and stand farther apart than
    the plane threshold (each view sees someone standing elsewhere) while their candidates on
    the apparatus planes (Eq. 7-8, ``planes``) disagree too (a gymnast in the air is on them).
    ``owner`` (K,) or a callable giving it: the previous window's 3D track of each segment's 2D
    track (-1: none); a pair
    whose two 2D tracks were both members of one track there is *confirmed* and never a ghost
    (the test is for new, wrong pairings; it also took the target's own pair in the
    air off the apparatus plane, e.g. on the pommel horse). Trade: a wrong pair that survived one
    window keeps surviving while both its 2D tracks last (+4 to +7 % false positives on the
    suite, -0.005 MOTA). ``owner`` may also be the tracker's ``(prev_2d, prev_owner)``: the 2D
    tracks of the previous window's tracklets and their 3D tracks (:class:`~.linking.WindowLinker`).
    ``outliers``: (tracking space (6,), max_speed): Eq. 4 by place first
    (:func:`.reconstruct.outliers_at_mean`, counted in ``tracklets_outliers``; the tracker's
    order), in the same call. Returns the clusters kept
    and the ghosts' segments (indices into ``segs``, for the floor stage only). One kernel call
    (:func:`._kernels.floor.ghost_split`: :func:`._kernels.floor.ghost_test` and the confirmation).
    """
    if tri is None or not len(tri):
        return tri, _NO_INDEX
    if owner is None:
        prev_2d = prev_owner = _NO_INDEX
    elif isinstance(owner, tuple):
        prev_2d, prev_owner = owner
    else:  # (K,) per segment, or a callable giving it
        prev_2d, prev_owner = segs.track2d, np.asarray(owner() if callable(owner) else owner, np.int64)
    tspace, max_speed = (_NO_SPACE, 0.0) if outliers is None else outliers
    drop, pair, stats = kernels.ghost_split(
        tri.members, tri.valid, tri.bottom_z, tri.xyz, segs.box, segs.valid, segs.observed, segs.camera, segs.track2d,
        prev_2d, prev_owner, owner is not None, rig, PlaneArrays.from_planes(planes), _space(scene.performance_space),
        AIR, MIN_COS, _rules(params.cluster_plane), tspace, float(max_speed), outliers is not None)
    n_outliers, any_ghost, confirmed, n = stats.tolist()
    if n_outliers:
        counts["tracklets_outliers"] += n_outliers
    if any_ghost and owner is not None:
        counts["floor_ghosts_confirmed"] += confirmed
    if n:
        counts["floor_ghosts"] += n
    if not n_outliers and not n:  # the usual window: nothing dropped
        return tri, _NO_INDEX
    return tri.subset(~drop), pair


_NO_SPACE = np.zeros(6)


def continuation_only(n: int, tri: WindowTracklets3D | None, floor: WindowTracklets3D | None,
                      plane: WindowTracklets3D | None, counts: dict) -> tuple[np.ndarray, np.ndarray]:
    """Which of a window's ``n`` 3D tracklets (triangulated, then floor, then plane ones, in that
    order) may only continue a track, and which are floor tracklets: (n,) bool each.

    One-view plane tracklets only continue (the paper's cascade keeps them for its one-view
    continuation). ``cascade+``: one view alone does not confirm a person on the floor either (a
    clutter box's foot ray meets the floor too), so a one-view floor tracklet only continues a
    track as well (counted in ``floor_single_view``)."""
    solo = np.zeros(n, bool)
    if plane is not None:
        solo[n - len(plane):] = (plane.members >= 0).sum(axis=1) == 1
    floor_rows = np.zeros(n, bool)
    floor_rows[len(tri or ()):][:len(floor or ())] = True
    if floor is not None:
        one = (floor.members >= 0).sum(axis=1) == 1
        solo[floor_rows] = one
        counts["floor_single_view"] += int(one.sum())
    return solo, floor_rows
