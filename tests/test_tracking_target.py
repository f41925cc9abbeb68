"""The target gymnast: Eq. 13 identification and re-identification, gap filling and smoothing,
and the Eq. 14 pose boxes."""

from __future__ import annotations

from types import SimpleNamespace

import cv2
import numpy as np
import pytest

from conftest import ring_rig

from gymtrack.detections import Detections
from gymtrack.tracking.identify import TargetBackfill, TargetSelector, backfill, identify_indicator, point_support
from gymtrack.tracking.smoothing import TargetSmoother
from gymtrack.tracking.target import (
    BODY_HALF_DEPTH, MIN_HALF_LENGTH, MIN_LENGTH_COS, buffered_boxes, track_box_sizes)
from gymtrack.tracking.types import INTERPOLATED, TRIANGULATION, TargetRows


def run_selector(sel, frames, rows, ended):
    """rows: frame -> list of (track id, indicator, in_perf). Returns the target per frame."""
    out = []
    for f in frames:
        r = rows.get(f, [])
        tid = np.array([x[0] for x in r], np.int64)
        ind, inperf = np.array([x[1] for x in r], bool), np.array([x[2] for x in r], bool)
        out.append(sel.select(f, f, np.full(len(tid), f, np.int64), tid, ind, inperf, ended)[0])
    return np.array(out)


def test_identified_once_more_than_half_of_the_last_30_frames_qualify_then_reidentified():
    sel = TargetSelector(identify_frames=30)
    rows = {}
    for f in range(0, 80):  # track 1: on the floor until frame 39, up on the apparatus from 40
        rows.setdefault(f, []).append((1, f >= 40, True))
    for f in range(0, 120):  # track 9: a coach in the performance space who never rises
        rows.setdefault(f, []).append((9, False, True))
    for f in range(84, 120):  # track 2: the gymnast's new track after track 1 ended
        rows.setdefault(f, []).append((2, True, True))
    ended = {}
    target = run_selector(sel, range(0, 80), rows, ended)
    # frame f >= 40 has f - 39 qualifying points of 30: more than half from f = 55
    assert target[54] == -1 and target[55] == 1
    assert np.all(target[55:80] == 1)
    ended[1] = 79  # cross-window linking did not continue track 1
    target = run_selector(sel, range(80, 120), rows, ended)
    assert np.all(target[:19] == -1)  # frames 80..98: track 1 is gone, track 2 has <= 15 qualifying frames
    assert target[19] == 2  # frame 99: frames 84..99, 16 of the last 30, qualify
    assert sel.switches == 1 and sel.identifications == 2


def test_target_is_released_when_it_leaves_the_performance_space():
    sel = TargetSelector(identify_frames=10)
    rows = {f: [(5, f < 20, f < 20)] for f in range(40)}
    target = run_selector(sel, range(40), rows, {})
    assert target[4] == -1 and target[5] == 5  # at frame 5, frames 0..5 (6 > 10 / 2) qualify
    first_free = int(np.flatnonzero(target[10:] == -1)[0]) + 10
    assert first_free == 24  # last 10 frames 15..24, only 15..19 in S_perf: not more than half


def test_identify_indicator():
    perf = np.array([-1.0, -1, 0, 1, 1, 4])
    xyz = np.array([[0, 0, 1.5], [0, 0, 1.5], [0, 0, 1.5], [3, 0, 1.5]])
    top = np.array([2.5, 1.9, 2.5, 2.5])
    bot = np.array([0.7, 0.7, np.nan, 0.7])
    ind, inperf = identify_indicator(xyz, top, bot, perf, 2.0, 0.6)
    assert ind.tolist() == [True, False, False, False]
    assert inperf.tolist() == [True, True, True, False]


