"""The numpy floor hypothesis of ``cascade+`` that :mod:`gymtrack.tracking._kernels.floor` replaced
(beyond the paper; Eq. 5-9 with the floor z = 0 as the plane): the reference
the tests compare the kernels with, on random inputs.

:func:`floor_candidates` (K, W, 2) foot, (K, W) height, (K, W) ok; :func:`floor_distances` (K, K);
:func:`floor_stage` -> (WindowTracklets3D, used (K,)); :func:`floor_split` (the tracker's
hook around it) -> (WindowTracklets3D or None, segments left); :func:`drop_floor_ghosts` -> (kept, ghost
segments). Same signatures as the production functions of :mod:`gymtrack.tracking.floor`.
"""

from __future__ import annotations

import numpy as np

from gymtrack.geometry.arrays import RigArrays
from gymtrack.tracking.clustering import complete_linkage
from gymtrack.tracking.floor import AIR, MAX_HEIGHT, MIN_DOWN, MIN_HEIGHT
from gymtrack.tracking.types import INTERPOLATED, PLANE, WindowTracklets, WindowTracklets3D


def floor_candidates(segs: WindowTracklets, rig: RigArrays) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Floor candidates of the segments: ``foot`` (K, W, 2), ``height`` (K, W) and
    ``plausible`` (K, W) bool (valid box, bottom ray down, height of a body)."""
    c = rig.centres[segs.camera][:, None, :]  # (K, 1, 3)
    rays = _rays(segs, rig)
    with np.errstate(invalid="ignore", divide="ignore"):
        d = rays(segs.points("bottom"))
        t = -c[..., 2] / d[..., 2]  # Eq. 7 with the floor z = 0
        foot = c[..., :2] + t[..., None] * d[..., :2]
        u = rays(segs.points("top"))
        # the top ray's point whose horizontal position is nearest the foot's vertical line
        uh = u[..., :2]
        s = ((foot - c[..., :2]) * uh).sum(-1) / (uh * uh).sum(-1)
        height = c[..., 2] + s * u[..., 2]
        down = d[..., 2] / np.linalg.norm(d, axis=-1) < -MIN_DOWN
        ok = segs.valid & down & (height >= MIN_HEIGHT) & (height <= MAX_HEIGHT) & np.isfinite(foot).all(-1)
    return foot, height, ok


def _rays(segs: WindowTracklets, rig: RigArrays):
    """Eq. 6 for the segments' (K, W, 2) pixels -> (K, W, 3) world directions."""
    back = rig.back[segs.camera]  # (K, 3, 3)

    def rays(uv):
        return np.einsum("kij,kwj->kwi", back[:, :, :2], uv) + back[:, None, :, 2]
    return rays


def floor_distances(foot: np.ndarray, ok: np.ndarray, camera: np.ndarray) -> np.ndarray:
    """Eq. 8 on the floor: (K, K) mean ground distance over frames both candidates are plausible;
    inf for the same camera or no shared frame."""
    diff = foot[:, None] - foot[None, :]  # (K, K, W, 2)
    both = ok[:, None] & ok[None, :]
    dist = np.where(both, np.sqrt(np.nan_to_num((diff * diff).sum(-1), nan=0.0)), 0.0)
    n = both.sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        D = dist.sum(-1) / n
    D[(n == 0) | (camera[:, None] == camera[None, :])] = np.inf
    return D


