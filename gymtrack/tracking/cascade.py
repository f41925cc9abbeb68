"""The cascaded data association of one window (paper Section III-C; Fig. 2, stages 4-5).

Triangulation where the views suffice, the vertical plane where they do not: a cluster of
Algorithm 1 with two or more views that is not just an opposite pair is triangulated (Eq. 3)
and tested (Eq. 4, :mod:`.reconstruct`); a single tracklet or an opposite pair goes on to the
ray-plane intersection and its matching (Eq. 5-9, :mod:`.plane_fallback`). ``triangulation``
(the recipe's ``plane: none``) drops the single tracklets instead.

Beyond the paper, by the recipe (:class:`gymtrack.modes.Method`): two-view clusters fused with
the plane (:mod:`.fusion`), the floor's ghost test and the floor hypothesis (:mod:`.floor`), a
dropped cluster's opposite pairs regrouped (:mod:`.regroup`), the points handed to the online
plane refinement (:mod:`.plane_refine`).

The stages are functions of the :class:`~.tracker.Tracker` ``t`` (its recipe, parameters and
stages); what one stage leaves for the next within the window (the regrouped segments, the
ghosts' segments for the floor only) is kept on it.
"""

from __future__ import annotations

import numpy as np

from .floor import drop_floor_ghosts, floor_split
from .plane_fallback import plane_split
from .regain import regained_views
from .reconstruct import cluster_members, fallback_segments, opposite_clusters, triangulate_clusters
from .regroup import continuing, gymnast_only, pairs_only, regroup, send_alone, target_lone
from .types import WindowTracklets, WindowTracklets3D

__all__ = ["triangulation_stage", "plane_stage", "drop_outliers"]


def triangulation_stage(t, segs: WindowTracklets, labels: np.ndarray | None, D2: np.ndarray | None = None
                        ) -> tuple[WindowTracklets3D | None, np.ndarray]:
    """Stage 4: triangulation of multi-view clusters, outliers dropped. Returns the 3D
    tracklets (None when nothing was clustered) and the segments for the plane (sorted)."""
    p, C = t.params, t.n_cameras
    if labels is None:
        return None, np.arange(len(segs))
    fused = None
    t._regrouped, t._groups, t._fresh = np.zeros(0, np.int64), None, np.zeros(0, np.int64)
    to_plane = t._floor_only = np.zeros(0, np.int64)
    if not len(segs):
        return None, to_plane
    members = cluster_members(labels, segs.camera, C)
    multi = (members >= 0).sum(axis=1) >= 2
    if t.method.plane == "rest":  # the cascade: single tracklets and opposite pairs go to the plane
        fallback = ~multi | opposite_clusters(members, t.opposite)
        if t.fusion is not None:  # two-view clusters fused with the plane (.fusion)
            fused, fallback, multi = t.fusion.step(segs, members, fallback, multi)
        to_plane = fallback_segments(members, fallback)  # (sorted)
        multi &= ~fallback
    else:
        t.counts["segments_dropped_single"] += int(np.count_nonzero(~multi))
    tri = triangulate_clusters(segs, members[multi], t.P)
    if t.venue.active:
        t._timed("venue", _watch, t, segs, members[multi])
    tri = tri if fused is None else WindowTracklets3D.concat([tri, fused])
    tested = tri.members if t.method.regroup and D2 is not None else None
    if t.method.ghost_test:  # Eq. 4, then the floor's ghost test; a ghost's segments may go to the floor only
        if t._space_mean is None:  # (the paper's Eq. 4 first; by the mean it runs inside the ghost test's call)
            tri = drop_outliers(t, tri)
        tri, t._floor_only = drop_floor_ghosts(tri, segs, t.rig.arrays, t.plane_arrays, p, t.scene, t.counts,
                                               (t.linker.prev_2d, t.linker.prev_owner),
                                               None if t._space_mean is None else (t.space, p.max_speed))
    else:
        tri = drop_outliers(t, tri)
    if tested is not None:  # a dropped cluster's opposite pairs on to the plane (.regroup)
        t._regrouped, t._groups, to_plane, t._floor_only, t._fresh = regroup(
            tested, tri.members, D2, segs.camera, t.opposite, p.cluster_2d, to_plane, t._floor_only, t.counts)
        if t.method.lone:  # the target's own dropped views go on alone, like a pair's lone view
            lone = target_lone(tested, tri.members, t._regrouped, segs.track2d, t.linker.prev_2d, t.linker.prev_owner,
                               t.target.live_track())
            if len(lone):
                t._regrouped, t._groups, to_plane, t._floor_only, t._fresh = send_alone(
                    lone, len(segs), t._regrouped, t._groups, to_plane, t._floor_only, t._fresh, t.counts)
    if t.refiner is not None:  # the plane's points: what passed the tests, and the opposite pairs
        t.refiner.observe(segs, tri, members[fallback & ((members >= 0).sum(axis=1) >= 2)])
    t.counts["clusters_triangulated"] += len(tri)
    return tri, to_plane


