"""The plane stage's compiled kernels (paper Section III-C, Eq. 5-9) against numpy references.

The references are the vectorised numpy versions of :mod:`gymtrack.tracking.plane_fallback`
that the kernels replaced (``tests/reference/plane.py``, with the kernel's steps one at a time);
the candidates are also checked against :func:`gymtrack.geometry.plane.intersect_rays_plane` and
its status codes (PARALLEL, BEHIND). Inputs: people on and off the plane seen by a ring of cameras, false positives, NaN
boxes, several planes (one behind some cameras, one containing a camera centre), and the
edge cases (no segment, one segment, no plane).
"""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.geometry.plane import Plane, RayPlaneStatus
from gymtrack.tracking import INTERPOLATED, PLANE
from gymtrack.tracking.plane_fallback import plane_stage
from gymtrack.tracking.types import WindowTracklets, WindowTracklets3D
from gymtrack.tracking.windows import fill_missing
from reference.clustering import complete_linkage_sequential
from reference.plane import (best_plane_distance, best_plane_distance_numpy, candidate_distances,
                             candidate_distances_numpy, candidates, candidates_numpy, fuse_on_planes,
                             fuse_on_planes_numpy, plane_candidates, plane_stage_numpy)
from conftest import person_boxes, ring_rig, same

W = 10
THRESHOLD = 0.5


# ============================================================ inputs
RIG = ring_rig([0, 80, 185, 265])  # camera 0 on +x, 2 near -x (nearly opposite), 1 / 3 near +-y
PLANES = [
    Plane(np.zeros(3), np.array([1.0, 0, 0])),  # x = 0, the scene's plane
    Plane(np.array([0.0, 1.5, 0]), np.array([0.2, 1.0, 0])),  # a second, tilted plane
    Plane(np.array([13.0, 0, 0]), np.array([1.0, 0, 0])),  # behind camera 0 (at x = 12), in front of 2
    Plane(np.zeros(3), np.array([0, 0, 1.0])),  # the floor: the box tops' rays of far cameras miss it
]


def scenario(rng, n_people=3, n_false=2, p_view=0.8, noise=2.0, nan_boxes=0):
    """Segments of people walking near the plane x = 0 (0.0-0.6 m off it) plus false positives."""
    cams, boxes, observed = [], [], []
    for _ in range(n_people):
        x0 = rng.uniform(-0.6, 0.6) * rng.integers(0, 2)
        start = np.array([x0, rng.uniform(-2, 2), rng.uniform(0.9, 1.3)])
        traj = start + np.outer(np.arange(W), rng.normal(0, 0.05, 3))
        for c in range(len(RIG)):
            if rng.random() < p_view:
                cams.append(c)
                boxes.append(person_boxes(RIG[c], traj) + rng.normal(0, noise, (W, 4)))
                observed.append(rng.random(W) < 0.8)
    for _ in range(n_false):
        cams.append(int(rng.integers(0, len(RIG))))
        boxes.append(np.column_stack([rng.uniform(200, 1700, W), rng.uniform(200, 900, W), np.full(W, 60.0),
                                      np.full(W, 150.0)]))
        observed.append(rng.random(W) < 0.8)
    K = len(cams)
    box = np.array(boxes).reshape(K, W, 4)
    obs = np.array(observed).reshape(K, W)
    obs[np.arange(K), rng.integers(0, W, K)] = True
    box[~obs] = np.nan
    filled, valid = fill_missing(box, obs, 2)
    for _ in range(nan_boxes):  # a NaN box where the segment claims to be observed: no candidate
        k, t = rng.integers(0, K), rng.integers(0, W)
        filled[k, t, rng.integers(0, 4)] = np.nan
    order = rng.permutation(K)
    return WindowTracklets(7, np.array(cams, np.int64)[order], np.arange(K, dtype=np.int64) + 100, filled[order],
                           obs[order], valid[order], np.full((K, W), -1, np.int64))


def same_tracklets(a: WindowTracklets3D, b: WindowTracklets3D):
    assert a.start == b.start
    for name in ("xyz", "top_z", "bottom_z"):
        same(getattr(a, name), getattr(b, name))
    for name in ("valid", "source", "n_views", "members", "track_id"):
        x, y = getattr(a, name), getattr(b, name)
        assert x.dtype == y.dtype and x.shape == y.shape and np.array_equal(x, y), name


