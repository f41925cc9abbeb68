"""Cross-view clustering: Algorithm 1 on hand-worked matrices, and the Eq. 2 distances."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ring_rig

from gymtrack.geometry.epipolar import epipolar_distance, fundamental_matrices
from gymtrack.tracking.clustering import complete_linkage, tracklet_distances
from gymtrack.tracking.types import WindowTracklets
from reference.clustering import complete_linkage_sequential

INF, NAN = np.inf, np.nan


def sym(n, entries):
    D = np.full((n, n), NAN)
    for (i, j), v in entries.items():
        D[i, j] = D[j, i] = v
    return D


def test_hand_worked_merge_order_with_unknown_and_forbidden():
    # A(cam0) B(cam1) C(cam2) D(cam0); C-D share no frame (unknown), A-D are one camera (inf).
    D = sym(4, {(0, 1): 0.10, (0, 2): 0.25, (0, 3): INF, (1, 2): 0.05, (1, 3): 0.20, (2, 3): NAN})
    merges = []
    labels = complete_linkage_sequential(D, 0.3, merges)
    # 1) B+C at 0.05; {BC}-A = max(0.10, 0.25) = 0.25, {BC}-D = the known 0.20 (C-D unknown)
    # 2) {BC}+D at 0.20; {BCD}-A = max(0.25, inf) = inf: A stays alone although A-B was 0.10
    assert merges == [(1, 2, 0.05), (1, 3, 0.20)]
    assert labels.tolist() == [0, 1, 1, 1]
    assert complete_linkage(D, 0.3).tolist() == [0, 1, 1, 1]


def test_complete_linkage_blocks_a_chain_that_single_linkage_would_join():
    D = sym(3, {(0, 1): 0.1, (1, 2): 0.2, (0, 2): 0.5})
    assert complete_linkage(D, 0.3).tolist() == [0, 0, 1]  # {A,B} then max(0.5, 0.2) >= 0.3
    D[0, 2] = D[2, 0] = NAN  # A and C share no frame: no evidence against joining
    assert complete_linkage(D, 0.3).tolist() == [0, 0, 0]


def test_threshold_is_strict_and_nothing_below_it_means_singletons():
    D = sym(3, {(0, 1): 0.3, (1, 2): 0.31, (0, 2): NAN})
    assert complete_linkage(D, 0.3).tolist() == [0, 1, 2]
    assert complete_linkage(np.full((1, 1), NAN), 0.3).tolist() == [0]
    assert complete_linkage(np.zeros((0, 0)), 0.3).tolist() == []


def test_same_camera_is_never_merged_even_through_unknowns():
    # 0 and 2 are one camera; both are close to 1, and 0-2 unknown would not block -- inf does
    D = sym(3, {(0, 1): 0.05, (1, 2): 0.06, (0, 2): INF})
    lab = complete_linkage(D, 0.3)
    assert lab[0] == lab[1] and lab[2] != lab[0]


def test_reciprocal_nearest_neighbour_rounds_equal_the_literal_loop():
    rng = np.random.default_rng(3)
    for _ in range(150):
        K = int(rng.integers(2, 30))
        D = rng.uniform(0, 0.8, (K, K))
        D = (D + D.T) / 2
        unknown = rng.random((K, K)) < rng.uniform(0, 0.6)
        D[unknown | unknown.T] = NAN
        cam = rng.integers(0, rng.integers(1, 6), K)
        D[cam[:, None] == cam[None]] = INF
        thr = rng.uniform(0.05, 0.6)
        assert complete_linkage(D, thr).tolist() == complete_linkage_sequential(D, thr).tolist()


def _segments(rng, K=14, W=10, cams=4):
    box = np.concatenate([rng.uniform(200, 1700, (K, W, 2)), rng.uniform(40, 300, (K, W, 2))], axis=2)
    observed = rng.random((K, W)) < 0.6
    observed[0] = False
    observed[0, :3] = True
    observed[1] = False
    observed[1, 6:] = True  # 0 and 1 share no observed frame
    cam = np.sort(rng.integers(0, cams, K))
    cam[0], cam[1] = 0, 1
    order = np.argsort(cam, kind="stable")
    box, observed, cam = box[order], observed[order], cam[order]
    valid = np.ones((K, W), bool)  # interpolated boxes everywhere: they must not count
    return WindowTracklets(0, cam, np.arange(K), box, observed, valid, np.full((K, W), -1)), order


def test_tracklet_distances_match_eq1_pair_by_pair():
    rng = np.random.default_rng(0)
    rig = ring_rig([0, 90, 180, 270])
    F = fundamental_matrices(rig)
    segs, order = _segments(rng)
    D = tracklet_distances(segs, F)
    K = len(segs)
    for i in range(K):
        for j in range(K):
            if segs.camera[i] == segs.camera[j]:
                assert D[i, j] == INF
                continue
            shared = segs.observed[i] & segs.observed[j]
            if not shared.any():
                assert np.isnan(D[i, j])
                continue
            ref = epipolar_distance(segs.box[i, shared], segs.box[j, shared], F[segs.camera[i], segs.camera[j]]).mean()
            assert D[i, j] == pytest.approx(ref, rel=1e-9)
    a, b = np.flatnonzero(order == 0)[0], np.flatnonzero(order == 1)[0]
    assert np.isnan(D[a, b])  # disjoint observed frames: unknown, although both are "valid"


def test_same_person_seen_from_three_views_forms_one_cluster():
    from conftest import person_boxes

    rig = ring_rig([0, 110, 230])
    F = fundamental_matrices(rig)
    t = np.arange(10)
    starts = [(-1.0, -1.0, 1.0), (0.5, 0.8, 1.6), (1.5, -1.2, 0.9)]  # not all in one epipolar plane
    people = [np.array(s) + np.outer(0.05 * t, [1.0, 0.5, 0.0]) for s in starts]
    boxes, cams = [], []
    for c, cam in enumerate(rig):
        for X in people:
            boxes.append(person_boxes(cam, X))
            cams.append(c)
    K = len(boxes)
    obs = np.ones((K, 10), bool)
    segs = WindowTracklets(0, np.array(cams), np.arange(K), np.stack(boxes), obs, obs, np.full((K, 10), -1))
    labels = complete_linkage(tracklet_distances(segs, F), 0.3)
    person = np.tile(np.arange(3), 3)
    for p in range(3):  # each person's three segments share one label, and no one else's
        assert len(set(labels[person == p])) == 1
    assert len(set(labels)) == 3