def _points(frames, xyz, tid=1):
    """Target rows at ``frames`` (n,) with centres ``xyz`` (n, 3), two views without detections."""
    n = len(frames)
    return TargetRows.of(frames, np.full(n, tid), np.reshape(xyz, (n, 3)), np.full(n, 2.2), np.full(n, 0.8),
                         np.full(n, TRIANGULATION), np.full((n, 2, 2), np.nan))


def _emitted(parts):
    """The rows the smoother emitted (None: nothing) as one TargetRows."""
    parts = [p for p in parts if p is not None]
    return TargetRows.concat(parts) if parts else _points([], np.zeros((0, 3)))


def test_smoother_fills_short_gaps_keeps_long_ones_and_preserves_lines():
    sm = TargetSmoother(max_gap=7, half_window=2)
    out = []
    frames = list(range(0, 10)) + list(range(13, 20)) + list(range(30, 40))  # gaps of 3 and 10 frames
    for f in frames:
        out += [sm.push(_points([f], [0.1 * f, 2.0 - 0.05 * f, 1.0])), sm.advance(f)]
    out = _emitted(out + [sm.close()])
    got = out.frame
    np.testing.assert_array_equal(got, list(range(0, 20)) + list(range(30, 40)))
    src = out.source
    assert np.all(src[[10, 11, 12]] == INTERPOLATED) and np.all(np.delete(src, [10, 11, 12]) == TRIANGULATION)
    assert np.isnan(out.wh[[10, 11, 12]]).all() and np.allclose(out.top_z, 2.2)  # heights interpolated too
    np.testing.assert_allclose(out.xyz, np.stack([0.1 * got, 2.0 - 0.05 * got, np.ones(len(got))], axis=1),
                               atol=1e-12)


def test_smoother_pushed_at_once_equals_point_by_point():
    rng = np.random.default_rng(3)
    frames = np.sort(rng.choice(np.arange(200), 150, replace=False))  # gaps short and long
    xyz = rng.normal(0, 1, (150, 3))
    one = TargetSmoother(max_gap=7)
    by_point = _emitted([one.push(_points([f], xyz[k])) for k, f in enumerate(frames)] + [one.close()])
    whole = TargetSmoother(max_gap=7)
    at_once = _emitted([whole.push(_points(frames, xyz)), whole.close()])
    np.testing.assert_array_equal(at_once.frame, by_point.frame)
    np.testing.assert_allclose(at_once.xyz, by_point.xyz, rtol=0, atol=1e-12)
    assert len(np.setdiff1d(at_once.frame, frames)) > 0  # some gaps were filled


def test_smoother_reduces_noise_and_is_exact_on_a_parabola():
    rng = np.random.default_rng(0)
    f = np.arange(60)
    truth = np.stack([0.02 * f, np.zeros(60), 1.0 + 0.5 * (f / 30) - 0.25 * (f / 30) ** 2], axis=1)
    for noise, check in ((0.0, "exact"), (0.02, "less")):
        sm = TargetSmoother(max_gap=7)
        noisy = truth + rng.normal(0, noise, truth.shape)
        out = [sm.push(_points([int(i)], noisy[i])) for i in f]
        xyz = _emitted(out + [sm.close()]).xyz
        if check == "exact":
            np.testing.assert_allclose(xyz, truth, atol=1e-12)  # quadratic Savitzky-Golay keeps parabolas
        else:
            assert np.mean(np.linalg.norm(xyz - truth, axis=1)) < 0.8 * np.mean(np.linalg.norm(noisy - truth, axis=1))


def test_smoother_latency_is_half_window():
    sm = TargetSmoother(max_gap=7, half_window=2)
    emitted = [len(_emitted([sm.push(_points([f], [0, 0, 1.0]))])) for f in range(10)]
    assert emitted == [0, 0, 1, 1, 1, 1, 1, 1, 1, 1]