# ============================================================ tests
@pytest.mark.parametrize("seed", range(4))
def test_candidates_kernel_matches_intersect_rays_plane(seed):
    rng = np.random.default_rng(seed)
    segs = scenario(rng, nan_boxes=3)
    X, status = candidates_numpy(segs, RIG, PLANES)
    got = plane_candidates(segs, RIG, PLANES)
    same(got, X)
    # every outcome occurs: hits, the plane behind camera 0, invalid (NaN) boxes
    assert (status == RayPlaneStatus.OK).any() and (status == RayPlaneStatus.BEHIND).any()
    assert (status == RayPlaneStatus.PARALLEL).any()
    assert np.array_equal(np.isfinite(got).all(axis=-1), status == RayPlaneStatus.OK)
    same(plane_candidates(segs, RIG, PLANES, ("bottom", "centre")), X[[2, 0]])  # any subset, in order
    _, ok = candidates(segs, RIG, PLANES)
    assert np.array_equal(ok, status == RayPlaneStatus.OK)


def test_candidates_parallel_and_behind():
    cam = RIG[0]
    K = cam.K
    # a box centred on the principal point: its ray is the optical axis
    box = np.array([[[K[0, 2], K[1, 2], 50.0, 100.0]] * W])
    segs = WindowTracklets(0, np.array([0]), np.array([0]), box, np.ones((1, W), bool), np.ones((1, W), bool),
                           np.zeros((1, W), np.int64))
    axis = cam.R[2]
    planes = [
        Plane(cam.centre + 5 * axis, cam.R[0]),  # contains the optical axis: parallel
        Plane(cam.centre + 5 * axis, axis),  # 5 m ahead, facing the camera: hit
        Plane(cam.centre - 5 * axis, axis),  # 5 m behind the camera
    ]
    X = plane_candidates(segs, RIG, planes)
    assert np.isnan(X[0, 0]).all()  # parallel centre ray: no candidate
    np.testing.assert_allclose(X[0, 1], np.broadcast_to(cam.centre + 5 * axis, (1, W, 3)), atol=1e-9)
    assert np.isnan(X[:, 2]).all()  # behind: no candidate for any point
    assert np.isfinite(X[1:, 1]).all()  # the top / bottom rays hit the plane ahead
    _, status = candidates_numpy(segs, RIG, planes)
    assert (status[0, 0] == RayPlaneStatus.PARALLEL).all() and (status[:, 2] == RayPlaneStatus.BEHIND).all()


def test_candidates_no_segments():
    segs = scenario(np.random.default_rng(0)).subset(np.zeros(0, np.int64))
    assert plane_candidates(segs, RIG, PLANES).shape == (3, len(PLANES), 0, W, 3)
    assert plane_candidates(segs, RIG, PLANES[:1], ("top",)).shape == (1, 1, 0, W, 3)


@pytest.mark.parametrize("P", [1, 2, 3])
def test_best_plane_distance_kernel(P):
    rng = np.random.default_rng(P)
    Dp = rng.uniform(0, 2, (P, 9, 9))
    Dp[rng.random(Dp.shape) < 0.3] = np.nan
    Dp[rng.random(Dp.shape) < 0.1] = np.inf
    Dp[:, 0, 1] = np.nan  # unknown on every plane: stays unknown
    same(best_plane_distance(Dp), best_plane_distance_numpy(Dp))
    assert np.isnan(best_plane_distance(Dp)[0, 1])
    assert best_plane_distance(np.zeros((P, 0, 0))).shape == (0, 0)


