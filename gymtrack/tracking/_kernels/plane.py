"""Compiled kernels of the plane fallback (paper Section III-C, Eq. 5-9).

A window hands this stage a few segments, where numpy's per-call overhead dominated, so
:func:`plane_stage` is one call: candidates of all segments, points and planes (Eq. 5-7, the
ray primitives of :mod:`gymtrack.geometry.primitives`), Eq. 8, Algorithm 1 and Eq. 9. The
other kernels are its steps. Numpy references: ``tests/reference/plane.py``.
Segments: box (K, W, 4), observed (K, W), camera (K,) int64; the rig and planes come as
:class:`~gymtrack.geometry.arrays.RigArrays` and :class:`~gymtrack.geometry.arrays.PlaneArrays`.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np
from numba import njit

from ...geometry.primitives import RAY_OK, RAY_PARALLEL, plane_offset, ray_direction, ray_plane
from ..types import INTERPOLATED, PLANE
from .clustering import NO_APART, NO_GROUP, complete_linkage, constraints
from .reconstruct import outliers, outliers_at_mean
from .sample import sample

_NAN = np.nan


class PlaneRules(NamedTuple):
    """min_cos: rays with ``|cos|`` to a plane's normal below it are parallel; threshold:
    Algorithm 1 threshold on Eq. 8 (metres); code / interpolated: source codes of a fused point
    with / without an observed view."""

    min_cos: float
    threshold: float
    code: int
    interpolated: int


class PlaneConstraints(NamedTuple):
    """group: (K,) int64 oracle person ids (pairs of different ids never match) or (0,): none;
    apart: (K, K) bool pairs that never match, or (0, 0): none; single: (K,) bool segments that
    may stand alone, or (0,): none."""

    group: np.ndarray
    apart: np.ndarray
    single: np.ndarray


NO_SINGLE = np.zeros(0, bool)


@njit(cache=True, error_model="numpy")
def candidate_distances(X, observed, camera, exists):
    """Eq. 8 on every plane, :func:`gymtrack.tracking.plane_fallback.candidate_distances`: X (P, K, W, 3),
    observed (K, W), camera (K,), exists (P, K, W) -> (P, K, K) (NaN: no shared frame; inf:
    same camera)."""
    P, K, W = exists.shape
    D = np.empty((P, K, K))
    for p in range(P):
        for i in range(K):
            D[p, i, i] = np.inf
            for j in range(i + 1, K):
                if camera[i] == camera[j]:
                    D[p, i, j] = np.inf
                    D[p, j, i] = np.inf
                    continue
                s = 0.0
                n = 0
                for t in range(W):
                    if observed[i, t] and observed[j, t] and exists[p, i, t] and exists[p, j, t]:
                        d0 = X[p, i, t, 0] - X[p, j, t, 0]
                        d1 = X[p, i, t, 1] - X[p, j, t, 1]
                        d2 = X[p, i, t, 2] - X[p, j, t, 2]
                        s += np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                        n += 1
                v = s / n if n > 0 else _NAN
                D[p, i, j] = v
                D[p, j, i] = v
    return D



#: a plane whose unit normal's |z| is below this (tilted less than 30 degrees off vertical: the
#: apparatus planes, fitted or given) gives top and bottom as the paper does; above, a support surface
SURFACE_Z = 0.5


@njit(cache=True, inline="always")
def _facing(box, back, c, k, t, o0, o1, o2, d0, d1, d2, dlen, centre, centre_ok, min_cos):
    """Eq. 7 of the ray (o, d) with the vertical plane through ``centre`` whose normal is the
    horizontal part of the box-centre ray of segment k at frame t (camera c)."""
    if not centre_ok:
        return RAY_PARALLEL, _NAN, _NAN, _NAN
    h0, h1, _ = ray_direction(back, c, box[k, t, 0], box[k, t, 1])
    hl = np.sqrt(h0 * h0 + h1 * h1)
    if not hl > 0:
        return RAY_PARALLEL, _NAN, _NAN, _NAN
    h0, h1 = h0 / hl, h1 / hl
    num = plane_offset(centre[0], centre[1], centre[2], h0, h1, 0.0, o0, o1, o2)
    return ray_plane(o0, o1, o2, d0, d1, d2, dlen, num, h0, h1, 0.0, min_cos)


@njit(cache=True, error_model="numpy")
def plane_candidates(box, camera, rig, planes, min_cos):
    """Eq. 5-7 for the box centre, top-centre and bottom-centre of every segment, frame and plane
    (:func:`gymtrack.geometry.primitives.ray_direction`, :func:`~gymtrack.geometry.primitives.ray_plane`:
    the arithmetic of :func:`gymtrack.geometry.plane.intersect_rays_plane`).

    box: (K, W, 4) centre-form undistorted boxes (NaN where not valid); camera: (K,) int64;
    rig: :class:`~gymtrack.geometry.arrays.RigArrays` (``back``, ``centres``); planes:
    :class:`~gymtrack.geometry.arrays.PlaneArrays` (P planes); min_cos: rays with ``|cos|`` to the
    normal below it are parallel.
    Returns X (3, P, K, W, 3) (centre, top, bottom; NaN where there is no intersection) and
    ok (3, P, K, W) bool: the ray is not parallel (nor NaN / zero) and the plane is in front.

    A surface far from vertical (``|n_z| >= SURFACE_Z``: a horizontal support surface) gives the centre only: the
    top and bottom rays meet the vertical plane through that centre facing the camera (normal:
    the centre ray's horizontal part), so their heights are the body's, not the surface's.
    """
    K, W = box.shape[0], box.shape[1]
    pp, pn = planes.point, planes.normal
    P = pp.shape[0]
    X = np.full((3, P, K, W, 3), _NAN)
    ok = np.zeros((3, P, K, W), np.bool_)
    num = np.empty(P)
    for k in range(K):
        c = camera[k]
        o0, o1, o2 = rig.centres[c, 0], rig.centres[c, 1], rig.centres[c, 2]
        for p in range(P):  # n . (X^p - X^o), one per segment and plane
            num[p] = plane_offset(pp[p, 0], pp[p, 1], pp[p, 2], pn[p, 0], pn[p, 1], pn[p, 2], o0, o1, o2)
        for q in range(3):
            sign = 0.0 if q == 0 else (-0.5 if q == 1 else 0.5)
            for t in range(W):
                u = box[k, t, 0]
                v = box[k, t, 1] if q == 0 else box[k, t, 1] + sign * box[k, t, 3]
                d0, d1, d2 = ray_direction(rig.back, c, u, v)
                dlen = np.sqrt(d0 * d0 + d1 * d1 + d2 * d2)
                for p in range(P):
                    if q == 0 or abs(pn[p, 2]) < SURFACE_Z:
                        status, x0, x1, x2 = ray_plane(o0, o1, o2, d0, d1, d2, dlen, num[p], pn[p, 0], pn[p, 1],
                                                       pn[p, 2], min_cos)
                    else:  # a surface's top / bottom: the vertical plane through its centre candidate
                        status, x0, x1, x2 = _facing(box, rig.back, c, k, t, o0, o1, o2, d0, d1, d2, dlen,
                                                     X[0, p, k, t], ok[0, p, k, t], min_cos)
                    if status == RAY_OK:
                        ok[q, p, k, t] = True
                        X[q, p, k, t, 0] = x0
                        X[q, p, k, t, 1] = x1
                        X[q, p, k, t, 2] = x2
    return X, ok


@njit(cache=True)
def best_plane_distance(Dp):
    """:func:`gymtrack.tracking.plane_fallback.best_plane_distance`: (P, K, K) -> (K, K), the smallest known
    (not NaN) distance over the planes, NaN where none is known."""
    P, K = Dp.shape[0], Dp.shape[1]
    D = np.empty((K, K))
    for i in range(K):
        for j in range(K):
            best = np.inf
            known = False
            for p in range(P):
                x = Dp[p, i, j]
                if x == x:
                    known = True
                    if x < best:
                        best = x
            D[i, j] = best if known else _NAN
    return D


@njit(cache=True, error_model="numpy")
def fuse_on_planes(X, ok, Dp, labels, camera, observed, n_cameras, single, rules):
    """Eq. 9, :func:`gymtrack.tracking.plane_fallback.fuse_on_planes`: the members of each cluster of two or more
    views (or a permitted single) averaged on the plane that minimises their mean Eq. 8 distance.

    X: (3, P, K, W, 3) centre / top / bottom candidates; ok: (3, P, K, W) where they exist;
    Dp: (P, K, K) Eq. 8 distances; labels: (K,) int64 clusters (at most one segment per camera);
    camera: (K,) int64; observed: (K, W) bool; single: (K,) bool segments that may stand alone
    (or (0,): none); rules: :class:`PlaneRules` (``code`` / ``interpolated``: the source codes of
    a point with / without an observed view). Returns xyz (M, W, 3), top_z, bottom_z (M, W), valid (M, W), source (M, W)
    int8, n_views (M, W) int8 and members (M, C) int64, in cluster order.
    """
    P = X.shape[1]
    K, W = observed.shape
    C = n_cameras
    n_clusters = 0
    for k in range(K):
        if labels[k] + 1 > n_clusters:
            n_clusters = labels[k] + 1
    every = np.full((n_clusters, C), -1, np.int64)
    for k in range(K):
        every[labels[k], camera[k]] = k
    keep = np.zeros(n_clusters, np.bool_)
    M = 0
    for m in range(n_clusters):
        count, last = 0, -1
        for c in range(C):
            if every[m, c] >= 0:
                count += 1
                last = every[m, c] if every[m, c] > last else last
        keep[m] = count >= 2 or (count == 1 and single.shape[0] > 0 and single[last])
        if keep[m]:
            M += 1
    members = np.empty((M, C), np.int64)
    a = 0
    for m in range(n_clusters):
        if keep[m]:
            members[a] = every[m]
            a += 1
    xyz = np.full((M, W, 3), _NAN)
    top = np.full((M, W), _NAN)
    bottom = np.full((M, W), _NAN)
    valid = np.zeros((M, W), np.bool_)
    source = np.empty((M, W), np.int8)
    n_views = np.zeros((M, W), np.int8)
    for m in range(M):
        plane = 0
        if P > 1:  # the plane minimising the mean pairwise distance of the cluster's members
            best = np.inf
            for p in range(P):
                s, n = 0.0, 0
                for ca in range(C):
                    i = members[m, ca]
                    if i < 0:
                        continue
                    for cb in range(C):
                        j = members[m, cb]
                        if cb == ca or j < 0:
                            continue
                        d = Dp[p, i, j]
                        if np.isfinite(d):
                            s += d
                            n += 1
                mean = s / n if n > 0 else np.inf
                if mean < best:
                    best, plane = mean, p
        for t in range(W):
            for q in range(3):
                s0, s1, s2, n = 0.0, 0.0, 0.0, 0
                for c in range(C):
                    k = members[m, c]
                    if k >= 0 and ok[q, plane, k, t]:
                        s0 += X[q, plane, k, t, 0]
                        s1 += X[q, plane, k, t, 1]
                        s2 += X[q, plane, k, t, 2]
                        n += 1
                if q == 0:
                    if n == 0:
                        break  # no centre: the frame is not valid, top and bottom stay NaN
                    valid[m, t] = True
                    xyz[m, t, 0], xyz[m, t, 1], xyz[m, t, 2] = s0 / n, s1 / n, s2 / n
                elif n > 0:
                    if q == 1:
                        top[m, t] = s2 / n
                    else:
                        bottom[m, t] = s2 / n
            nv = 0
            for c in range(C):
                k = members[m, c]
                if k >= 0 and observed[k, t] and ok[0, plane, k, t]:
                    nv += 1
            n_views[m, t] = nv
            source[m, t] = rules.code if nv > 0 else rules.interpolated
    return xyz, top, bottom, valid, source, n_views, members


@njit(cache=True, error_model="numpy")
def plane_stage(box, observed, camera, rig, planes, constraints, rules):
    """The whole plane fallback of one window, :func:`gymtrack.tracking.plane_fallback.plane_stage`:
    candidates (:func:`plane_candidates`), Eq. 8 (:func:`candidate_distances`,
    :func:`best_plane_distance`), Algorithm 1 (:func:`~.clustering.complete_linkage`) and Eq. 9
    (:func:`fuse_on_planes`) in one call.

    box (K, W, 4), observed (K, W), camera (K,) int64: the segments; rig: RigArrays; planes:
    PlaneArrays; constraints: :class:`PlaneConstraints`; rules: :class:`PlaneRules`.
    Returns what :func:`fuse_on_planes` returns (M = 0 when nothing is fused).
    """
    K, W = observed.shape
    P = planes.point.shape[0]
    n_cameras = rig.K.shape[0]
    group, apart, single = constraints.group, constraints.apart, constraints.single
    threshold = rules.threshold
    any_single = False
    for k in range(single.shape[0]):
        if single[k]:
            any_single = True
    if (K < 2 and not any_single) or P == 0:
        X = np.full((3, P, K, W, 3), _NAN)
        ok = np.zeros((3, P, K, W), np.bool_)
        return fuse_on_planes(X, ok, np.zeros((P, K, K)), np.zeros(0, np.int64), camera[:0], observed[:0],
                              n_cameras, single, rules)
    X, ok = plane_candidates(box, camera, rig, planes, rules.min_cos)
    Dp = candidate_distances(X[0], observed, camera, ok[0])
    D = best_plane_distance(Dp)
    agree = False
    for i in range(K):
        for j in range(K):
            if group.shape[0] > 0 and group[i] != group[j]:
                D[i, j] = np.inf
            if apart.shape[0] > 0 and apart[i, j]:
                D[i, j] = np.inf
            if D[i, j] < threshold:
                agree = True
    if not agree and not any_single:  # no two views agree: every candidate is discarded
        return fuse_on_planes(X, ok, Dp, np.zeros(0, np.int64), camera[:0], observed[:0], n_cameras, single,
                              rules)
    labels = complete_linkage(D, threshold) if agree else np.arange(K)
    return fuse_on_planes(X, ok, Dp, labels, camera, observed, n_cameras, single, rules)


@njit(cache=True, error_model="numpy")
def plane_split(box, observed, camera, track2d, to_plane, D2, cut, person, prev_2d, prev_seen, rig, planes, rules,
                tspace, max_speed, at_mean, pspace):
    """The tracker's plane stage for the segments ``to_plane`` (int64 indices into the window's
    box (K, W, 4), observed (K, W), camera, track2d (K,)) in one call
    (:func:`gymtrack.tracking.plane_fallback.plane_split`): Eq. 2's separations (``D2`` (K, K)
    >= ``cut``; (0, 0): none) and oracle ids (``person`` (K,); (0,): none) as constraints, the
    one-view continuation (a 2D track among ``prev_2d`` or not among ``prev_seen``),
    :func:`plane_stage`, Eq. 4 (``tspace``; ``at_mean``: the space test on the tracklet's mean position),
    members to the window's segments, and one-view tracklets only inside ``pspace`` (any valid
    point outside drops them; (0,): no such test, the paper's cascade).
    Returns xyz, top_z, bottom_z, valid, source, n_views, members and (3,) int64 counts:
    tracklets fused, outliers, one-view tracklets outside."""
    K = len(to_plane)
    apart, group = constraints(to_plane, D2, cut, person)  # Eq. 2 says different people: never fused on the plane
    single = np.empty(K, np.bool_)
    for i in range(K):
        t = track2d[to_plane[i]]
        member, seen = False, False
        for q in range(len(prev_2d)):
            if prev_2d[q] == t:
                member = True
                break
        for q in range(len(prev_seen)):
            if prev_seen[q] == t:
                seen = True
                break
        single[i] = member or not seen
    xyz, top, bottom, valid, source, n_views, members = plane_stage(
        box[to_plane], observed[to_plane], camera[to_plane], rig, planes, PlaneConstraints(group, apart, single), rules)
    M, W = valid.shape
    stats = np.zeros(3, np.int64)
    stats[0] = M
    keep = np.ones(M, np.bool_)
    if M > 0:
        keep = ~(outliers_at_mean(xyz, valid, tspace, max_speed) if at_mean else outliers(xyz, valid, tspace, max_speed))
    for m in range(M):
        stats[1] += not keep[m]
        if not keep[m]:
            continue
        n = 0
        for c in range(members.shape[1]):
            if members[m, c] >= 0:
                n += 1
                members[m, c] = to_plane[members[m, c]]
        if n == 1 and len(pspace):  # one view alone only inside S_perf (NaN: outside)
            for t in range(W):
                x, y = xyz[m, t, 0], xyz[m, t, 1]
                if valid[m, t] and not (x >= pspace[0] and x <= pspace[3] and y >= pspace[1] and y <= pspace[4]):
                    keep[m] = False
                    stats[2] += 1
                    break
    if stats[1] + stats[2] > 0:  # (integer takes of the kept rows)
        rows = np.flatnonzero(keep)
        xyz, top, bottom, valid, source, n_views, members = (
            xyz[rows], top[rows], bottom[rows], valid[rows], source[rows], n_views[rows], members[rows])
    return xyz, top, bottom, valid, source, n_views, members, stats


def warm_up() -> None:
    """Compile (or load) the stage kernel: the sample person's two views fused on the plane,
    with and without constraints."""
    from ...geometry.arrays import PlaneArrays

    s = sample()
    rules = PlaneRules(1e-3, 0.5, PLANE, INTERPOLATED)
    planes = PlaneArrays.from_planes(s.planes)
    for given in (PlaneConstraints(NO_GROUP, NO_APART, NO_SINGLE),
                  PlaneConstraints(np.zeros(2, np.int64), np.zeros((2, 2), bool), np.ones(2, bool))):
        plane_stage(s.box, s.observed, s.camera, s.rig.arrays, planes, given, rules)
    i2, space = np.arange(2, dtype=np.int64), np.array([-1.0, -1.0, 0.0, 1.0, 1.0, 3.0])
    for D2, person in ((np.zeros((0, 0)), NO_GROUP), (np.zeros((2, 2)), i2)):
        for at_mean, pspace in ((True, space), (False, space[:0])):
            plane_split(s.box, s.observed, s.camera, i2, i2, D2, 1.0, person, i2, i2, s.rig.arrays, planes, rules, space,
                        0.5, at_mean, pspace)
