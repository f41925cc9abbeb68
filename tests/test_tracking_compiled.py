"""The compiled kernels (gymtrack.tracking._compiled) against plain numpy / scipy references.

The references are the vectorised numpy versions the kernels replaced (kept here verbatim, not
in the package) and, where one exists, an independent formula (Eq. 1 per pair, the geometry
module's triangulation). Random inputs plus edge cases: empty, one element, NaN / inf, ties.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from conftest import points_seen_by, random_rig, same
from gymtrack.geometry.epipolar import epipolar_distance, fundamental_matrices
from gymtrack.geometry.triangulation import triangulate_views as triangulate_views_numpy
from gymtrack.tracking import _compiled
from gymtrack.tracking.clustering import complete_linkage, complete_linkage_sequential, tracklet_distances
from gymtrack.tracking.linking import link_distances
from gymtrack.tracking.plane_fallback import candidate_distances
from gymtrack.tracking.reconstruct import GN_ITERATIONS, cluster_members, outliers, triangulate_clusters
from gymtrack.tracking.single_view import IoUTracker, assign, corners, iou_corners, iou_matrix
from gymtrack.tracking.types import WindowTracklets
from gymtrack.tracking.windows import fill_missing


# ============================================================ numpy references (the replaced code)
class IoUTrackerNumpy:
    """The IoU tracker before compilation: full IoU matrix over all cameras, one assignment."""

    def __init__(self, iou_threshold=0.1, max_age=2):
        self.iou_threshold, self.max_age = iou_threshold, max_age
        self.box, self.last, self.track_id, self.next_id = np.zeros((5, 0)), np.zeros(0, np.int64), np.zeros(0, np.int64), 0

    def update(self, frame, camera, box):
        if len(self.last) and self.last.min() < frame - self.max_age - 1:
            alive = frame - self.last <= self.max_age + 1
            self.box, self.last, self.track_id = self.box[:, alive], self.last[alive], self.track_id[alive]
        n = len(camera)
        cb = corners(box, camera)
        ids = np.full(n, -1, np.int64)
        if len(self.track_id) and n:
            iou = iou_corners(self.box, cb)
            r, c = assign(iou, iou >= self.iou_threshold)
            ids[c] = self.track_id[r]
            self.box[:, r] = cb[:, c]
            self.last[r] = frame
        new = np.flatnonzero(ids < 0)
        if len(new):
            new_ids = self.next_id + np.arange(len(new))
            self.next_id += len(new)
            ids[new] = new_ids
            self.box = np.concatenate([self.box, cb[:, new]], axis=1)
            self.last = np.concatenate([self.last, np.full(len(new), frame, np.int64)])
            self.track_id = np.concatenate([self.track_id, new_ids])
        return ids


def complete_linkage_numpy(D, threshold):
    """Algorithm 1 in vectorised reciprocal-nearest-neighbour rounds (the replaced numpy code)."""
    S = np.array(D, dtype=np.float64)
    K = S.shape[0]
    owner = np.arange(K)
    if K >= 2:
        np.fill_diagonal(S, np.nan)
        idx = np.arange(K)
        while True:
            W = np.fmin(S, np.inf)
            nn = np.argmin(W, axis=1)
            d = W[idx, nn]
            I = np.flatnonzero((nn[nn] == idx) & (idx < nn) & (d < threshold))
            if len(I) == 0:
                if not d.min() < threshold:
                    break
                I = np.array([int(np.argmin(d))])
            J = nn[I]
            S[I] = np.fmax(S[I], S[J])
            S[:, I] = np.fmax(S[:, I], S[:, J])
            S[J] = np.nan
            S[:, J] = np.nan
            S[I, I] = np.nan
            relabel = idx.copy()
            relabel[J] = I
            owner = relabel[owner]
    first = np.full(K, K)
    np.minimum.at(first, owner, np.arange(K))
    is_first = first[owner] == np.arange(K)
    return (np.cumsum(is_first) - 1)[first[owner]]


def tracklet_distances_numpy(segs, F):
    K, W = segs.observed.shape
    cam = segs.camera
    if K == 0:
        return np.zeros((0, 0))
    C = F.shape[0]
    obs, box = segs.observed, segs.box
    xh = np.empty((K, W, 3))
    xh[..., :2] = box[..., :2]
    xh[..., 2] = 1.0
    xh[~obs] = 0.0
    scale = np.abs(box[..., 2] + box[..., 3])
    scale[~obs] = 1.0
    xh /= scale[..., None]
    lines = (F[cam].reshape(K, 3 * C, 3) @ xh.transpose(0, 2, 1)).reshape(K, C, 3, W)
    norm = np.sqrt(lines[:, :, 0] ** 2 + lines[:, :, 1] ** 2)
    norm[norm == 0] = 1.0
    lines /= norm[:, :, None]
    full = (xh.transpose(1, 0, 2) @ lines.transpose(3, 2, 1, 0).reshape(W, 3, C * K)).reshape(W, K, C, K)
    S = np.abs(full[:, np.arange(K), cam, :]).sum(axis=0)
    obsf = obs.astype(np.float64)
    n = obsf @ obsf.T
    with np.errstate(invalid="ignore", divide="ignore"):
        D = (S + S.T) / n
    D[n == 0] = np.nan
    D[cam[:, None] == cam[None, :]] = np.inf
    return D


def outliers_numpy(xyz, valid, space, max_speed):
    M, W = valid.shape
    if M == 0:
        return np.zeros(0, bool)
    flat = xyz.reshape(M * W, 3)
    pts = flat.T
    inside = ((pts >= space[:3, None]) & (pts <= space[3:, None])).all(axis=0).reshape(M, W)
    bad = (valid & ~inside).any(axis=1) | ~valid.any(axis=1)
    t = np.arange(W)
    prev = np.maximum.accumulate(np.where(valid, t, -1), axis=1)
    later = np.flatnonzero(valid[:, 1:] & (prev[:, :-1] >= 0))
    if len(later):
        row = later // (W - 1)
        tt = later - row * (W - 1) + 1
        p = prev[row, tt - 1]
        d = flat[row * W + tt] - flat[row * W + p]
        bad[row[np.linalg.norm(d, axis=1) > max_speed * (tt - p)]] = True
    return bad


def link_distances_numpy(prev_xyz, prev_valid, new_xyz, new_valid, offset):
    Wo = prev_xyz.shape[1] - offset
    a, av = prev_xyz[:, offset:], prev_valid[:, offset:]
    b, bv = new_xyz[:, :Wo], new_valid[:, :Wo]
    both = av[:, None] & bv[None]
    d = np.linalg.norm(a[:, None] - b[None], axis=-1)
    n = both.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        D = np.where(both, d, 0.0).sum(axis=-1) / n
    D[n == 0] = np.nan
    return D


def candidate_distances_numpy(X, observed, camera, exists):
    ok = observed[None] & exists
    shared = ok[:, :, None] & ok[:, None, :]
    diff = X[:, :, None] - X[:, None, :]
    d = np.sqrt(np.einsum("pijtk,pijtk->pijt", diff, diff))
    n = shared.sum(axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        D = np.where(shared, d, 0.0).sum(axis=-1) / n
    D[:, camera[:, None] == camera[None, :]] = np.inf
    return D


def triangulate_clusters_numpy(segs, members, P):
    """(centre (M, W, 3), top_z, bottom_z, valid, n_views) as before compilation."""
    M, C = members.shape
    W = segs.width
    has = members >= 0
    b = segs.box[np.where(has, members, 0)].transpose(3, 1, 0, 2)
    x, y, half = np.where(has.T[:, :, None], b[0], np.nan), b[1], b[3] / 2
    u = np.empty((C, 3, M, W))
    v = np.empty((C, 3, M, W))
    u[:] = x[:, None]
    v[:, 0] = y
    v[:, 1] = y - half
    v[:, 2] = y + half
    X, _ = triangulate_views_numpy(P, u.reshape(C, -1), v.reshape(C, -1), iterations=GN_ITERATIONS)
    X = X.reshape(3, 3, M, W)
    centre = X[:, 0].transpose(1, 2, 0)
    valid = np.isfinite(centre).all(axis=2)
    obs = segs.observed[np.where(has, members, 0)] & has[..., None]
    return centre, X[2, 1], X[2, 2], valid, obs.sum(axis=1).astype(np.int8)


# ============================================================ helpers
def random_segments(rng, K, W=10, C=3, p_obs=0.7):
    camera = np.sort(rng.integers(0, C, K)).astype(np.int64)
    box = np.stack([rng.uniform(100, 1800, (K, W)), rng.uniform(100, 1000, (K, W)), rng.uniform(20, 200, (K, W)),
                    rng.uniform(40, 400, (K, W))], axis=-1)
    observed = rng.random((K, W)) < p_obs
    observed[np.arange(K), rng.integers(0, W, K)] = True
    box[~observed] = np.nan
    filled, valid = fill_missing(box, observed, 2)
    return WindowTracklets(0, camera, np.arange(K, dtype=np.int64), filled, observed, valid,
                           np.where(observed, 1, -1).astype(np.int64))


# ============================================================ tests
@pytest.mark.parametrize("seed", range(4))
def test_iou_tracker_matches_full_assignment(seed):
    """Crowded random frames (people drifting, appearing, vanishing, near-duplicate boxes):
    the same ids as one full-matrix assignment per frame."""
    rng = np.random.default_rng(seed)
    fast, ref = IoUTracker(0.1, 2), IoUTrackerNumpy(0.1, 2)
    P = 30
    pos = np.column_stack([rng.uniform(0, 600, P), rng.uniform(0, 400, P), rng.uniform(30, 90, P), rng.uniform(60, 180, P)])
    cam = rng.integers(0, 3, P)
    for frame in range(60):
        pos[:, :2] += rng.normal(0, 8, (P, 2))
        seen = rng.random(P) < (0.0 if frame == 7 else 0.85)  # frame 7: no boxes at all
        box = pos[seen] + rng.normal(0, 3, (int(seen.sum()), 4))
        c = cam[seen].astype(np.int64)
        if frame % 11 == 3 and len(box):  # a near-duplicate detection
            box = np.vstack([box, box[:1] + 0.5])
            c = np.append(c, c[0])
        assert np.array_equal(fast.update(frame, c, box), ref.update(frame, c, box))
        assert np.array_equal(fast.track_id, ref.track_id) and np.array_equal(fast.last, ref.last)


def test_iou_tracker_edge_cases():
    fast = IoUTracker()
    assert fast.update(0, np.zeros(0, np.int64), np.zeros((0, 4))).tolist() == []
    one = np.array([[10.0, 10.0, 4.0, 8.0]])
    assert fast.update(1, np.array([0]), one).tolist() == [0]
    assert fast.update(2, np.array([1]), one).tolist() == [1]  # same pixels, other camera: a new track
    assert fast.update(3, np.array([0, 1]), np.vstack([one, one])).tolist() == [0, 1]
    assert fast.update(7, np.array([0]), one).tolist() == [2]  # older than max_age: dropped
    assert len(fast) == 1
    # a tie: two identical tracks, one box -> the assignment takes one of them, the other box is new
    t = IoUTracker()
    t.update(0, np.array([0, 0]), np.vstack([one, one]))
    ids = t.update(1, np.array([0]), one)
    assert ids.tolist() == IoUTrackerNumpy().update(0, np.array([0, 0]), np.vstack([one, one]))[:1].tolist()
    same(iou_matrix(one, one), [[1.0]])


@pytest.mark.parametrize("K", [0, 1, 2, 7, 25])
def test_fill_missing_kernel_is_exact(rng, K):
    W = 10
    box = rng.normal(size=(K, W, 4))
    observed = rng.random((K, W)) < 0.4
    if K:
        observed[np.arange(K), rng.integers(0, W, K)] = True
    for max_ext in (0, 2, 20):
        a, av = fill_missing(box, observed, max_ext)
        b, bv = _compiled.fill_missing(box, observed, max_ext)
        assert np.array_equal(av, bv)
        assert np.array_equal(a, b, equal_nan=True)


@pytest.mark.parametrize("K", [0, 1, 2, 12, 40])
def test_tracklet_distances_kernel(rng, K):
    rig = random_rig(rng, 3)
    F = fundamental_matrices(rig)
    segs = random_segments(rng, K)
    D = tracklet_distances(segs, F)
    same(D, tracklet_distances_numpy(segs, F))
    # and Eq. 1 pair by pair, averaged over the shared observed frames
    for i in range(K):
        for j in range(K):
            if segs.camera[i] == segs.camera[j]:
                assert D[i, j] == np.inf
                continue
            both = segs.observed[i] & segs.observed[j]
            if not both.any():
                assert np.isnan(D[i, j])
                continue
            e = epipolar_distance(segs.box[i, both], segs.box[j, both], F[segs.camera[i], segs.camera[j]])
            assert D[i, j] == pytest.approx(e.mean(), rel=1e-9)


@pytest.mark.parametrize("seed", range(20))
def test_complete_linkage_kernel(seed):
    rng = np.random.default_rng(seed)
    K = int(rng.integers(0, 30))
    if seed % 2:  # integer distances: many exact ties
        D = rng.integers(0, 6, (K, K)).astype(np.float64) / 10
    else:
        D = rng.uniform(0, 1, (K, K))
    D = np.minimum(D, D.T)
    D[rng.random((K, K)) < 0.2] = np.nan
    D[rng.random((K, K)) < 0.1] = np.inf
    D = np.where(np.isnan(D) | np.isnan(D.T), np.nan, np.maximum(D, D.T))
    for thr in (0.05, 0.3, 0.7):
        labels = complete_linkage(D, thr)
        assert labels.dtype == np.int64
        assert np.array_equal(labels, complete_linkage_numpy(D, thr))
        if seed % 2 == 0:  # without ties also the literal one-merge-at-a-time loop
            assert np.array_equal(labels, complete_linkage_sequential(D, thr))


def test_complete_linkage_kernel_small():
    assert complete_linkage(np.zeros((0, 0)), 0.3).tolist() == []
    assert complete_linkage(np.zeros((1, 1)), 0.3).tolist() == [0]
    assert complete_linkage(np.array([[0.0, 0.1], [0.1, 0.0]]), 0.3).tolist() == [0, 0]
    assert complete_linkage(np.array([[0.0, np.nan], [np.nan, 0.0]]), 0.3).tolist() == [0, 1]
    assert complete_linkage(np.array([[0.0, np.inf], [np.inf, 0.0]]), 0.3).tolist() == [0, 1]


@pytest.mark.parametrize("iterations", [0, 1, 3])
def test_triangulation_kernel(rng, iterations):
    rig = random_rig(rng, 4)
    P = rig.projections
    X = points_seen_by(rng, list(rig), 200)
    uv = np.stack([cam.project(X, distort=False) for cam in rig]) + rng.normal(0, 2.0, (4, 200, 2))
    u, v = uv[..., 0].copy(), uv[..., 1].copy()
    mask = rng.random((4, 200)) < 0.6
    mask[:, :3] = False  # no view
    mask[0, 3:6] = True  # (and exactly one view for the next three)
    mask[1:, 3:6] = False
    u[~mask & (rng.random((4, 200)) < 0.5)] = np.nan  # masked views may hold NaN
    Xk, ek = _compiled.triangulate_views(P, u, v, mask, iterations)
    Xr, er = triangulate_views_numpy(P, u, v, mask, iterations)
    assert np.all(np.isnan(Xk[:, :6]))
    same(Xk, Xr, rtol=1e-7, atol=1e-7)
    same(ek, er, rtol=1e-6, atol=1e-7)
    Xe, _ = _compiled.triangulate_views(P, np.zeros((4, 0)), np.zeros((4, 0)), np.zeros((4, 0), bool), 1)
    assert Xe.shape == (3, 0)


@pytest.mark.parametrize("K", [1, 6, 20])
def test_triangulate_clusters_kernel(rng, K):
    rig = random_rig(rng, 3)
    segs = random_segments(rng, K)
    labels = np.zeros(K, np.int64)  # at most one segment per camera per cluster
    for c in range(3):
        labels[segs.camera == c] = np.arange(np.count_nonzero(segs.camera == c))
    members = cluster_members(labels, segs.camera, 3)
    tri = triangulate_clusters(segs, members, rig.projections)
    centre, top, bottom, valid, n_views = triangulate_clusters_numpy(segs, members, rig.projections)
    assert np.array_equal(tri.valid, valid) and np.array_equal(tri.n_views, n_views)
    same(tri.xyz, centre, rtol=1e-7, atol=1e-7)
    same(tri.top_z, top, rtol=1e-7, atol=1e-7)
    same(tri.bottom_z, bottom, rtol=1e-7, atol=1e-7)


@pytest.mark.parametrize("M", [0, 1, 5, 30])
def test_outliers_kernel(rng, M):
    W = 10
    xyz = rng.normal(0, 1, (M, W, 3)).cumsum(axis=1) * 0.05
    valid = rng.random((M, W)) < 0.7
    if M:
        valid[0] = False  # nothing valid: an outlier
    xyz[~valid] = np.nan
    space = np.array([-0.3, -0.3, -0.3, 0.3, 0.3, 0.3])
    for speed in (0.02, 0.05, 1.0):
        assert np.array_equal(outliers(xyz, valid, space, speed), outliers_numpy(xyz, valid, space, speed))


@pytest.mark.parametrize("shape", [(0, 3), (3, 0), (1, 1), (8, 11)])
def test_link_distances_kernel(rng, shape):
    W, step = 10, 5
    a = rng.normal(size=(shape[0], W, 3))
    b = rng.normal(size=(shape[1], W, 3))
    av = rng.random((shape[0], W)) < 0.6
    bv = rng.random((shape[1], W)) < 0.6
    same(link_distances(a, av, b, bv, step), link_distances_numpy(a, av, b, bv, step))


@pytest.mark.parametrize("K", [0, 1, 9])
def test_candidate_distances_kernel(rng, K):
    P, W = 2, 10
    X = rng.normal(size=(P, K, W, 3))
    observed = rng.random((K, W)) < 0.7
    exists = rng.random((P, K, W)) < 0.8
    camera = rng.integers(0, 3, K).astype(np.int64)
    same(candidate_distances(X, observed, camera, exists), candidate_distances_numpy(X, observed, camera, exists))


def test_lsa_reference_sanity():
    """The reference assignment itself: scipy's solver on the assign() cost picks the best total."""
    score = np.array([[0.5, 0.4], [0.45, 0.0]])
    r, c = assign(score, score >= 0.1)
    assert sorted(zip(r.tolist(), c.tolist())) == [(0, 1), (1, 0)]
    assert linear_sum_assignment(-score)[1].tolist() == [1, 0]

