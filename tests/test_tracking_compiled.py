"""The compiled kernels (gymtrack.tracking._kernels) against plain numpy / scipy references.

The references are the vectorised numpy versions the kernels replaced (``tests/reference/``) and, where one exists, an independent formula (Eq. 1 per pair, the geometry
module's triangulation). Random inputs plus edge cases: empty, one element, NaN / inf, ties.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import linear_sum_assignment

from conftest import points_seen_by, random_rig, same
from gymtrack.geometry.epipolar import epipolar_distance, fundamental_matrices
from gymtrack.geometry.primitives import triangulate_points
from gymtrack.geometry.triangulation import triangulate_views as triangulate_views_numpy
from gymtrack.tracking._kernels import windows as window_kernels
from gymtrack.tracking.clustering import complete_linkage, tracklet_distances
from gymtrack.tracking.linking import link_distances, merge_overlaps
from gymtrack.tracking.reconstruct import cluster_members, outliers, outliers_at_mean, triangulate_clusters
from gymtrack.tracking.single_view import IoUTracker, assign, iou_matrix
from gymtrack.tracking.types import WindowTracklets
from gymtrack.tracking.windows import fill_missing
from gymtrack.tracking.single_view_motion import MotionIoUTracker
from reference.clustering import complete_linkage_numpy, complete_linkage_sequential, tracklet_distances_numpy
from reference.linking import link_distances_numpy, merge_overlaps_numpy
from reference.plane import candidate_distances, candidate_distances_numpy
from reference.reconstruct import outliers_at_mean_numpy, outliers_numpy, triangulate_clusters_numpy
from reference.single_view import IoUTrackerNumpy
from reference.single_view_motion import MotionIoUTrackerNumpy
from reference.windows import fill_missing as fill_missing_numpy


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


@pytest.mark.parametrize("seed", range(4))
def test_motion_tracker_matches_full_assignment(seed):
    """A crowd at 2 fps in 4 views (people walking up to 0.6 body heights a frame, turning,
    missed, near-duplicate boxes, a whole view empty for a frame): the kernel, which compares a
    view's tracks with that view's boxes only and solves only the conflicts, gives the same ids,
    state and link counts as one full-matrix assignment over all views per frame."""
    rng = np.random.default_rng(seed)
    fast, ref = MotionIoUTracker(2.0), MotionIoUTrackerNumpy(2.0)
    P = 60
    h = rng.uniform(60, 240, P)
    pos = np.column_stack([rng.uniform(0, 1500, P), rng.uniform(200, 900, P)])
    vel = rng.normal(0, 0.3, (P, 2)) * h[:, None]
    cam = rng.integers(0, 4, P)
    for frame in range(40):
        vel += rng.normal(0, 0.1, (P, 2)) * h[:, None]
        pos += vel
        seen = (rng.random(P) < 0.85) & ((cam != 2) | (frame != 9))
        box = np.column_stack([pos, 0.4 * h, h])[seen] * rng.normal(1, 0.02, (int(seen.sum()), 4))
        c = cam[seen].astype(np.int64)
        if frame % 7 == 3 and len(box):  # a near-duplicate detection: two boxes compete for a track
            box, c = np.vstack([box, box[:1] + 2.0]), np.append(c, c[0])
        assert np.array_equal(fast.update(frame, c, box), ref.update(frame, c, box))
        assert np.array_equal(fast.track_id, ref.track_id) and np.array_equal(fast.last, ref.last)
        assert np.allclose(fast.vel, ref.vel) and np.array_equal(fast.has_vel, ref.has_vel)
    assert fast.counts == ref.counts
    assert fast.counts["links_2d_motion"] > 50 and fast.counts["links_2d_overlap"] > 50  # both kinds occur


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
        a, av = fill_missing_numpy(box, observed, max_ext)
        b, bv = window_kernels.fill_missing(box, observed, max_ext)
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
    Xk, ek = triangulate_points(P, u, v, mask, iterations)
    Xr, er = triangulate_views_numpy(P, u, v, mask, iterations)
    assert np.all(np.isnan(Xk[:, :6]))
    same(Xk, Xr, rtol=1e-7, atol=1e-7)
    same(ek, er, rtol=1e-6, atol=1e-7)
    Xe, _ = triangulate_points(P, np.zeros((4, 0)), np.zeros((4, 0)), np.zeros((4, 0), bool), 1)
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
        assert np.array_equal(outliers_at_mean(xyz, valid, space, speed),
                              outliers_at_mean_numpy(xyz, valid, space, speed))


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



@pytest.mark.parametrize("best_only", [False, True])
@pytest.mark.parametrize("n", [1, 2, 60])
def test_merge_overlaps_kernel(rng, n, best_only):
    # Eq. 12: compiled vs numpy on random rows, groups of 1-4 estimates per (frame, track), NaN heights
    frame = rng.integers(3, 9, n)
    track = rng.integers(0, 4, n) * 7
    xyz = rng.normal(size=(n, 3)) * [1.0, 1e6, 1e-6]  # wide magnitudes: summation order shows
    top = np.where(rng.random(n) < 0.3, np.nan, rng.normal(size=n))
    bottom = np.where(rng.random(n) < 0.3, np.nan, rng.normal(size=n))
    source = rng.integers(0, 3, n).astype(np.int8)
    views = rng.integers(0, 5, n).astype(np.int8)
    got = merge_overlaps(frame, track, xyz, top, bottom, source, views, best_only)
    want = merge_overlaps_numpy(frame, track, xyz, top, bottom, source, views, best_only)
    for f in ("frame", "track_id", "xyz", "top_z", "bottom_z", "source", "n_views"):
        g, w = getattr(got, f), getattr(want, f)
        assert g.dtype == w.dtype and np.array_equal(g, w, equal_nan=True), f  # bit-identical


@pytest.mark.parametrize("seed", range(6))
def test_link_by_2d_kernel(seed):
    # cascade+'s link by 2D tracks: compiled vs numpy on random windows (few ids: many hits, ties and conflicts)
    from gymtrack.tracking._kernels.linking import link_by_2d
    from reference.linking import link_by_2d_numpy
    rng = np.random.default_rng(seed)
    M, C, K = 8, 4, 12
    members = np.where(rng.random((M, C)) < 0.5, rng.integers(0, K, (M, C)), -1).astype(np.int64)
    track2d = rng.integers(0, 8, K).astype(np.int64)
    prev_2d = rng.permutation(8)[:7].astype(np.int64)
    prev_owner = rng.integers(0, 3, 7).astype(np.int64) // 2  # (mostly one owner: links are made)
    ids = np.where(rng.random(M) < 0.2, rng.integers(0, 3, M), -1).astype(np.int64)
    rows = np.flatnonzero((members >= 0).sum(1) >= 1)
    a, b = ids.copy(), ids.copy()
    assert link_by_2d(rows, members, track2d, prev_2d, prev_owner, a) == link_by_2d_numpy(
        rows, members, track2d, prev_2d, prev_owner, b)
    assert np.array_equal(a, b)


def test_opposite_clusters_and_fallback_segments_match_numpy():
    """The cascade's two-view opposite clusters (any symmetric or one-sided pair table) and the
    segments of the fallback clusters, against the numpy table lookup and take."""
    from gymtrack.tracking.reconstruct import fallback_segments, opposite_clusters
    from reference.reconstruct import fallback_segments_numpy, opposite_clusters_numpy

    rng = np.random.default_rng(12)
    hits = 0
    for _ in range(200):
        M, C = int(rng.integers(0, 9)), int(rng.integers(2, 7))
        members = np.where(rng.random((M, C)) < 0.4, rng.integers(0, 40, (M, C)), -1)
        opposite = rng.random((C, C)) < 0.3
        got = opposite_clusters(members, opposite)
        assert got.dtype == bool and np.array_equal(got, opposite_clusters_numpy(members, opposite))
        hits += int(got.sum())
        fallback = got | (rng.random(M) < 0.3)
        seg = fallback_segments(members, fallback)
        want = fallback_segments_numpy(members, fallback)
        assert seg.dtype == want.dtype and np.array_equal(seg, want)
    assert hits > 20
