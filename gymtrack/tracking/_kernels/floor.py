"""Compiled kernels of ``cascade+``'s floor hypothesis (beyond the paper; the
rays and the floor as a plane are Eq. 5-7, matching and averaging Eq. 8-9 and Algorithm 1).

A window hands the floor a few segments and the ghost test a few two-view clusters, where
numpy's per-call overhead dominated (dozens of small calls per window), so each step is one
call: :func:`floor_stage` (candidates, Eq. 8 on the ground positions, Algorithm 1, the
performance-space test of lone segments, Eq. 9) and :func:`ghost_test` (the floor's test of
two-view triangulated clusters). Both are written over the ray primitives of
:mod:`gymtrack.geometry.primitives` (:func:`~gymtrack.geometry.primitives.ray_direction`,
:func:`~gymtrack.geometry.primitives.ray_plane`). Numpy references: ``tests/reference/floor.py``.

Segments: box (K, W, 4) centre-form undistorted, valid / observed (K, W) bool, camera (K,)
int64; the rig comes as :class:`~gymtrack.geometry.arrays.RigArrays`, planes as
:class:`~gymtrack.geometry.arrays.PlaneArrays`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ...geometry.primitives import plane_offset, ray_direction, ray_plane
from ..types import INTERPOLATED, PLANE
from .clustering import NO_APART, NO_GROUP, complete_linkage, constraints
from .reconstruct import outliers, outliers_at_mean, segments_of
from .sample import sample

_NAN = np.nan
_BIG = np.finfo(np.float64).max  # numpy.nan_to_num's stand-in for inf


class FloorRules(NamedTuple):
    """min_down: the bottom ray's unit z must be below ``-min_down``; min_height / max_height:
    a body's top (metres); threshold: Algorithm 1 threshold on the floor's Eq. 8 (metres);
    code / interpolated: source codes of a point with / without an observed view."""

    min_down: float
    min_height: float
    max_height: float
    threshold: float
    code: int
    interpolated: int


@njit(cache=True, error_model="numpy")
def floor_candidates(box, valid, camera, rig, rules):
    """Floor candidates of every segment and frame: the bottom-centre ray meets z = 0 (Eq. 6-7)
    at ``foot`` (K, W, 2); the top-centre ray's point nearest that vertical line gives ``height``
    (K, W); ``ok`` (K, W) bool: valid, bottom ray down, height of a body, foot finite."""
    K, W = box.shape[0], box.shape[1]
    foot = np.empty((K, W, 2))
    height = np.empty((K, W))
    ok = np.zeros((K, W), np.bool_)
    for k in range(K):
        c = camera[k]
        o0, o1, o2 = rig.centres[c, 0], rig.centres[c, 1], rig.centres[c, 2]
        for t in range(W):
            u = box[k, t, 0]
            d0, d1, d2 = ray_direction(rig.back, c, u, box[k, t, 1] + 0.5 * box[k, t, 3])
            s = -o2 / d2  # Eq. 7 with the floor z = 0
            f0 = o0 + s * d0
            f1 = o1 + s * d1
            u0, u1, u2 = ray_direction(rig.back, c, u, box[k, t, 1] + -0.5 * box[k, t, 3])
            r = ((f0 - o0) * u0 + (f1 - o1) * u1) / (u0 * u0 + u1 * u1)
            h = o2 + r * u2
            foot[k, t, 0], foot[k, t, 1], height[k, t] = f0, f1, h
            down = d2 / np.sqrt(d0 * d0 + d1 * d1 + d2 * d2) < -rules.min_down
            ok[k, t] = (valid[k, t] and down and h >= rules.min_height and h <= rules.max_height
                        and np.isfinite(f0) and np.isfinite(f1))
    return foot, height, ok


@njit(cache=True)
def _clip(x, nan):
    """numpy.nan_to_num(x, nan=nan) of a scalar."""
    if x != x:
        return nan
    return min(max(x, -_BIG), _BIG)


@njit(cache=True)
def _floorish(ok, observed, k):
    """Most of segment k's observed frames have a plausible floor candidate."""
    a, b = 0, 0
    for t in range(ok.shape[1]):
        if observed[k, t]:
            b += 1
            if ok[k, t]:
                a += 1
    return a * 2 > b