@pytest.mark.parametrize("seed", range(6))
def test_fuse_on_planes_kernel(seed):
    rng = np.random.default_rng(seed)
    segs = scenario(rng, n_people=4, nan_boxes=2)
    planes = PLANES[: 1 + seed % 3]
    cand, status = candidates_numpy(segs, RIG, planes)
    exists = status == RayPlaneStatus.OK
    Dp = candidate_distances_numpy(cand[0], segs.observed, segs.camera, exists[0])
    labels = complete_linkage_sequential(best_plane_distance_numpy(Dp), THRESHOLD)
    single = rng.random(len(segs)) < 0.5
    for s in (None, single):
        ref = fuse_on_planes_numpy(segs, cand, Dp, labels, len(RIG), s, exists)
        same_tracklets(fuse_on_planes(segs, cand, Dp, labels, len(RIG), s, exists), ref)
        same_tracklets(fuse_on_planes(segs, cand, Dp, labels, len(RIG), s), ref)  # exists from finiteness
    every = np.arange(len(segs))  # every segment alone: only the permitted singles are kept
    out = fuse_on_planes(segs, cand, Dp, every, len(RIG), single, exists)
    assert np.array_equal(out.members.max(axis=1), np.flatnonzero(single))
    same_tracklets(out, fuse_on_planes_numpy(segs, cand, Dp, every, len(RIG), single, exists))


def test_plane_stage_kernel_matches_numpy():
    n_fused = 0
    for seed in range(16):
        rng = np.random.default_rng(100 + seed)
        segs = scenario(rng, n_people=int(rng.integers(1, 5)), n_false=int(rng.integers(0, 3)), nan_boxes=seed % 2)
        K = len(segs)
        planes = [PLANES[i] for i in rng.permutation(len(PLANES))[: 1 + seed % 4]]
        single = rng.random(K) < 0.3
        apart = rng.random((K, K)) < 0.2
        apart |= apart.T
        groups = rng.integers(0, 3, K)
        for kw in ({}, {"single": single}, {"apart": apart}, {"labels": groups}, {"single": single, "apart": apart}):
            got = plane_stage(segs, RIG, planes, THRESHOLD, **kw)
            same_tracklets(got, plane_stage_numpy(segs, RIG, planes, THRESHOLD, **kw))
            n_fused += int(((got.members >= 0).sum(axis=1) >= 2).sum())
    assert n_fused >= 20  # the comparisons above are mostly of non-empty results


def test_plane_stage_fuses_a_person_on_the_plane():
    """Two views of one person standing on the plane: one tracklet, on the plane, from both."""
    t = np.arange(W)
    traj = np.stack([np.zeros(W), -1 + 0.1 * t, np.full(W, 1.1)], axis=1)
    box = np.stack([person_boxes(RIG[c], traj) for c in (0, 1)])
    obs = np.ones((2, W), bool)
    segs = WindowTracklets(3, np.array([0, 1]), np.array([5, 6]), box, obs, obs, np.zeros((2, W), np.int64))
    out = plane_stage(segs, RIG, PLANES[:1], THRESHOLD)
    assert len(out) == 1 and out.members.tolist() == [[0, 1, -1, -1]]
    assert out.valid.all() and (out.source == PLANE).all() and (out.n_views == 2).all()
    np.testing.assert_allclose(out.xyz[0, :, 0], 0.0, atol=1e-9)
    assert np.median(np.linalg.norm(out.xyz[0] - traj, axis=1)) < 0.1
    assert np.all(out.top_z > out.xyz[..., 2]) and np.all(out.bottom_z < out.xyz[..., 2])
    # the same two segments known apart, or in different oracle groups: nothing fused
    assert len(plane_stage(segs, RIG, PLANES[:1], THRESHOLD, apart=~np.eye(2, dtype=bool))) == 0
    assert len(plane_stage(segs, RIG, PLANES[:1], THRESHOLD, labels=np.array([0, 1]))) == 0


def test_plane_stage_edge_cases():
    segs = scenario(np.random.default_rng(3), n_people=2)
    C = len(RIG)
    empty = segs.subset(np.zeros(0, np.int64))
    one = segs.subset(np.array([0]))
    for s, kw in ((empty, {}), (one, {}), (one, {"single": np.array([False])}), (segs, {"planes": []})):
        out = plane_stage(s, RIG, kw.pop("planes", PLANES), THRESHOLD, **kw)
        same_tracklets(out, WindowTracklets3D.empty(s.start, W, C))
    # one segment that may stand alone: a one-view plane tracklet (on the first plane)
    out = plane_stage(one, RIG, PLANES[:1], THRESHOLD, single=np.array([True]))
    same_tracklets(out, plane_stage_numpy(one, RIG, PLANES[:1], THRESHOLD, single=np.array([True])))
    assert len(out) == 1 and out.members[0].max() == 0 and (out.members[0] >= 0).sum() == 1
    assert set(np.unique(out.source)) <= {PLANE, INTERPOLATED}
    # every box NaN: no candidate exists, nothing fused even when singles are allowed
    nan = WindowTracklets(0, segs.camera, segs.track2d, np.full_like(segs.box, np.nan), segs.observed, segs.valid,
                          segs.det)
    assert len(plane_stage(nan, RIG, PLANES, THRESHOLD)) == 0
    out = plane_stage(nan, RIG, PLANES, THRESHOLD, single=np.ones(len(segs), bool))
    same_tracklets(out, plane_stage_numpy(nan, RIG, PLANES, THRESHOLD, single=np.ones(len(segs), bool)))
    assert not out.valid.any()


