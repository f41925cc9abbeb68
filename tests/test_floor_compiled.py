"""The compiled floor of cascade+ (tracking._kernels.floor) against the numpy code it replaced
(tests/reference/floor.py), on random windows: people on the floor and in the air seen by a
ring of cameras, with noise, gaps, wrong boxes, constraints and several planes. Ids, members and
decisions must be identical; coordinates equal to rounding."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from conftest import ring_rig
from gymtrack.geometry.plane import Plane
from gymtrack.tracking import floor
from gymtrack.tracking.types import WindowTracklets, WindowTracklets3D
from reference import floor as ref

W = 10
SPACE = np.array([-3.0, -3.0, 0.0, 3.0, 3.0, 4.5])


def _window(rng, rig, n_people):
    """Segments of n_people (feet on the floor or up to 1.5 m up, some outside the space), one per
    camera that sees them, with pixel noise, invalid and unobserved frames and a few random boxes."""
    box, cam = [], []
    for _ in range(n_people):
        x, y = rng.uniform(-6, 6, 2)
        zb = 0.0 if rng.random() < 0.6 else rng.uniform(0.0, 1.5)
        zt = zb + rng.uniform(0.5, 2.2)
        for c, camera in enumerate(rig):
            if rng.random() < 0.2:
                continue
            P = camera.P
            pts = np.array([[x, y, zb, 1.0], [x, y, zt, 1.0]]) @ P.T
            uv = pts[:, :2] / pts[:, 2:]
            uv = uv + rng.normal(0, 2.0, (W, 2, 2))
            h = uv[:, 0, 1] - uv[:, 1, 1]
            bx = np.stack([uv[:, 0, 0], (uv[:, 0, 1] + uv[:, 1, 1]) / 2, 0.4 * np.abs(h), h], axis=-1)
            if rng.random() < 0.1:
                bx = rng.uniform(0, 1500, (W, 4))
            box.append(bx)
            cam.append(c)
    K = len(cam)
    box = np.array(box).reshape(K, W, 4)
    valid = rng.random((K, W)) < 0.9
    observed = valid & (rng.random((K, W)) < 0.8)
    box[~valid] = np.nan
    order = np.argsort(cam, kind="stable")
    return WindowTracklets(0, np.array(cam, np.int64)[order], np.arange(K, dtype=np.int64), box[order],
                           observed[order], valid[order], np.arange(K * W).reshape(K, W))


def _same_tracklets(a: WindowTracklets3D, b: WindowTracklets3D):
    assert a.members.tolist() == b.members.tolist()
    assert np.array_equal(a.valid, b.valid) and np.array_equal(a.source, b.source)
    assert np.array_equal(a.n_views, b.n_views) and np.array_equal(a.track_id, b.track_id)
    for x, y in ((a.xyz, b.xyz), (a.top_z, b.top_z), (a.bottom_z, b.bottom_z)):
        assert np.allclose(x, y, rtol=0, atol=1e-9, equal_nan=True)


@pytest.mark.parametrize("seed", range(25))
def test_floor_candidates_and_stage_match_numpy(seed):
    rng = np.random.default_rng(seed)
    rig = ring_rig(sorted(rng.choice(360, size=rng.integers(2, 5), replace=False)), radius=10.0, height=3.0)
    segs = _window(rng, rig, rng.integers(0, 6))
    foot, height, ok = floor.floor_candidates(segs, rig.arrays)
    foot_r, height_r, ok_r = ref.floor_candidates(segs, rig.arrays)
    assert np.array_equal(ok, ok_r)
    assert np.allclose(foot[ok], foot_r[ok], rtol=0, atol=1e-9) and np.allclose(height[ok], height_r[ok], rtol=0, atol=1e-9)
    K = len(segs)
    a = rng.random((K, K)) < 0.2
    apart = a | a.T
    labels = rng.integers(0, 3, K)
    for kw in ({}, {"apart": apart}, {"labels": labels}):
        fl, used = floor.floor_stage(segs, rig.arrays, 0.5, SPACE, **kw)
        fl_r, used_r = ref.floor_stage(segs, rig.arrays, 0.5, SPACE, **kw)
        assert used.tolist() == used_r.tolist()
        _same_tracklets(fl, fl_r)


def test_floor_stage_random_windows_take_something():
    """The random windows above are not all trivial: the floor takes segments in many of them."""
    taken = 0
    for seed in range(25):
        rng = np.random.default_rng(seed)
        rig = ring_rig(sorted(rng.choice(360, size=rng.integers(2, 5), replace=False)), radius=10.0, height=3.0)
        segs = _window(rng, rig, rng.integers(0, 6))
        taken += int(floor.floor_stage(segs, rig.arrays, 0.5, SPACE)[1].sum())
    assert taken > 20


def _ghost_case(seed):
    """A random window and 8 random clusters of 1-3 of its segments (two-view ones are judged)."""
    rng = np.random.default_rng(100 + seed)
    rig = ring_rig(sorted(rng.choice(360, size=rng.integers(2, 5), replace=False)), radius=10.0, height=3.0)
    segs = _window(rng, rig, rng.integers(2, 6))
    K, C = len(segs), len(rig)
    M = 8
    members = np.full((M, C), -1, np.int64)
    for m in range(M):
        for k in rng.choice(K, size=min(K, rng.integers(1, 4)), replace=False):
            members[m, segs.camera[k]] = k
    valid = rng.random((M, W)) < 0.8
    xyz = rng.uniform(-4, 4, (M, W, 3))
    bottom = np.where(rng.random((M, W)) < 0.9, rng.uniform(-0.2, 1.0, (M, W)), np.nan)
    tri = WindowTracklets3D(0, xyz, bottom + 1.5, bottom, valid, np.zeros((M, W), np.int8),
                            np.full((M, W), 2, np.int8), members, np.full(M, -1, np.int64))
    params = SimpleNamespace(cluster_plane=rng.choice([0.5, 1.5]))
    return segs, rig, tri, params, SimpleNamespace(performance_space=SPACE)


PLANES = [Plane(np.zeros(3), np.array([1.0, 0.0, 0.0])), Plane(np.zeros(3), np.array([0.0, 1.0, 0.0]))]


@pytest.mark.parametrize("seed", range(25))
def test_ghost_test_matches_numpy(seed):
    segs, rig, tri, params, scene = _ghost_case(seed)
    for pl in ([], PLANES[:1], PLANES):
        counts, counts_r = {"floor_ghosts": 0}, {"floor_ghosts": 0}
        kept, out = floor.drop_floor_ghosts(tri, segs, rig.arrays, pl, params, scene, counts)
        kept_r, out_r = ref.drop_floor_ghosts(tri, segs, rig.arrays, pl, params, scene, counts_r)
        assert counts == counts_r and out.tolist() == out_r.tolist()
        _same_tracklets(kept, kept_r)


def test_ghost_test_random_clusters_are_not_trivial():
    """Over the random cases some two-view clusters in the air are ghosts and some are kept."""
    ghosts = kept_two = 0
    for seed in range(25):
        segs, rig, tri, params, scene = _ghost_case(seed)
        kept, _ = floor.drop_floor_ghosts(tri, segs, rig.arrays, PLANES, params, scene, {"floor_ghosts": 0})
        ghosts += len(tri) - len(kept)
        kept_two += int(((kept.members >= 0).sum(1) == 2).sum())
    assert ghosts > 5 and kept_two > 5


def _floor_split_case(seed):
    """A random window, part of it to the plane, a few ghosts' segments, Eq. 2 distances, and a
    tracking space that cuts some floor tracklets off."""
    rng = np.random.default_rng(200 + seed)
    rig = ring_rig(sorted(rng.choice(360, size=rng.integers(2, 5), replace=False)), radius=10.0, height=3.0)
    segs = _window(rng, rig, rng.integers(0, 7))
    K = len(segs)
    pick = rng.permutation(K)
    n_plane = int(rng.integers(0, K + 1))
    to_plane = np.sort(pick[:n_plane]).astype(np.int64)
    floor_only = pick[n_plane:n_plane + int(rng.integers(0, 3))].astype(np.int64)
    D2 = rng.uniform(0, 40, (K, K))
    D2 = (D2 + D2.T) / 2  # (Eq. 2 is symmetric)
    params = SimpleNamespace(cluster_2d=30.0, cluster_plane=rng.choice([0.5, 1.5]), max_speed=rng.choice([0.1, 1.0]))
    scene = SimpleNamespace(performance_space=tuple(SPACE), tracking_space=(-4.0, -4.5, 0.0, 5.0, 4.0, 4.5))
    return segs, rig, to_plane, floor_only, D2, params, scene


@pytest.mark.parametrize("seed", range(25))
def test_floor_split_matches_numpy(seed):
    """The tracker's hook (one kernel call): a random part of the window to the plane, a few
    ghosts' segments, Eq. 2 separations or an oracle, and Eq. 4 by place on a tracking space
    that cuts some floor tracklets off."""
    segs, rig, to_plane, floor_only, D2, params, scene = _floor_split_case(seed)
    for d2, oracle in ((None, False), (D2, False), (None, True)):
        counts, counts_r = {}, {}
        for c in (counts, counts_r):
            c.update(dict.fromkeys(("segments_to_floor", "tracklets_outliers", "floor_tracklets",
                                    "segments_dropped_ghost"), 0))
        fl, rest = floor.floor_split(segs, to_plane, d2, rig.arrays, params, scene, oracle, counts, floor_only)
        fl_r, rest_r = ref.floor_split(segs, to_plane, d2, rig.arrays, params, scene, oracle, counts_r, floor_only)
        assert counts == counts_r and rest.tolist() == rest_r.tolist()
        assert (fl is None) == (fl_r is None)
        if fl is not None:
            _same_tracklets(fl, fl_r)


def test_floor_split_random_cases_are_not_trivial():
    """Over the random cases above the floor takes tracklets, Eq. 4 drops some and ghosts' segments go."""
    counts = dict.fromkeys(("segments_to_floor", "tracklets_outliers", "floor_tracklets", "segments_dropped_ghost"), 0)
    for seed in range(25):
        segs, rig, to_plane, floor_only, _, params, scene = _floor_split_case(seed)
        floor.floor_split(segs, to_plane, None, rig.arrays, params, scene, False, counts, floor_only)
    assert counts["floor_tracklets"] > 5 and counts["tracklets_outliers"] > 2 and counts["segments_dropped_ghost"] > 0