def floor_stage(segs: WindowTracklets, rig: RigArrays, threshold: float, space: np.ndarray,
                apart: np.ndarray | None = None, labels: np.ndarray | None = None,
                ) -> tuple[WindowTracklets3D, np.ndarray]:
    """The floor hypothesis for the segments handed to the plane stage.

    threshold: Algorithm 1 threshold on the floor's Eq. 8 (metres); space: (6,) the performance
    space (x0, y0, z0, x1, y1, z1): a lone segment standing outside it is on the floor.
    apart: (K, K) bool pairs known to be different people; labels: (K,) oracle person ids.
    Returns the floor tracklets (``members`` index ``segs``) and ``used`` (K,) bool, the
    segments they took (the rest go on to the apparatus plane).
    """
    K, W = segs.valid.shape
    C = len(rig.K)
    used = np.zeros(K, bool)
    if K == 0:
        return WindowTracklets3D.empty(segs.start, W, C), used
    foot, height, ok = floor_candidates(segs, rig)
    # a candidate speaks for the floor only if most of its observed frames are plausible
    floorish = (ok & segs.observed).sum(1) * 2 > segs.observed.sum(1)
    if not floorish.any():
        return WindowTracklets3D.empty(segs.start, W, C), used
    D = floor_distances(foot, ok, segs.camera)
    D[~floorish, :] = np.inf
    D[:, ~floorish] = np.inf
    if apart is not None:
        D[apart] = np.inf
    if labels is not None:
        D[labels[:, None] != labels[None, :]] = np.inf
    cl = complete_linkage(D, threshold) if K > 1 else np.zeros(1, np.int64)
    size = np.bincount(cl)
    lone = size[cl] == 1
    n_ok = np.maximum(ok.sum(1), 1)[:, None]
    mean_foot = np.where(ok[..., None], np.nan_to_num(foot), 0.0).sum(1) / n_ok  # (K, 2); 0 where none (not floorish)
    # alone, the floor is sure only if the feet's ray never crosses the performance space (else
    # the feet may be in the air inside it: the apparatus plane's case)
    outside = ~_crosses(rig.centres[segs.camera], np.column_stack([mean_foot, np.zeros(K)]), space)
    take = floorish & (~lone | outside)
    idx = np.flatnonzero(take)  # (every member of a group of two or more is floorish: the rest are apart)
    groups, gi = np.unique(cl[idx], return_inverse=True)
    M = len(groups)
    members = np.full((M, C), -1, np.int64)
    members[gi, segs.camera[idx]] = idx
    used[idx] = True
    # Eq. 9: average the members' candidates, as matrix products with the (M, n) membership
    A = (gi[None, :] == np.arange(M)[:, None]).astype(np.float64)
    o = ok[idx]
    n = A @ o
    n_views = (A @ (o & segs.observed[idx])).astype(np.int8)
    with np.errstate(invalid="ignore", divide="ignore"):
        xy = np.einsum("mn,nwk->mwk", A, np.where(o[..., None], foot[idx], 0.0)) / n[..., None]
        top = (A @ np.where(o, height[idx], 0.0)) / n
    valid = n > 0
    xyz = np.concatenate([xy, top[..., None] / 2], axis=-1)
    source = np.where(n_views > 0, PLANE, INTERPOLATED).astype(np.int8)
    bottom = np.where(valid, 0.0, np.nan)
    return WindowTracklets3D(segs.start, xyz, top, bottom, valid, source, n_views, members,
                             np.full(M, -1, np.int64)), used