# ---------------------------------------------------------------- numpy reference of the body box
def ref_half_lengths(rig, wh, depth, along, across, half_depth):
    """(N,) the half-length along the plane measured per row (NaN: no view measured)."""
    right = np.stack([cam.R[0] for cam in rig])  # (C, 3) camera x-axes in world coordinates
    f = np.array([cam.K[0, 0] for cam in rig])
    ca, cb = np.abs(along @ right.T), np.abs(across @ right.T)
    with np.errstate(invalid="ignore", divide="ignore"):
        metres = wh[..., 0] * depth / f
        if half_depth is None:
            a = metres / (2 * (ca + cb))
        else:
            a = np.where(ca >= MIN_LENGTH_COS, (metres / 2 - half_depth * cb) / ca, np.nan)
    a = np.where(np.isfinite(a) & (depth > 0), a, -np.inf).max(axis=1)
    return np.where(np.isfinite(a), np.maximum(a, MIN_HALF_LENGTH), np.nan)


def ref_body_lengths(rig, X, top, bot, a, along, across, b):
    """(N, C) max(w, h) of the projected body box, corners projected with cv2.projectPoints."""
    out = np.full((len(X), len(rig)), np.nan)
    for n in range(len(X)):
        corners = np.array([[*(X[n, :2] + sa * a[n] * along[n, :2] + sb * b[n] * across[n, :2]), z]
                            for sa in (-1, 1) for sb in (-1, 1) for z in (bot[n], top[n])])
        for c, cam in enumerate(rig):
            front = cam.depth(corners) > 1e-12
            if front.any():
                uv = cv2.projectPoints(corners[front], cv2.Rodrigues(cam.R)[0], cam.t, cam.K, cam.dist)[0][:, 0]
                out[n, c] = (uv.max(axis=0) - uv.min(axis=0)).max()
    return out


def ref_buffered_boxes(rig, X, top, bot, wh, scale, prior, normal):
    """The Eq. 14 boxes with the body box, row by row in numpy / OpenCV."""
    N, C = wh.shape[:2]
    across = np.tile([0.0, 1.0, 0.0] if normal is None else [normal[0], normal[1], 0.0], (N, 1))
    across /= np.linalg.norm(across, axis=1, keepdims=True)
    along = np.stack([-across[:, 1], across[:, 0], np.zeros(N)], axis=1)
    depth = np.stack([cam.depth(X) for cam in rig], axis=1)
    a = ref_half_lengths(rig, wh, depth, along, across, None if normal is None else BODY_HALF_DEPTH)
    for n in range(N):  # rows without a measurement keep the last one
        a[n] = a[n] if np.isfinite(a[n]) else (a[n - 1] if n else prior)
    b = a if normal is None else np.full(N, BODY_HALF_DEPTH)
    ell = np.where(np.isfinite(wh).all(axis=2), wh.max(axis=2), np.nan)
    size = np.where(np.isfinite(ell), ell, ref_body_lengths(rig, X, top, bot, a, along, across, b))
    uv = np.stack([cam.project(X) for cam in rig], axis=1)
    box = np.concatenate([uv, scale * size[..., None], scale * size[..., None]], axis=2)
    return box, a[-1]


@pytest.mark.parametrize("normal", [np.array([1.0, 0.0, 0.0]), np.array([0.6, 0.8, 0.0]), None])
def test_buffered_boxes_match_the_reference(normal):
    rig = ring_rig([0, 70, 180, 250], dist=(-0.05, 0.01, 0.001, -0.001, 0.002))
    rng = np.random.default_rng(7)
    N = 40
    X = np.column_stack([rng.uniform(-1, 1, (N, 2)), rng.uniform(0.5, 2.5, N)])
    top, bot = X[:, 2] + rng.uniform(0.2, 1.0, N), X[:, 2] - rng.uniform(0.2, 1.0, N)
    uv = np.stack([cam.project(X) for cam in rig], axis=1)
    wh = rng.uniform(60, 300, (N, 4, 2))
    wh[rng.random((N, 4)) < 0.4] = np.nan  # views without a detection
    wh[5:9] = np.nan  # rows no view measured
    memory = {"half_length": 0.4}
    box, ok = buffered_boxes(rig, X, top, bot, wh, 1.3, memory, normal)
    ref, last = ref_buffered_boxes(rig, X, top, bot, wh, 1.3, 0.4, normal)
    np.testing.assert_allclose(box, ref, rtol=1e-6, atol=1e-6)
    assert memory["half_length"] == pytest.approx(last)
    size = np.array([cam.size for cam in rig], float)
    inside = (uv[..., 0] >= 0) & (uv[..., 0] <= size[:, 0]) & (uv[..., 1] >= 0) & (uv[..., 1] <= size[:, 1])
    np.testing.assert_array_equal(ok, inside & (ref[..., 2] > 0))