@pytest.mark.parametrize("seed", range(25))
def test_ghost_confirmation_by_the_previous_windows_owners_matches_numpy(seed):
    """The tracker's form (prev_2d, prev_owner): the 2D tracks of the previous window's
    tracklets (some of this window's, some gone) and their 3D tracks, against the numpy test
    with the per-segment owners they give."""
    segs, rig, tri, params, scene = _ghost_case(seed)
    rng = np.random.default_rng(400 + seed)
    K = len(segs)
    prev_2d = rng.permutation(np.r_[segs.track2d[rng.random(K) < 0.7], 1000 + np.arange(3)]).astype(np.int64)
    prev_owner = rng.integers(0, 2, len(prev_2d)).astype(np.int64)  # few tracks: pairs often share one
    by_2d = dict(zip(prev_2d.tolist(), prev_owner.tolist()))
    owner = np.array([by_2d.get(t, -1) for t in segs.track2d.tolist()], np.int64)
    for pl in ([], PLANES):
        counts, counts_r = {"floor_ghosts": 0, "floor_ghosts_confirmed": 0}, {"floor_ghosts": 0, "floor_ghosts_confirmed": 0}
        kept, out = floor.drop_floor_ghosts(tri, segs, rig.arrays, pl, params, scene, counts, (prev_2d, prev_owner))
        kept_r, out_r = ref.drop_floor_ghosts(tri, segs, rig.arrays, pl, params, scene, counts_r, owner)
        assert counts == counts_r and out.tolist() == out_r.tolist()
        _same_tracklets(kept, kept_r)
        for o in (owner, lambda: owner):  # the per-segment forms
            counts_o = {"floor_ghosts": 0, "floor_ghosts_confirmed": 0}
            kept_o, out_o = floor.drop_floor_ghosts(tri, segs, rig.arrays, pl, params, scene, counts_o, o)
            assert counts_o == counts_r and out_o.tolist() == out_r.tolist()