def test_candidate_distances_on_the_kernel_candidates():
    """Eq. 8 of the compiled candidates equals the numpy Eq. 8 of the numpy candidates."""
    segs = scenario(np.random.default_rng(11), n_people=4)
    X, status = candidates_numpy(segs, RIG, PLANES)
    got = plane_candidates(segs, RIG, PLANES, ("centre",))[0]
    same(candidate_distances(got, segs.observed, segs.camera),
         candidate_distances_numpy(X[0], segs.observed, segs.camera, status[0] == RayPlaneStatus.OK))


@pytest.mark.parametrize("plus", [True, False])
def test_plane_split_matches_the_cascades_path_around_the_stage(plus):
    """The tracker's one call (plane_fallback.plane_split) against the numpy stage with the steps
    the tracker ran around it: random segments to the plane, Eq. 2 separations, oracle ids,
    one-view continuations, and spaces that drop some tracklets (Eq. 4; cascade+: Eq. 4 by place
    and one view outside S_perf; the paper's cascade: Eq. 4 on every point, no S_perf test)."""
    from types import SimpleNamespace

    from gymtrack.geometry.arrays import PlaneArrays
    from gymtrack.tracking.plane_fallback import plane_split
    from reference.plane import plane_split_numpy

    keys = ("segments_to_plane", "tracklets_outliers", "plane_single_view_outside", "plane_tracklets")
    total = dict.fromkeys(keys, 0)
    for seed in range(24):
        rng = np.random.default_rng(300 + seed)
        segs = scenario(rng, n_people=int(rng.integers(1, 5)), n_false=int(rng.integers(0, 3)), nan_boxes=seed % 2)
        K = len(segs)
        to_plane = np.sort(rng.choice(K, int(rng.integers(1, K + 1)), replace=False)).astype(np.int64)
        planes = [PLANES[i] for i in rng.permutation(len(PLANES))[: 1 + seed % 3]]
        D2 = rng.uniform(0, 40, (K, K))
        D2 = (D2 + D2.T) / 2
        prev_seen = rng.choice(segs.track2d, int(rng.integers(0, K + 1)), replace=False)
        prev_2d = prev_seen[: len(prev_seen) // 2]
        params = SimpleNamespace(cluster_2d=30.0, cluster_plane=THRESHOLD, max_speed=float(rng.choice([0.3, 1.0])))
        tspace = np.array([-1.0, -1.9, 0.0, 1.0, 1.9, 3.0])
        pspace = np.array([-0.4, -1.0, 0.0, 0.4, 1.0, 3.0])
        for d2, oracle in ((None, False), (D2, False), (None, True)):
            counts, counts_r = dict.fromkeys(keys, 0), dict.fromkeys(keys, 0)
            ps = pspace if plus else None
            got = plane_split(segs, to_plane, d2, RIG.arrays, PlaneArrays.from_planes(planes), params, oracle, prev_2d,
                              prev_seen, tspace, ps, counts, at_mean=plus)
            want = plane_split_numpy(segs, to_plane, d2, RIG, planes, params, oracle, prev_2d, prev_seen, tspace, ps,
                                     counts_r, at_mean=plus)
            assert counts == counts_r and (got is None) == (want is None)
            if got is not None:
                same_tracklets(got, want)
            for k in keys:
                total[k] += counts[k]
    assert total["plane_tracklets"] > 10 and total["tracklets_outliers"] > 3
    assert total["plane_single_view_outside"] > 3 if plus else total["plane_single_view_outside"] == 0