def test_buffered_boxes_eq14_with_detections_and_the_body_box_without():
    rig = ring_rig([0, 90], dist=(-0.05, 0.01, 0, 0, 0))
    X = np.array([[0.2, 0.1, 1.2], [0.3, 0.1, 1.2], [0.4, 0.1, 1.2]])
    wh = np.full((3, 2, 2), np.nan)
    wh[0, 0] = [120.0, 200.0]
    wh[2, 0] = [220.0, 90.0]
    memory = {}
    normal = np.array([1.0, 0.0, 0.0])  # the plane x = 0
    box, ok = buffered_boxes(rig, X, np.full(3, 2.0), np.full(3, 0.4), wh, 1.3, memory, normal)
    assert ok.all()
    for c, cam in enumerate(rig):
        np.testing.assert_allclose(box[:, c, :2], cam.project(X))  # centred on the projected 3D centre
    np.testing.assert_allclose(box[[0, 2], 0, 2], [260.0, 286.0])  # alpha * max(w, h) of the detection
    np.testing.assert_array_equal(box[..., 2], box[..., 3])  # square
    # cam0 faces the plane: its box widths measure the half-length (row 1 keeps row 0's)
    a = np.array([120.0, 120.0, 220.0]) * rig[0].depth(X) / rig[0].K[0, 0] / 2
    a[1] = a[0]
    for n in range(3):  # cam1 (and cam0 in row 1): alpha * max(w, h) of the projected body box
        corners = np.array([[X[n, 0] + sb * BODY_HALF_DEPTH, X[n, 1] + sa * a[n], z]
                            for sa in (-1, 1) for sb in (-1, 1) for z in (0.4, 2.0)])
        for c in range(2):
            if np.isfinite(wh[n, c, 0]):
                continue
            uv = cv2.projectPoints(corners, cv2.Rodrigues(rig[c].R)[0], rig[c].t, rig[c].K, rig[c].dist)[0][:, 0]
            assert box[n, c, 2] == pytest.approx(1.3 * (uv.max(axis=0) - uv.min(axis=0)).max(), rel=1e-3)
    assert memory["half_length"] == pytest.approx(a[2], rel=1e-3)


def test_body_half_length_recovers_a_body_box_seen_face_on():
    """A body box (half-length 0.6 m along the plane, half-depth 0.25 m across) seen by a view
    facing the plane: its projected box, given as the detection, measures the half-length again
    (to the perspective error of a 0.5 m deep box at 10 m), and a view without a detection gets
    the projected body box."""
    rig = ring_rig([0, 90], radius=10.0)
    X = np.array([[0.0, 0.0, 1.2]])
    corners = np.array([[sb * 0.25, sa * 0.6, z] for sa in (-1, 1) for sb in (-1, 1) for z in (0.4, 2.0)])
    uv = rig[0].project(corners)
    w, h = uv.max(axis=0) - uv.min(axis=0)
    assert abs(rig[0].R[0] @ [0.0, 1.0, 0.0]) > 0.9  # the view does face the plane x = 0
    memory = {}
    box, _ = buffered_boxes(rig, X, np.array([2.0]), np.array([0.4]), np.array([[[w, h], [np.nan, np.nan]]]), 1.0,
                            memory, np.array([1.0, 0.0, 0.0]))
    assert memory["half_length"] == pytest.approx(0.6, rel=0.05)
    side = rig[1].project(np.array([[sb * 0.25, sa * 0.6, z] for sa in (-1, 1) for sb in (-1, 1) for z in (0.4, 2.0)]))
    assert box[0, 1, 2] == pytest.approx((side.max(axis=0) - side.min(axis=0)).max(), rel=0.05)