def test_ghost_confirmation_cases_are_not_trivial():
    confirmed = 0
    for seed in range(25):
        segs, rig, tri, params, scene = _ghost_case(seed)
        rng = np.random.default_rng(400 + seed)
        K = len(segs)
        prev_2d = rng.permutation(np.r_[segs.track2d[rng.random(K) < 0.7], 1000 + np.arange(3)]).astype(np.int64)
        prev_owner = rng.integers(0, 2, len(prev_2d)).astype(np.int64)
        counts = {"floor_ghosts": 0, "floor_ghosts_confirmed": 0}
        floor.drop_floor_ghosts(tri, segs, rig.arrays, PLANES, params, scene, counts, (prev_2d, prev_owner))
        confirmed += counts["floor_ghosts_confirmed"]
    assert confirmed > 3


@pytest.mark.parametrize("seed", range(25))
def test_outliers_then_ghosts_in_one_call_match_numpy(seed):
    _outliers_then_ghosts(seed)


def _outliers_then_ghosts(seed):
    """The tracker's call: Eq. 4 by place first (counted), then the ghost test with the owners'
    confirmation on what is left, against the numpy outlier test and ghost test in that order."""
    from reference.reconstruct import outliers_at_mean_numpy

    segs, rig, tri, params, scene = _ghost_case(seed)
    rng = np.random.default_rng(500 + seed)
    prev_2d = segs.track2d[rng.random(len(segs)) < 0.7].astype(np.int64)
    prev_owner = rng.integers(0, 2, len(prev_2d)).astype(np.int64)
    by_2d = dict(zip(prev_2d.tolist(), prev_owner.tolist()))
    owner = np.array([by_2d.get(t, -1) for t in segs.track2d.tolist()], np.int64)
    tspace, speed = np.array([-3.0, -3.5, -1.0, 3.5, 3.0, 5.0]), float(rng.choice([2.0, 8.0]))
    keys = ("floor_ghosts", "floor_ghosts_confirmed", "tracklets_outliers")
    counts, counts_r = dict.fromkeys(keys, 0), dict.fromkeys(keys, 0)
    kept, out = floor.drop_floor_ghosts(tri, segs, rig.arrays, PLANES, params, scene, counts, (prev_2d, prev_owner),
                                        (tspace, speed))
    bad = outliers_at_mean_numpy(tri.xyz, tri.valid, tspace, speed)
    counts_r["tracklets_outliers"] += int(bad.sum())
    kept_r, out_r = ref.drop_floor_ghosts(tri.subset(~bad), segs, rig.arrays, PLANES, params, scene, counts_r, owner)
    assert counts == counts_r and out.tolist() == out_r.tolist()
    _same_tracklets(kept, kept_r)
    return counts, len(kept)


def test_outliers_then_ghosts_cases_are_not_trivial():
    total = {"tracklets_outliers": 0, "floor_ghosts": 0, "kept": 0}
    for seed in range(25):
        counts, n_kept = _outliers_then_ghosts(seed)
        total["tracklets_outliers"] += counts["tracklets_outliers"]
        total["floor_ghosts"] += counts["floor_ghosts"]
        total["kept"] += n_kept
    assert total["tracklets_outliers"] > 10 and total["floor_ghosts"] > 3 and total["kept"] > 10