@njit(cache=True, error_model="numpy")
def _ground_distance(foot, ok, i, j):
    """Eq. 8 on the floor between segments i and j: mean ground distance over the frames both
    are plausible (NaN without one)."""
    s, n = 0.0, 0
    for t in range(ok.shape[1]):
        if ok[i, t] and ok[j, t]:
            dx = foot[i, t, 0] - foot[j, t, 0]
            dy = foot[i, t, 1] - foot[j, t, 1]
            s += np.sqrt(_clip(dx * dx + dy * dy, 0.0))
            n += 1
    return s / n if n > 0 else _NAN


@njit(cache=True, error_model="numpy")
def crosses(a0, a1, a2, b0, b1, b2, box):
    """The segment a -> b crosses the box (6,) ``[x0, y0, z0, x1, y1, z1]`` (slab test)."""
    lo, hi = -np.inf, np.inf
    a = (a0, a1, a2)
    b = (b0, b1, b2)
    for i in range(3):
        d = b[i] - a[i]
        t0 = (box[i] - a[i]) / d
        t1 = (box[3 + i] - a[i]) / d
        mn = _NAN if (t0 != t0 or t1 != t1) else min(t0, t1)
        mx = _NAN if (t0 != t0 or t1 != t1) else max(t0, t1)
        lo = max(lo, _clip(mn, -np.inf)) if i else _clip(mn, -np.inf)
        hi = min(hi, _clip(mx, np.inf)) if i else _clip(mx, np.inf)
    return lo <= hi and hi >= 0 and lo <= 1


@njit(cache=True, error_model="numpy")
def floor_stage(box, valid, observed, camera, rig, space, apart, group, rules):
    """The floor hypothesis of one window (:func:`gymtrack.tracking.floor.floor_stage`) in one call.

    space: (6,) performance space; apart: (K, K) bool pairs that never match, or (0, 0); group:
    (K,) int64 oracle ids (different ids never match), or (0,); rules: :class:`FloorRules`.
    Returns xyz (M, W, 3), top_z, bottom_z (M, W), valid (M, W), source, n_views (M, W) int8,
    members (M, C) int64 (indices of the segments) and used (K,) bool, the segments taken.
    """
    K, W = valid.shape
    C = rig.K.shape[0]
    used = np.zeros(K, np.bool_)
    foot, height, ok = floor_candidates(box, valid, camera, rig, rules)
    floorish = np.zeros(K, np.bool_)
    for k in range(K):
        floorish[k] = _floorish(ok, observed, k)
    D = np.full((K, K), np.inf)
    for i in range(K):
        for j in range(i + 1, K):
            if (not floorish[i] or not floorish[j] or camera[i] == camera[j]
                    or (apart.shape[0] > 0 and (apart[i, j] or apart[j, i]))
                    or (group.shape[0] > 0 and group[i] != group[j])):
                continue
            d = _ground_distance(foot, ok, i, j)
            if d == d:
                D[i, j] = D[j, i] = d
    labels = complete_linkage(D, rules.threshold) if K > 1 else np.zeros(K, np.int64)
    n_labels = 0
    for k in range(K):
        n_labels = max(n_labels, labels[k] + 1)
    size = np.zeros(n_labels, np.int64)
    for k in range(K):
        size[labels[k]] += 1
    # a lone segment is on the floor only if the feet's ray never crosses the performance space
    for k in range(K):
        if not floorish[k]:
            continue
        if size[labels[k]] > 1:
            used[k] = True
            continue
        c = camera[k]
        s0, s1, n = 0.0, 0.0, 0
        for t in range(W):
            if ok[k, t]:
                s0 += foot[k, t, 0]
                s1 += foot[k, t, 1]
                n += 1
        n = max(n, 1)
        used[k] = not crosses(rig.centres[c, 0], rig.centres[c, 1], rig.centres[c, 2], s0 / n, s1 / n, 0.0, space)
    # the groups in label order; Eq. 9 averages their members' plausible candidates
    row = np.full(n_labels, -1, np.int64)
    M = 0
    for lab in range(n_labels):
        for k in range(K):
            if used[k] and labels[k] == lab:
                row[lab] = M
                M += 1
                break
    members = np.full((M, C), -1, np.int64)
    for k in range(K):
        if used[k]:
            members[row[labels[k]], camera[k]] = k
    xyz = np.empty((M, W, 3))
    top = np.empty((M, W))
    bottom = np.empty((M, W))
    fvalid = np.zeros((M, W), np.bool_)
    source = np.empty((M, W), np.int8)
    n_views = np.zeros((M, W), np.int8)
    for m in range(M):
        for t in range(W):
            s0, s1, sh, n, nv = 0.0, 0.0, 0.0, 0, 0
            for c in range(C):
                k = members[m, c]
                if k >= 0 and ok[k, t]:
                    s0 += foot[k, t, 0]
                    s1 += foot[k, t, 1]
                    sh += height[k, t]
                    n += 1
                    if observed[k, t]:
                        nv += 1
            xyz[m, t, 0], xyz[m, t, 1] = s0 / n, s1 / n  # NaN without a candidate (0 / 0)
            top[m, t] = sh / n
            xyz[m, t, 2] = top[m, t] / 2
            fvalid[m, t] = n > 0
            bottom[m, t] = 0.0 if n > 0 else _NAN
            n_views[m, t] = nv
            source[m, t] = rules.code if nv > 0 else rules.interpolated
    return xyz, top, bottom, fvalid, source, n_views, members, used