def _plane_distance(sub: WindowTracklets, rig: RigArrays, planes) -> np.ndarray:
    """(n,) Eq. 8 between the box-centre candidates of the segment pairs ``sub`` (2n: 0-1, 2-3,
    ...) on the apparatus planes, the smallest over the planes (inf without a shared frame)."""
    from gymtrack.geometry.plane import intersect_rays_plane

    d = _rays(sub, rig)(sub.points("centre"))
    o = rig.centres[sub.camera][:, None, :]
    best = np.full(len(sub) // 2, np.inf)
    for plane in planes:
        X, _ = intersect_rays_plane(o, d, plane)
        diff = X[0::2] - X[1::2]
        both = sub.valid[0::2] & sub.valid[1::2] & np.isfinite(diff).all(-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            m = np.where(both, np.sqrt(np.nan_to_num((diff * diff).sum(-1))), 0.0).sum(1) / both.sum(1)
        best = np.fmin(best, np.nan_to_num(m, nan=np.inf))
    return best


def _crosses(a: np.ndarray, b: np.ndarray, box: np.ndarray) -> np.ndarray:
    """(n,) bool: the segments ``a`` -> ``b`` (n, 3) cross the box (6,) ``[x0, y0, z0, x1, y1, z1]``
    (slab test)."""
    d = b - a
    with np.errstate(divide="ignore", invalid="ignore"):
        t0, t1 = (box[:3] - a) / d, (box[3:] - a) / d
    lo = np.nan_to_num(np.minimum(t0, t1), nan=-np.inf).max(1)
    hi = np.nan_to_num(np.maximum(t0, t1), nan=np.inf).min(1)
    return (lo <= hi) & (hi >= 0) & (lo <= 1)


def drop_floor_ghosts(tri: WindowTracklets3D | None, segs: WindowTracklets, rig: RigArrays, planes, params, scene,
                      counts: dict, owner: np.ndarray | None = None) -> tuple[WindowTracklets3D | None, np.ndarray]:
    """``cascade+``: the two-view triangulated clusters the floor says are ghosts (a wrong pair
    of two people's segments triangulates to a short body floating above the floor).

    A cluster of two views whose triangulated bottom is in the air (mean ``bottom_z`` > ``AIR``)
    is a ghost when it lies outside the performance space (off the apparatus nobody's feet leave
    the floor) or when both views' floor candidates are plausible and stand farther apart than
    the plane threshold (each view sees someone standing elsewhere) while their candidates on
    the apparatus planes (Eq. 7-8, ``planes``) disagree too (a gymnast in the air is on them). Returns the clusters kept
    and the ghosts' segments (indices into ``segs``, for the floor stage only).
    """
    none = np.zeros(0, np.int64)
    if tri is None or not len(tri):
        return tri, none
    two = (tri.members >= 0).sum(1) == 2
    with np.errstate(invalid="ignore"):
        bottom = np.nanmean(np.where(tri.valid, tri.bottom_z, np.nan), axis=1) if two.any() else None
    cand = np.flatnonzero(two & (np.nan_to_num(bottom, nan=0.0) > AIR)) if two.any() else none
    if not len(cand):
        return tri, none
    space = np.asarray(scene.performance_space, dtype=np.float64)
    xy = np.nanmean(np.where(tri.valid[cand, :, None], tri.xyz[cand, :, :2], np.nan), axis=1)
    outside = ~((xy[:, 0] >= space[0]) & (xy[:, 0] <= space[3]) & (xy[:, 1] >= space[1]) & (xy[:, 1] <= space[4]))
    pair = np.sort(tri.members[cand], axis=1)[:, -2:]  # (n, 2) the two segments
    sub = segs.subset(pair.ravel())
    foot, _, ok = floor_candidates(sub, rig)
    floorish = ((ok & sub.observed).sum(1) * 2 > sub.observed.sum(1)).reshape(-1, 2).all(1)
    d = foot[0::2] - foot[1::2]
    both = ok[0::2] & ok[1::2]
    with np.errstate(invalid="ignore"):
        dist = np.where(both, np.sqrt(np.nan_to_num((d * d).sum(-1))), 0.0).sum(1) / both.sum(1)
    far = floorish & (np.nan_to_num(dist, nan=np.inf) > params.cluster_plane)
    if far.any() and len(planes):
        far &= _plane_distance(sub, rig, planes) > params.cluster_plane
    ghost = outside | far
    if not ghost.any():
        return tri, none
    if owner is not None:  # (K,) the previous window's track of each segment: a pair of one track is confirmed
        mem = tri.members[cand]
        o = np.where(mem >= 0, owner[np.maximum(mem, 0)], -2)
        lo = np.where(mem >= 0, o, np.iinfo(np.int64).max).min(axis=1)
        confirmed = (lo >= 0) & ((o == lo[:, None]) | (mem < 0)).all(axis=1)
        counts["floor_ghosts_confirmed"] += int((ghost & confirmed).sum())
        ghost &= ~confirmed
        if not ghost.any():
            return tri, none
    bad = np.zeros(len(tri), bool)
    bad[cand[ghost]] = True
    counts["floor_ghosts"] += int(ghost.sum())
    return tri.subset(~bad), np.sort(pair[ghost].ravel())


def floor_split(segs: WindowTracklets, to_plane: np.ndarray, D2: np.ndarray | None, rig: RigArrays, params, scene,
                oracle: bool, counts: dict, floor_only: np.ndarray | None = None
                ) -> tuple[WindowTracklets3D | None, np.ndarray]:
    """The tracker's floor hook: :func:`floor_stage` on the segments ``to_plane`` then
    ``floor_only``, Eq. 2's separations (``D2 >= cluster_2d``) and oracle ids as constraints,
    Eq. 4 by place (S_track) on the result; members index ``segs``. Returns the floor tracklets
    (None when none) and the ``to_plane`` segments left for the plane."""
    from reference.reconstruct import outliers_at_mean_numpy

    C = len(rig.K)
    n_plane = len(to_plane)
    if floor_only is not None and len(floor_only):
        to_plane = np.concatenate([to_plane, floor_only])
    if not len(to_plane):
        return None, to_plane
    apart = None if D2 is None else D2[np.ix_(to_plane, to_plane)] >= params.cluster_2d
    labels = np.unique(segs.track2d[to_plane] // C, return_inverse=True)[1] if oracle else None
    fl, used = floor_stage(segs.subset(to_plane), rig, params.cluster_plane, np.asarray(scene.performance_space, float),
                           apart, labels)
    counts["segments_to_floor"] += int(used.sum())
    out = None
    if len(fl):
        bad = outliers_at_mean_numpy(fl.xyz, fl.valid, np.asarray(scene.tracking_space, float), params.max_speed)
        if bad.any():
            counts["tracklets_outliers"] += int(bad.sum())
            fl = fl.subset(~bad)
        if len(fl):
            out = fl.with_members(np.where(fl.members >= 0, to_plane[np.maximum(fl.members, 0)], -1))
            counts["floor_tracklets"] += len(out)
    rest = ~used
    if rest[n_plane:].any():
        counts["segments_dropped_ghost"] += int(rest[n_plane:].sum())
        rest[n_plane:] = False
    return out, to_plane[rest]
