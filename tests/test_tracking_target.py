"""The target gymnast: Eq. 13 identification and re-identification, gap filling and smoothing,
and the Eq. 14 pose boxes."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent))
from test_tracking_synth import ring_rig  # noqa: E402

from gymtrack.tracking.target import TargetSelector, TargetSmoother, buffered_boxes, identify_indicator, project_all  # noqa: E402
from gymtrack.tracking.types import INTERPOLATED, TRIANGULATION  # noqa: E402


def run_selector(sel, frames, rows, ended):
    """rows: frame -> list of (track id, indicator, in_perf). Returns the target per frame."""
    out = []
    for f in frames:
        r = rows.get(f, [])
        tid = np.array([x[0] for x in r], np.int64)
        out.append(sel.step(f, tid, np.array([x[1] for x in r], bool), np.array([x[2] for x in r], bool), ended))
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


def _point(f, xyz, tid=1, ell=None):
    return (f, tid, np.asarray(xyz, float), 2.2, 0.8, TRIANGULATION, np.full(2, np.nan) if ell is None else ell)


def test_smoother_fills_short_gaps_keeps_long_ones_and_preserves_lines():
    sm = TargetSmoother(max_gap=7, half_window=2)
    out = []
    frames = list(range(0, 10)) + list(range(13, 20)) + list(range(30, 40))  # gaps of 3 and 10 frames
    for f in frames:
        out += sm.push(_point(f, [0.1 * f, 2.0 - 0.05 * f, 1.0]))
        out += sm.advance(f)
    out += sm.close()
    got = np.array([o[0] for o in out])
    np.testing.assert_array_equal(got, list(range(0, 20)) + list(range(30, 40)))
    src = np.array([o[5] for o in out])
    assert np.all(src[[10, 11, 12]] == INTERPOLATED) and np.all(np.delete(src, [10, 11, 12]) == TRIANGULATION)
    xyz = np.stack([o[2] for o in out])
    np.testing.assert_allclose(xyz, np.stack([0.1 * got, 2.0 - 0.05 * got, np.ones(len(got))], axis=1), atol=1e-12)


def test_smoother_reduces_noise_and_is_exact_on_a_parabola():
    rng = np.random.default_rng(0)
    f = np.arange(60)
    truth = np.stack([0.02 * f, np.zeros(60), 1.0 + 0.5 * (f / 30) - 0.25 * (f / 30) ** 2], axis=1)
    for noise, check in ((0.0, "exact"), (0.02, "less")):
        sm = TargetSmoother(max_gap=7)
        noisy = truth + rng.normal(0, noise, truth.shape)
        out = []
        for i in f:
            out += sm.push(_point(int(i), noisy[i]))
        out += sm.close()
        xyz = np.stack([o[2] for o in out])
        if check == "exact":
            np.testing.assert_allclose(xyz, truth, atol=1e-12)  # quadratic Savitzky-Golay keeps parabolas
        else:
            assert np.mean(np.linalg.norm(xyz - truth, axis=1)) < 0.8 * np.mean(np.linalg.norm(noisy - truth, axis=1))


def test_smoother_latency_is_half_window():
    sm = TargetSmoother(max_gap=7, half_window=2)
    emitted = [len(sm.push(_point(f, [0, 0, 1.0]))) for f in range(10)]
    assert emitted == [0, 0, 1, 1, 1, 1, 1, 1, 1, 1]


def test_buffered_boxes_eq14():
    rig = ring_rig([0, 90], dist=(-0.05, 0.01, 0, 0, 0))
    X = np.array([[0.2, 0.1, 1.2], [0.3, 0.1, 1.2], [0.4, 0.1, 1.2]])
    ell = np.array([[200.0, np.nan], [np.nan, np.nan], [220.0, np.nan]])
    memory = {}
    box, ok = buffered_boxes(rig, X, np.full(3, 2.0), np.full(3, 0.4), ell, 1.3, memory)
    assert ok.all()
    for c, cam in enumerate(rig):
        np.testing.assert_allclose(box[:, c, :2], cam.project(X))  # centred on the projected 3D centre
    np.testing.assert_allclose(box[[0, 2], 0, 2], [260.0, 286.0])  # alpha * l
    np.testing.assert_array_equal(box[..., 2], box[..., 3])  # square
    d = rig[0].depth(X)
    assert box[1, 0, 2] == pytest.approx(260.0 * d[0] / d[1])  # last size, scaled by depth
    # a view that never saw the target: the projected top-bottom extent
    extent = np.linalg.norm(rig[1].project(np.array([[0.2, 0.1, 2.0]])) - rig[1].project(np.array([[0.2, 0.1, 0.4]])))
    assert box[0, 1, 2] == pytest.approx(1.3 * extent)
    assert memory["ell"][0] == 220.0


def test_project_all_matches_camera_project():
    rig = ring_rig([0, 100, 200], dist=(-0.1, 0.02, 0.001, -0.001, 0.003))
    X = np.random.default_rng(1).uniform(-2, 2, (30, 3))
    uv, depth = project_all(rig, X)
    for c, cam in enumerate(rig):
        np.testing.assert_allclose(uv[:, c], cam.project(X), atol=1e-9)
        np.testing.assert_allclose(depth[:, c], cam.depth(X), atol=1e-12)