@njit(cache=True, error_model="numpy")
def floor_split(box, valid, observed, camera, to_plane, floor_only, D2, cut, person, rig, space, tspace, max_speed,
                rules, at_mean):
    """The tracker's floor hook (:func:`gymtrack.tracking.floor.floor_split`) in one call: the
    segments ``to_plane`` then ``floor_only`` (int64 indices into the window's box, valid,
    observed (K, W), camera (K,)) taken out, Eq. 2's separations (``D2`` (K, K) >= ``cut``;
    (0, 0): none) and oracle ids (``person`` (K,); (0,): none) as constraints,
    :func:`floor_stage`, then Eq. 4 in ``tspace`` (``at_mean``: the space test on the mean,
    :func:`.reconstruct.outliers_at_mean`; else on every point).
    Returns xyz, top_z, bottom_z, valid, source, n_views of the kept floor tracklets, their
    members (indices of the window's segments), the ``to_plane`` segments left for the plane
    (in order) and (3,) int64 counts: segments taken, outlier tracklets, ``floor_only`` left."""
    n_plane = len(to_plane)
    K = n_plane + len(floor_only)
    idx = np.empty(K, np.int64)
    idx[:n_plane] = to_plane
    idx[n_plane:] = floor_only
    apart, group = constraints(idx, D2, cut, person)  # Eq. 2 says different people: never one on the floor
    xyz, top, bottom, fvalid, source, n_views, members, used = floor_stage(
        box[idx], valid[idx], observed[idx], camera[idx], rig, space, apart, group, rules)
    stats = np.zeros(3, np.int64)
    for k in range(K):
        stats[0] += used[k]
        if k >= n_plane and not used[k]:
            stats[2] += 1
    n_rest = 0
    for k in range(n_plane):
        n_rest += not used[k]
    rest = np.empty(n_rest, np.int64)
    n_rest = 0
    for k in range(n_plane):
        if not used[k]:
            rest[n_rest] = idx[k]
            n_rest += 1
    M = members.shape[0]
    keep = np.ones(M, np.bool_)
    if M > 0:
        keep = ~(outliers_at_mean(xyz, fvalid, tspace, max_speed) if at_mean else outliers(xyz, fvalid, tspace, max_speed))
    n_keep = 0
    for m in range(M):
        n_keep += keep[m]
    stats[1] = M - n_keep
    if n_keep < M:  # (integer takes of the kept rows)
        rows = np.flatnonzero(keep)
        xyz, top, bottom, fvalid, source, n_views, members = (
            xyz[rows], top[rows], bottom[rows], fvalid[rows], source[rows], n_views[rows], members[rows])
    for m in range(members.shape[0]):  # members index the window's segments
        for c in range(members.shape[1]):
            if members[m, c] >= 0:
                members[m, c] = idx[members[m, c]]
    return xyz, top, bottom, fvalid, source, n_views, members, rest, stats