def drop_outliers(t, tr: WindowTracklets3D) -> WindowTracklets3D:
    """Eq. 4 (the recipe's space test) in ``S_track``; the outliers counted and left out."""
    bad = t._outliers(tr.xyz, tr.valid, t.space, t.params.max_speed)
    if bad.any():
        t.counts["tracklets_outliers"] += int(bad.sum())
        tr = tr.subset(~bad)
    return tr


def _watch(t, segs: WindowTracklets, members: np.ndarray) -> None:
    """The venue check's share of the window (:mod:`.drift`): the clusters' residuals, leaving out the
    boxes the image's edge cuts (their centre is not the person's)."""
    t.venue.observe(segs.start, segs.box, segs.observed & ~t.table.cut(segs.det), members)


def plane_stage(t, segs: WindowTracklets, to_plane: np.ndarray, D2: np.ndarray | None
                ) -> tuple[WindowTracklets3D | None, WindowTracklets3D | None]:
    """Stage 5: the segments ``to_plane`` on the vertical plane (Eq. 5-9), outliers dropped;
    ``members`` index ``segs``. None when nothing is left. With the floor hypothesis: people on
    the floor first (:func:`.floor.floor_split`), returned second."""
    p = t.params
    floor = None
    if t.method.floor and len(to_plane) + len(t._floor_only):
        floor, to_plane = floor_split(segs, to_plane, D2, t.rig.arrays, p, t.scene, t.association == "oracle",
                                      t.counts, t._floor_only, t.method.outliers_at_mean)
    if floor is not None and len(t._fresh):  # a new regrouped segment on the floor only with its partner
        floor = pairs_only(floor, t._fresh, t._groups, t.counts)
    elif len(t._floor_only) and not t.method.floor:  # the ghosts' segments, without a floor to take them
        t.counts["segments_dropped_ghost"] += len(t._floor_only)
    if not len(to_plane):
        return None, floor
    # Eq. 2's separations, the one-view continuation, Eq. 5-9, Eq. 4, one view only inside S_perf
    prev_2d = t.linker.prev_2d
    if t.method.regain:  # the lost target's view, seen but never placed, may continue alone (.regain)
        back = regained_views(segs, to_plane, prev_2d, t.linker.prev_seen, t.linker.lost.get(t.target.live_track()),
                              t.P)
        if len(back):
            t.counts["target_regained_views"] += len(back)
            prev_2d = np.concatenate([prev_2d, back])
    pl = plane_split(segs, to_plane, D2, t.rig.arrays, t.stage_planes, p, t.association == "oracle",
                     prev_2d, t.linker.prev_seen, t.space, t._solo_space, t.counts,
                     t.method.outliers_at_mean, t._groups)
    if pl is not None and len(t._regrouped):  # only a gymnast's regrouped pair is kept (.regroup)
        pl = gymnast_only(pl, t._regrouped, t.perf_space, t.scene.target, t.counts,
                          continuing(pl, t.linker.may_continue_alone(segs.track2d)) if t.method.rejoin else None)
    if pl is not None and t.fusion is not None:  # two-view plane tracklets fused with the plane (.fusion)
        pl = drop_outliers(t, t.fusion.refine(segs, pl))  # (Eq. 4 on the fused points too)
    return pl, floor