def test_track_box_sizes_maps_boxes_to_their_track_points():
    tracks = SimpleNamespace(frame=np.array([3, 3, 4]), track_id=np.array([1, 7, 7]))
    boxes = Detections.from_arrays(np.array([3, 3, 4, 4, 5]), np.array([0, 1, 1, 0, 0]),
                                   np.array([[0, 0, 10, 20], [0, 0, 11, 21], [0, 0, 12, 22], [0, 0, 13, 23],
                                             [0, 0, 14, 24]], float), ("a", "b"), track_id=np.array([7, 1, 7, 2, 7]))
    wh = track_box_sizes(tracks, boxes, 2)
    expected = np.full((3, 2, 2), np.nan)
    expected[1, 0] = [10, 20]  # frame 3, track 7, view a
    expected[0, 1] = [11, 21]  # frame 3, track 1, view b
    expected[2, 1] = [12, 22]  # frame 4, track 7, view b; (4, track 2) and (5, track 7) have no point
    np.testing.assert_array_equal(wh, expected)


def test_backfill_hand_worked():
    # frames 0..9; track 4 identified at frame 6, track 9 was the target until frame 2
    decision = np.array([9, 9, 9, -1, -1, -1, 4, 4, 4, -1])
    index = np.array([0, 1, 2, 3, 4, 5, 6, 7, 8, 1, 2, 4, 5, 6, 8])
    tid = np.array([9, 9, 9, 9, 9, 9, 9, 9, 9, 4, 4, 4, 4, 4, 4])
    out = backfill(decision.copy(), index, tid, frames=30)
    # frames 3..5 had no target: track 4 gets 4 and 5 (it has no point at 3); frames <= 2 stay 9's
    np.testing.assert_array_equal(out, [9, 9, 9, -1, 4, 4, 4, 4, 4, -1])
    np.testing.assert_array_equal(backfill(decision.copy(), index, tid, frames=1), [9, 9, 9, -1, -1, 4, 4, 4, 4, -1])
    np.testing.assert_array_equal(backfill(decision.copy(), index, tid, frames=0), decision)
    # changes before ``since`` were handled already: nothing happens
    np.testing.assert_array_equal(backfill(decision.copy(), index, tid, frames=30, since=7), decision)
    # a lost target is held (no points) until Eq. 13 lets it go: its successor takes those frames
    held = np.array([9, 9, 9, 9, 9, 9, 4, 4, 4, -1])  # track 9's last point is at frame 2
    index2 = np.array([0, 1, 2, 1, 2, 4, 5, 6, 8])
    tid2 = np.array([9, 9, 9, 4, 4, 4, 4, 4, 4])
    np.testing.assert_array_equal(backfill(held, index2, tid2, frames=30), [9, 9, 9, 9, 4, 4, 4, 4, 4, -1])


