"""Single-view IoU tracking (global assignment, max_age) and the windows' segments."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.tracking.single_view import IoUTracker, assign, iou_matrix
from gymtrack.tracking.windows import build_window, fill_missing, window_starts


def test_iou_matrix_hand_values():
    a = np.array([[0.0, 0.0, 10.0, 10.0]])
    b = np.array([[5.0, 0.0, 10.0, 10.0], [0.0, 0.0, 10.0, 10.0], [30.0, 0.0, 10.0, 10.0], [0.0, 0.0, 5.0, 5.0]])
    np.testing.assert_allclose(iou_matrix(a, b), [[50 / 150, 1.0, 0.0, 25 / 100]])


def test_global_assignment_beats_greedy():
    # Track A [-5, 5], track B [3, 13]; det 1 [-2, 8], det 2 [-9, 1] (x extents, all 10 high).
    # IoU: A-1 7/13, A-2 6/14, B-1 5/15, B-2 0. Greedy takes A-1 (the best pair) and leaves B
    # and det 2 unmatched; the global optimum A-2 + B-1 keeps both tracks.
    trk = IoUTracker(iou_threshold=0.1, max_age=2)
    ids0 = trk.update(0, np.array([0, 0]), np.array([[0.0, 0, 10, 10], [8.0, 0, 10, 10]]))
    ids1 = trk.update(1, np.array([0, 0]), np.array([[3.0, 0, 10, 10], [-4.0, 0, 10, 10]]))
    assert ids1.tolist() == [ids0[1], ids0[0]]  # det 1 continues B, det 2 continues A
    # the same IoU matrix, solved greedily, would lose a track
    iou = iou_matrix(np.array([[0.0, 0, 10, 10], [8.0, 0, 10, 10]]), np.array([[3.0, 0, 10, 10], [-4.0, 0, 10, 10]]))
    assert np.argmax(iou[0]) == 0 and iou[1, 1] < 0.1
    r, c = assign(iou, iou >= 0.1)
    assert sorted(zip(r.tolist(), c.tolist())) == [(0, 1), (1, 0)]


def test_boxes_of_different_cameras_never_match():
    trk = IoUTracker()
    ids0 = trk.update(0, np.array([0]), np.array([[0.0, 0, 10, 10]]))
    ids1 = trk.update(1, np.array([1]), np.array([[0.0, 0, 10, 10]]))
    assert ids1[0] != ids0[0]


def test_iou_threshold():
    trk = IoUTracker(iou_threshold=0.1)
    ids0 = trk.update(0, np.array([0]), np.array([[0.0, 0, 10, 10]]))
    ids1 = trk.update(1, np.array([0]), np.array([[8.5, 0, 10, 10]]))  # IoU 1.5/18.5 < 0.1
    assert ids1[0] != ids0[0]
    ids2 = trk.update(2, np.array([0]), np.array([[10.0, 0, 10, 10]]))  # IoU with the new track 8.5/11.5
    assert ids2[0] == ids1[0]


@pytest.mark.parametrize("missed, continued", [(1, True), (2, True), (3, False)])
def test_max_age(missed, continued):
    trk = IoUTracker(iou_threshold=0.1, max_age=2)
    box = np.array([[100.0, 100, 20, 50]])
    first = trk.update(0, np.array([0]), box)[0]
    for f in range(1, missed + 1):
        trk.update(f, np.zeros(0, np.int64), np.zeros((0, 4)))
    again = trk.update(missed + 1, np.array([0]), box)[0]
    assert bool(again == first) is continued
    assert len(trk) == 1  # continued, or the dead track forgotten and a new one begun


def test_dead_tracks_are_dropped_from_state():
    trk = IoUTracker(max_age=2)
    for f in range(50):  # a new person every frame, each seen once
        trk.update(f, np.array([0]), np.array([[40.0 * f, 0, 10, 10]]))
    assert len(trk) <= 4


# ---------------------------------------------------------------------- windows
def test_window_starts_overlap_by_half():
    np.testing.assert_array_equal(window_starts(1, 5, 17), [1, 6, 11, 16])


def test_fill_missing_interpolates_and_holds_at_most_max_extrapolate():
    W = 10
    t = np.arange(W)
    box = np.stack([10.0 * t, 2.0 * t, 5 + t, 9 + t], axis=1)[None]  # linear motion and growth
    obs = np.zeros((1, W), bool)
    obs[0, [2, 3, 5, 6, 7]] = True
    filled, valid = fill_missing(np.where(obs[..., None], box, np.nan), obs, max_extrapolate=2)
    np.testing.assert_allclose(filled[0, 4], box[0, 4])  # interpolated exactly (linear motion)
    np.testing.assert_allclose(filled[0, [0, 1]], box[0, [2, 2]])  # held first box, 2 frames
    np.testing.assert_allclose(filled[0, [8, 9]], box[0, [7, 7]])  # held last box, 2 frames
    assert valid.all()
    filled, valid = fill_missing(np.where(obs[..., None], box, np.nan), obs, max_extrapolate=1)
    assert valid[0].tolist() == [False, True, True, True, True, True, True, True, True, False]
    assert np.isnan(filled[0, 0]).all() and np.isnan(filled[0, 9]).all()


def test_build_window_drops_short_segments_and_counts_them():
    W = 10
    rows = []
    for f in range(20):
        if f % 2 == 0:
            rows.append((f, 0, 7, [100.0 + f, 50, 20, 40]))  # track 7: every other frame
        rows.append((f, 1, 3, [300.0, 80, 20, 40]))  # track 3: every frame
        if 12 <= f <= 15:
            rows.append((f, 1, 9, [600.0, 80, 20, 40]))  # track 9: 4 boxes only
    f, c, tid, box = (np.array(x) for x in zip(*rows))
    det = np.arange(len(f))
    segs, dropped = build_window(10, W, f, c, tid, box, det, min_boxes=5, max_extrapolate=2)
    assert segs.track2d.tolist() == [7, 3]  # sorted by camera
    assert segs.camera.tolist() == [0, 1]
    assert dropped == 1
    assert segs.observed[0].sum() == 5 and segs.valid[0].sum() == 10
    np.testing.assert_allclose(segs.box[0, 1, 0], 111.0)  # frame 11 interpolated between 10 and 12
    i = np.flatnonzero((f == 14) & (tid == 3))[0]
    assert segs.det[1, 4] == det[i]