@njit(cache=True, error_model="numpy")
def _plane_distance(box, valid, camera, rig, planes, i, j, min_cos):
    """Eq. 8 between the box-centre candidates of segments i and j on the apparatus planes, the
    smallest over the planes (inf without a shared frame)."""
    ci, cj = camera[i], camera[j]
    best = np.inf
    for p in range(planes.point.shape[0]):
        pp, pn = planes.point[p], planes.normal[p]
        s, n = 0.0, 0
        for t in range(valid.shape[1]):
            X = np.empty((2, 3))
            for a in range(2):
                k, c = (i, ci) if a == 0 else (j, cj)
                o0, o1, o2 = rig.centres[c, 0], rig.centres[c, 1], rig.centres[c, 2]
                d0, d1, d2 = ray_direction(rig.back, c, box[k, t, 0], box[k, t, 1])
                num = plane_offset(pp[0], pp[1], pp[2], pn[0], pn[1], pn[2], o0, o1, o2)
                _, X[a, 0], X[a, 1], X[a, 2] = ray_plane(o0, o1, o2, d0, d1, d2, np.sqrt(d0 * d0 + d1 * d1 + d2 * d2),
                                                         num, pn[0], pn[1], pn[2], min_cos)
            e0, e1, e2 = X[0, 0] - X[1, 0], X[0, 1] - X[1, 1], X[0, 2] - X[1, 2]
            if valid[i, t] and valid[j, t] and np.isfinite(e0) and np.isfinite(e1) and np.isfinite(e2):
                s += np.sqrt(_clip(e0 * e0 + e1 * e1 + e2 * e2, 0.0))
                n += 1
        m = s / n if n > 0 else np.inf
        best = min(best, m) if m == m else best
    return best


@njit(cache=True, error_model="numpy")
def ghost_test(members, valid3, bottom_z, xyz, box, valid, observed, camera, rig, planes, space, air, min_cos, rules):
    """The floor's ghost test of triangulated clusters (:func:`gymtrack.tracking.floor.drop_floor_ghosts`).

    members (M, C) int64, valid3 (M, W), bottom_z (M, W), xyz (M, W, 3): the clusters; box,
    valid, observed, camera: the window's segments; planes: the apparatus planes; space (6,);
    air: a bottom above it is in the air. Returns (M,) bool: two-view clusters in the air that
    stand outside the performance space, or whose views' floor candidates stand apart (more than
    ``rules.threshold``) while their apparatus-plane candidates disagree too.
    """
    M, W = valid3.shape
    ghost = np.zeros(M, np.bool_)
    pair = np.empty(2, np.int64)
    for m in range(M):
        n = 0
        for c in range(members.shape[1]):
            if members[m, c] >= 0:
                if n < 2:
                    pair[n] = members[m, c]
                n += 1
        if n != 2:
            continue
        sb, nb, sx, nx, sy, ny = 0.0, 0, 0.0, 0, 0.0, 0
        for t in range(W):
            if valid3[m, t]:
                if bottom_z[m, t] == bottom_z[m, t]:
                    sb += bottom_z[m, t]
                    nb += 1
                if xyz[m, t, 0] == xyz[m, t, 0]:
                    sx += xyz[m, t, 0]
                    nx += 1
                if xyz[m, t, 1] == xyz[m, t, 1]:
                    sy += xyz[m, t, 1]
                    ny += 1
        if not (nb > 0 and sb / nb > air):
            continue
        x, y = sx / nx if nx else _NAN, sy / ny if ny else _NAN
        if not (x >= space[0] and x <= space[3] and y >= space[1] and y <= space[4]):
            ghost[m] = True
            continue
        a, b = min(pair[0], pair[1]), max(pair[0], pair[1])
        sub = np.array([a, b])
        foot, _, ok = floor_candidates(box[sub], valid[sub], camera[sub], rig, rules)
        if not (_floorish(ok, observed[sub], 0) and _floorish(ok, observed[sub], 1)):
            continue
        d = _ground_distance(foot, ok, 0, 1)
        if not (_clip(d, np.inf) > rules.threshold):
            continue
        ghost[m] = planes.point.shape[0] == 0 or _plane_distance(box, valid, camera, rig, planes, a, b,
                                                                 min_cos) > rules.threshold
    return ghost