def test_target_backfill_streaming_equals_offline():
    rng = np.random.default_rng(5)
    F = 200
    decision = np.full(F, -1)
    for a, b, t in ((20, 60, 3), (75, 120, 8), (121, 150, 3), (170, 200, 8)):
        decision[a:b] = t
    rows = [(f, t) for f in range(F) for t in (3, 8, 11) if rng.random() < 0.8]
    frame = np.array([r[0] for r in rows])
    tid = np.array([r[1] for r in rows])
    offline = backfill(decision.copy(), frame, tid, 30)
    buf = TargetBackfill(30)
    got = []
    cuts = np.sort(rng.choice(np.arange(1, F), 25, replace=False)).tolist() + [F]
    a = 0
    for b in cuts:  # uneven chunks of final frames, released 30 frames late
        m = (frame >= a) & (frame < b)
        n = int(m.sum())
        buf.push(a, decision[a:b], TargetRows.of(frame[m], tid[m], np.zeros((n, 3)), np.zeros(n), np.zeros(n),
                                                 np.zeros(n), np.full((n, 2, 2), np.nan)))
        out = buf.pop(b - 1 - 30)
        got += [] if out is None else list(zip(out.frame.tolist(), out.track_id.tolist()))
        a = b
    out = buf.pop()
    got += [] if out is None else list(zip(out.frame.tolist(), out.track_id.tolist()))
    expected = [(f, t) for f, t in zip(frame.tolist(), tid.tolist()) if offline[f] == t]
    assert got == expected
    assert len(buf) == 0
    assert offline[45] == 3 and np.count_nonzero(offline[60:75] == 8) > 0  # track 8 took frames before 75


@pytest.mark.parametrize("renamed", [True, False])
def test_handover_rename_counts_the_new_tracks_held_rows_for_the_target(renamed):
    """Track 1 (the target) ends at frame 20; track 2 resumes the gymnast from frame 21, standing
    (in S_perf, never qualifying). Handed over at frame 27: with the selector's rows of track 2
    renamed, frames 21..27 count for the target and it is kept; without, the last Delta = 10
    frames hold 2 of its points and it is lost at once."""
    sel = TargetSelector(identify_frames=10)
    rows = {f: [(1, True, True)] for f in range(21)}
    for f in range(21, 28):
        rows[f] = [(2, False, True)]
    before = run_selector(sel, range(21), rows, {})
    assert before[5] == 1 and np.all(before[5:] == 1)
    lost = run_selector(sel, range(21, 28), rows, {1: 20})
    assert np.all(lost == -1) and sel.last_target == 1  # ended, and track 2 never qualifies
    if renamed:
        sel.rename(2, 1, 20)
        assert np.all(sel._tid[sel._frame > 20] == 1) and np.all(sel._tid[sel._frame <= 20] == 1)
    sel.target = 1  # the handover resumes the lost target
    after = run_selector(sel, range(28, 36), {f: [(1, False, True)] for f in range(28, 36)}, {})
    if renamed:
        assert np.all(after == 1)  # frames 19..28 all in S_perf under the target's id: 10 > 5
    else:
        assert np.all(after == -1)  # frames 19, 20 and 28 only: 3 <= 5


def test_selector_rename_touches_only_that_tracks_rows_after_the_frame():
    sel = TargetSelector(identify_frames=10)
    tid = np.array([2, 3, 2, 2, 3])
    frame = np.array([4, 5, 5, 6, 6])
    sel.select(4, 6, frame, tid, np.zeros(5, bool), np.ones(5, bool), {})
    sel.rename(2, 7, 4)
    assert sel._tid.tolist() == [2, 3, 7, 7, 3]


def _run_with_support(sel, frames, rows):
    """rows: frame -> list of (track id, indicator, support). Returns the target per frame."""
    out = []
    for f in frames:
        r = rows.get(f, [])
        tid = np.array([x[0] for x in r], np.int64)
        ind = np.array([x[1] for x in r], bool)
        sup = np.array([x[2] for x in r], np.int64)
        out.append(sel.select(f, f, np.full(len(tid), f, np.int64), tid, ind, np.ones(len(tid), bool), {}, sup)[0])
    return np.array(out)


