"""Metrics of gymtrack.eval.metrics on tiny hand-made tracks; every expected value is worked out
by hand in the comments next to it."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.eval.metrics import (
    average_euclidean_distance,
    coverage,
    failure_rate,
    mot_metrics,
    nearest_person,
    pairs_by_key,
    performing_frames,
    target_id_switches,
)

S_PERF = np.array([-5.0, -5.0, -1.0, 5.0, 5.0, 5.0])


def test_pairs_by_key_is_an_inner_join():
    a = np.array([3, 1, 2, 7])
    b = np.array([1, 3, 3, 5, 1])
    ia, ib = pairs_by_key(a, b)
    got = sorted(zip(ia.tolist(), ib.tolist()))
    # a[0]=3 pairs with b[1], b[2]; a[1]=1 with b[0], b[4]; 2 and 7 have no partner
    assert got == [(0, 1), (0, 2), (1, 0), (1, 4)]


def _two_people(frames):
    """GT: target (id 1) at the origin, coach (id 2) at x = 3; the target leaves S_perf at frame 10."""
    f = np.asarray(frames)
    tx = np.where(f == 10, 100.0, 0.0)
    gt_frame = np.r_[f, f]
    gt_person = np.r_[np.ones(f.size, int), np.full(f.size, 2)]
    gt_xyz = np.r_[np.c_[tx, 0 * f, 0 * f], np.c_[np.full(f.size, 3.0), 0 * f, 0 * f]]
    return gt_frame, gt_person, gt_xyz


def test_performing_frames_uses_s_perf_and_phase():
    f = np.arange(1, 12)
    gt_frame, gt_person, gt_xyz = _two_people(f)
    t = gt_person == 1
    assert performing_frames(gt_frame[t], gt_xyz[t], S_PERF).tolist() == [1, 2, 3, 4, 5, 6, 7, 8, 9, 11]
    phase = f >= 3
    assert performing_frames(gt_frame[t], gt_xyz[t], S_PERF, phase).tolist() == [3, 4, 5, 6, 7, 8, 9, 11]


def test_id_switches_count_track_id_changes_and_coach_following_once_each_transition():
    f = np.arange(1, 12)
    gt_frame, gt_person, gt_xyz = _two_people(f)
    perf = performing_frames(gt_frame[gt_person == 1], gt_xyz[gt_person == 1], S_PERF)
    # output target: frame -> (track id, x)
    out = {
        1: (7, 0.1),   # on the target
        2: (7, 0.1),
        3: (7, 2.9),   # same id, now on the coach: person change -> switch 1
        4: (8, 2.9),   # new id, still the coach: id change -> switch 2
        # 5: no output (gap is bridged)
        6: (8, 0.0),   # back on the target under id 8: person change -> switch 3
        7: (9, 3.0),   # new id AND on the coach: both change, counted once -> switch 4
        8: (9, 10.0),  # 7 m from the coach: nobody, no change
        9: (9, 3.0),   # the coach again: same as the last known person -> no switch
        10: (10, 3.0),  # target not performing (outside S_perf): frame ignored
        11: (9, 3.0),  # compared with frame 9: no switch
    }
    of = np.array(list(out))
    tid = np.array([v[0] for v in out.values()])
    xyz = np.c_[[v[1] for v in out.values()], np.zeros(len(out)), np.zeros(len(out))]
    r = target_id_switches(perf, of, tid, xyz, gt_frame, gt_person, gt_xyz, gate=1.0)
    assert r.total == 4
    assert r.track_id_changes == 2  # 7->8 at frame 4, 8->9 at frame 7
    assert r.person_changes == 3  # frames 3, 6, 7
    assert r.transitions == 8  # evaluated frames 1,2,3,4,6,7,8,9,11
    assert r.frames_not_on_anybody == 1


def test_id_switches_of_a_perfect_track_are_zero_and_order_does_not_matter():
    f = np.arange(1, 10)
    gt_frame, gt_person, gt_xyz = _two_people(f)
    perf = np.arange(1, 10)
    rev = f[::-1]
    r = target_id_switches(perf, rev, np.full(9, 5), np.zeros((9, 3)), gt_frame, gt_person, gt_xyz)
    assert (r.total, r.transitions) == (0, 8)


def test_nearest_person_gate():
    gt_frame = np.array([1, 1, 2])
    gt_person = np.array([1, 2, 1])
    gt_xyz = np.array([[0.0, 0, 0], [3, 0, 0], [0, 0, 0]])
    who, d = nearest_person(np.array([1, 1, 2, 3]), np.array([[2.5, 0, 0], [1.4, 0, 0], [0.5, 0, 0], [0, 0, 0]]), gt_frame, gt_person, gt_xyz, gate=1.0)
    assert who.tolist() == [2, -1, 1, -1]  # 1.4 m from the target, 1.6 from the coach: nobody
    np.testing.assert_allclose(d, [0.5, 1.4, 0.5, np.inf])


def test_aed_is_the_mean_distance_over_common_frames():
    gt_frame = np.array([1, 2, 3, 4])
    gt_xyz = np.zeros((4, 3))
    out_frame = np.array([1, 2, 5])
    out_xyz = np.array([[3.0, 4.0, 0.0], [0.0, 0.0, 1.0], [9.0, 9.0, 9.0]])  # 5 m, 1 m, no GT
    r = average_euclidean_distance(gt_frame, gt_xyz, out_frame, out_xyz)
    assert r.n == 2 and r.mean == pytest.approx(3.0) and r.total == pytest.approx(6.0)
    r2 = average_euclidean_distance(gt_frame, gt_xyz, out_frame, out_xyz, frames=np.array([2]))
    assert r2.n == 1 and r2.mean == pytest.approx(1.0)
    assert np.isnan(average_euclidean_distance(gt_frame, gt_xyz, np.array([9]), np.zeros((1, 3))).mean)


def test_failure_rate_three_kinds():
    box = [100.0, 100.0, 40.0, 100.0]  # x 80..120, y 50..150, length 100
    gt_frame = np.array([1, 1, 2, 2, 3, 3])
    gt_cam = np.array([0, 1, 0, 1, 0, 1])
    gt_box = np.array([box] * 6)
    out = [
        (1, 0, [100, 100, 130, 130]),  # OK: 35..165 covers it, 100 >= 65
        # (1, 1) missing                 -> missing
        (2, 0, [100, 130, 130, 130]),  # y 65..195: top of the true box outside -> outside
        (2, 1, [100, 100, 260, 260]),  # inside but 100 < 130 -> too small
        (3, 0, [100, 100, 200, 200]),  # inside and 100 == 0.5 * 200 (not less) -> OK
        (3, 1, [300, 100, 300, 300]),  # outside and too small: counted once, as outside
        (4, 0, [100, 100, 130, 130]),  # no GT box to evaluate: ignored
    ]
    r = failure_rate(
        gt_frame, gt_cam, gt_box,
        np.array([o[0] for o in out]), np.array([o[1] for o in out]), np.array([o[2] for o in out], float),
    )
    assert (r.evaluated, r.failures, r.missing, r.outside, r.too_small) == (6, 4, 1, 2, 1)
    assert r.rate == pytest.approx(4 / 6)


def test_failure_rate_clips_to_the_image():
    # true box x -20..20 runs off the left edge; b_buf x -5..125
    gt = np.array([[0.0, 100.0, 40.0, 100.0]])
    buf = np.array([[60.0, 100.0, 130.0, 130.0]])
    r_raw = failure_rate([1], [0], gt, [1], [0], buf)
    r_img = failure_rate([1], [0], gt, [1], [0], buf, image_size=np.array([[1920, 1080]]))
    assert r_raw.outside == 1  # -20 < -5
    assert r_img.failures == 0  # visible part 0..20 lies in 0..125


def test_failure_rate_rejects_duplicate_output_boxes():
    with pytest.raises(ValueError, match="more than one"):
        failure_rate([1], [0], np.ones((1, 4)), [1, 1], [0, 0], np.ones((2, 4)))


def test_coverage():
    c = coverage(np.array([1, 2, 3, 4]), np.array([2, 3, 9]))
    assert (c.covered, c.frames) == (2, 4) and c.share == pytest.approx(0.5)


def _mot_case():
    # frames 0..2; GT 1 at the origin, GT 2 at x = 5
    gt_frame = np.array([0, 0, 1, 1, 2, 2])
    gt_id = np.array([1, 2, 1, 2, 1, 2])
    gt_pts = np.array([[0, 0, 0], [5, 0, 0]] * 3, float)
    hyp_frame = np.array([0, 0, 1, 1, 2, 2])
    hyp_id = np.array([10, 11, 10, 12, 10, 13])
    hyp_pts = np.array([[0.1, 0, 0], [5.2, 0, 0], [0.1, 0, 0], [5.2, 0, 0], [0.1, 0, 0], [20, 0, 0]], float)
    return gt_frame, gt_id, gt_pts, hyp_frame, hyp_id, hyp_pts


def test_mot_metrics_hand_case():
    r = mot_metrics(*_mot_case(), max_dist=1.0)
    # 6 GT person-frames; GT 2 is missed at frame 2 (FN 1), hyp 13 matches nobody (FP 1),
    # GT 2 goes from hyp 11 to hyp 12 at frame 1 (IDSW 1): MOTA = 1 - 3/6
    assert (r.objects, r.matches, r.misses, r.false_positives, r.id_switches) == (6, 5, 1, 1, 1)
    assert r.mota == pytest.approx(0.5)
    # IDF1: best one-to-one id map 1<->10 (3 frames) and 2<->11 (or 12) (1 frame): IDTP 4;
    # IDFN = 6 - 4 = 2, IDFP = 6 - 4 = 2 -> 2*4 / (2*4 + 2 + 2) = 2/3
    assert r.idf1 == pytest.approx(2 / 3)
    # MOTP: mean match distance (0.1 + 0.2 + 0.1 + 0.2 + 0.1) / 5
    assert r.motp == pytest.approx(0.14)
    assert r.median_distance == pytest.approx(0.1)  # of 0.1, 0.2, 0.1, 0.2, 0.1


def test_mot_metrics_gate_and_distractors():
    gt_frame, gt_id, gt_pts, hyp_frame, hyp_id, hyp_pts = _mot_case()
    # 1.2 m off is beyond the 1 m gate: the match at GT 1, frame 0 becomes a miss + a false positive
    hp = hyp_pts.copy()
    hp[0] = [1.2, 0, 0]
    r = mot_metrics(gt_frame, gt_id, gt_pts, hyp_frame, hyp_id, hp, max_dist=1.0)
    assert (r.misses, r.false_positives) == (2, 2)
    # a spectator (GT 3, outside the region) at x = 50 with an output on it: neither TP nor FP
    g = (np.r_[gt_frame, 0], np.r_[gt_id, 3], np.r_[gt_pts, [[50, 0, 0]]])
    h = (np.r_[hyp_frame, 0], np.r_[hyp_id, 14], np.r_[hyp_pts, [[50.3, 0, 0]]])
    region = np.r_[np.ones(6, bool), False]
    r = mot_metrics(*g, *h, max_dist=1.0, gt_in_region=region)
    assert (r.objects, r.false_positives, r.ignored_hypotheses) == (6, 1, 1)
    assert r.mota == pytest.approx(0.5)
    # without the region the spectator counts: 7 objects, 6 matches
    r = mot_metrics(*g, *h, max_dist=1.0)
    assert (r.objects, r.matches) == (7, 6)


def test_mot_metrics_works_in_2d():
    r = mot_metrics([0, 1], [1, 1], np.zeros((2, 2)), [0, 1], [4, 4], np.full((2, 2), 0.3))
    assert r.mota == pytest.approx(1.0) and r.idf1 == pytest.approx(1.0)
    assert r.motp == pytest.approx(np.hypot(0.3, 0.3))