@njit(cache=True, error_model="numpy")
def ghost_split(members, valid3, bottom_z, xyz, box, valid, observed, camera, track2d, prev_2d, prev_owner, confirm,
                rig, planes, space, air, min_cos, rules, tspace, max_speed, eq4):
    """:func:`ghost_test` and what :func:`gymtrack.tracking.floor.drop_floor_ghosts` does with it, in
    one call. track2d (K,): the segments' 2D tracks; ``confirm``: a ghost whose 2D tracks were all
    members of one 3D track of the previous window (``prev_owner`` (n,) of the 2D tracks
    ``prev_2d`` (n,); -1 / none found: no track) is kept; ``eq4``: first Eq. 4 with the space test on the mean
    (:func:`.reconstruct.outliers_at_mean` in ``tspace``; the outliers are not tested).
    Returns drop (M,) bool (outliers and ghosts), the ghosts' segments (sorted) and (4,) int64:
    outliers, any ghost before the confirmation (0 / 1), ghosts confirmed, ghosts."""
    M, C = members.shape
    stats = np.zeros(4, np.int64)
    bad = np.zeros(M, np.bool_)
    if eq4 and M > 0:
        bad = outliers_at_mean(xyz, valid3, tspace, max_speed)
    ghost = ghost_test(members, valid3, bottom_z, xyz, box, valid, observed, camera, rig, planes, space, air, min_cos,
                       rules)  # (row by row: an outlier's answer is not used)
    for m in range(M):
        stats[0] += bad[m]
        ghost[m] = ghost[m] and not bad[m]
        stats[3] += ghost[m]
    if stats[3] == 0:
        return bad, np.zeros(0, np.int64), stats
    stats[1] = 1
    if confirm:
        known = len(prev_2d) > 0 and len(prev_owner) == len(prev_2d)
        for m in range(M):
            if not ghost[m]:
                continue
            first, same = -2, True  # every member's owner one and the same track (>= 0)
            for c in range(C):
                k = members[m, c]
                if k < 0:
                    continue
                o = -1
                if known:
                    for q in range(len(prev_2d)):
                        if prev_2d[q] == track2d[k]:
                            o = prev_owner[q]
                            break
                if o < 0 or (first != -2 and o != first):
                    same = False
                first = o
            if same and first >= 0:
                ghost[m] = False
                stats[2] += 1
        stats[3] -= stats[2]
    return bad | ghost, segments_of(members, ghost), stats


def warm_up() -> None:
    """Compile (or load) both kernels on the sample person's two views, with and without
    constraints."""
    from ...geometry.arrays import PlaneArrays

    s = sample()
    rig = s.rig.arrays
    rules = FloorRules(1e-3, 0.7, 2.4, 0.5, PLANE, INTERPOLATED)
    valid = np.isfinite(s.box).all(-1)
    space = np.array([-1.0, -1.0, 0.0, 1.0, 1.0, 3.0])
    for apart, group in ((NO_APART, NO_GROUP), (np.zeros((2, 2), bool), np.zeros(2, np.int64))):
        floor_stage(s.box, valid, s.observed, s.camera, rig, space, apart, group, rules)
    M, W = 1, s.box.shape[1]
    D2 = np.zeros((2, 2))
    for d2, person, at_mean in ((np.zeros((0, 0)), NO_GROUP, True), (D2, np.zeros(2, np.int64), False)):
        floor_split(s.box, valid, s.observed, s.camera, np.array([0], np.int64), np.array([1], np.int64), d2, 1.0,
                    person, rig, space, space, 0.5, rules, at_mean)
    ghost_test(np.array([[0, 1]], np.int64), np.ones((M, W), bool), np.ones((M, W)), np.ones((M, W, 3)), s.box,
               valid, s.observed, s.camera, rig, PlaneArrays.from_planes(s.planes), space, 0.25, 1e-3, rules)
    i2 = np.arange(2, dtype=np.int64)
    ghost_split(np.array([[0, 1]], np.int64), np.ones((M, W), bool), np.ones((M, W)), np.ones((M, W, 3)), s.box,
                valid, s.observed, s.camera, i2, i2, i2, True, rig, PlaneArrays.from_planes(s.planes), space, 0.25, 1e-3,
                rules, space, 0.5, True)