def test_reidentify_gives_the_target_to_a_better_supported_qualifying_track():
    # track 1: a phantom seen in one view (support 2) qualifying from frame 0; track 2: the
    # gymnast in 3 views, triangulated (support 7), qualifying from frame 10
    rows = {f: [(1, True, 2)] + ([(2, True, 7)] if f >= 10 else []) for f in range(40)}
    paper = _run_with_support(TargetSelector(identify_frames=10), range(40), rows)
    assert paper[4] == -1 and np.all(paper[5:] == 1)  # the paper's Eq. 13 holds the phantom
    counts = {}
    sel = TargetSelector(identify_frames=10, reidentify=True, counts=counts)
    target = _run_with_support(sel, range(40), rows)
    assert np.all(target[5:15] == 1)  # frames 10..14: 5 of 10 better supported, not more than half
    assert np.all(target[15:] == 2)  # frame 15: 6 of the last 10
    assert sel.switches == 1 and sel.identifications == 2 and counts["target_reidentifications"] == 1


def test_reidentify_needs_a_qualifying_track_with_more_support():
    counts = {}
    # track 2 as well supported as the target; track 3 better supported but never qualifying
    # (on the floor); track 4 better supported in only 5 of every 10 frames
    rows = {f: [(1, True, 4), (2, f >= 10, 4), (3, False, 8), (4, f >= 10, 6 if f % 2 else 3)] for f in range(40)}
    sel = TargetSelector(identify_frames=10, reidentify=True, counts=counts)
    target = _run_with_support(sel, range(40), rows)
    assert np.all(target[5:] == 1) and sel.switches == 0 and counts == {}


def _sizes(views, n_cameras=4):
    """(C, 2) detection sizes of a point seen in ``views`` (NaN elsewhere)."""
    wh = np.full((n_cameras, 2), np.nan)
    wh[list(views)] = (60.0, 150.0)
    return wh


def test_point_support_counts_the_views_with_a_detection():
    wh = np.stack([_sizes([]), _sizes([0]), _sizes([0, 1]), _sizes([0, 1, 3])])
    assert point_support(wh).tolist() == [0, 1, 2, 3]


def test_reidentify_keeps_the_target_from_a_triangulated_wrong_pair_of_the_same_views():
    # the gymnast (track 1): the opposite pair cam0/cam1, a plane candidate, from frame 0; a
    # phantom (track 2) from frame 10: a wrong pair of boxes of the same two views whose rays
    # meet short of opposite, so it is triangulated. Both qualify (on the high bar / in the air).
    gymnast, phantom = point_support(np.stack([_sizes([0, 1])] * 2))  # plane candidate, triangulated
    rows = {f: [(1, True, int(gymnast))] + ([(2, True, int(phantom))] if f >= 10 else []) for f in range(60)}
    counts = {}
    sel = TargetSelector(identify_frames=10, reidentify=True, counts=counts)
    target = _run_with_support(sel, range(60), rows)
    assert np.all(target[5:] == 1) and sel.switches == 0 and counts == {}
    # the same phantom does take the target from a track seen in one view only
    rows = {f: [(1, True, int(point_support(_sizes([1])[None])[0]))] + ([(2, True, int(phantom))] if f >= 10 else [])
            for f in range(60)}
    sel = TargetSelector(identify_frames=10, reidentify=True)
    target = _run_with_support(sel, range(60), rows)
    assert np.all(target[5:15] == 1) and np.all(target[15:] == 2) and sel.switches == 1


def test_paper_selector_keeps_no_support_and_reidentify_needs_it():
    rows = {f: [(1, True, 2)] + ([(2, True, 7)] if f >= 10 else []) for f in range(20)}
    paper = TargetSelector(identify_frames=10)
    target = _run_with_support(paper, range(20), rows)
    assert np.all(target[5:] == 1) and len(paper) == 20 and len(paper._support) == 0  # frames 10..19, 2 rows each
    on = TargetSelector(identify_frames=10, reidentify=True)
    _run_with_support(on, range(20), rows)
    assert len(on._support) == len(on) and on.counts == {"target_reidentifications": 1}
    with pytest.raises(ValueError, match="support"):
        on.select(20, 20, np.array([20]), np.array([1]), np.array([True]), np.array([True]), {})
