"""The take-over's look-back (the recipe's ``reidentify``, gymtrack.tracking.identify): when a
better-seen track takes the target over, the frames just before where it had a point seen in at
least as many views as the old target become its own. Hand-worked arrays for :func:`backfill`, the selector and
back-fill together, and cascade+ on a simulated rings routine against its ground truth."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.modes import RECIPES
from gymtrack.simulate.routine import simulate_routine
from gymtrack.tracking import identify
from gymtrack.tracking.identify import TargetBackfill, TargetSelector, backfill, point_support
from gymtrack.tracking.offline import track_detections
from gymtrack.tracking.types import TargetRows


def _points(spec, n_frames):
    """spec: track -> {frame: support}. Returns index, track_id, support (n,) in frame order."""
    rows = sorted((f, t, s) for t, d in spec.items() for f, s in d.items() if f < n_frames)
    f, t, s = (np.array(x, np.int64) for x in zip(*rows))
    return f, t, s


def test_the_run_of_better_seen_frames_before_a_take_over_is_the_new_tracks():
    """Track 1 (the target, 2 views) has a point in every frame; track 2 takes over at frame 20.
    Track 2 is seen in 2 views at frames 8-11 (as many as track 1), has no point at 13, and 3
    views at 12 and 14-24: the run that ends at the take-over is 14-19 (6 frames; frame 13,
    without a point of track 2, ends it). Frames 12 and before stay track 1's."""
    decision = np.r_[np.ones(20, np.int64), np.full(5, 2)]
    sup2 = {f: 2 for f in range(8, 12)} | {12: 3} | {f: 3 for f in range(14, 25)}
    index, tid, support = _points({1: {f: 2 for f in range(25)}, 2: sup2}, 25)
    counts = {}
    backfill(decision, index, tid, 60, takeover=(np.array([20]), support, counts))
    assert decision.tolist() == [1] * 14 + [2] * 11
    assert counts == {"target_frames_taken_over": 6}


def test_the_look_back_stops_at_the_back_fill_reach_and_at_the_old_targets_better_frames():
    """Reach of 4 frames: only 16-19 can change. A frame where the old target is seen in more views
    than the new one (frame 18) ends the run: only frame 19 changes; where it is seen in as many
    (a tie goes to the track that won), all four change. A change of target that is not a
    take-over (an identification after none) is left to the plain back-fill."""
    for at_18, changed in ((4, 1), (3, 4)):
        decision = np.r_[np.ones(20, np.int64), np.full(5, 2)]
        sup1 = {f: 2 for f in range(25)} | {18: at_18}
        index, tid, support = _points({1: sup1, 2: {f: 3 for f in range(25)}}, 25)
        backfill(decision, index, tid, 4, takeover=(np.array([20]), support, {}))
        assert decision.tolist() == [1] * (20 - changed) + [2] * (5 + changed)
    plain = np.r_[np.full(20, -1), np.full(5, 2)]
    backfill(plain, index, tid, 4, takeover=(np.array([20]), support, {}))  # not a take-over: -1 before
    assert plain.tolist() == [-1] * 16 + [2] * 9  # the plain back-fill's look-back of 4


def _rows(frames, spec, n_cameras=4):
    """TargetRows of frames ``frames``: spec track -> (first frame, views)."""
    rows = [(f, t, views) for f in frames for t, (first, views) in sorted(spec.items()) if f >= first]
    n = len(rows)
    wh = np.full((n, n_cameras, 2), np.nan)
    for i, (_, _, views) in enumerate(rows):
        wh[i, list(views)] = (60.0, 150.0)
    f = np.array([r[0] for r in rows], np.int64)
    t = np.array([r[1] for r in rows], np.int64)
    return TargetRows.of(f, t, np.zeros((n, 3)), np.full(n, 2.5), np.full(n, 0.8), np.zeros(n), wh)


@pytest.mark.parametrize("takeover", [False, True])
def test_selector_and_back_fill_give_the_challenged_frames_to_the_new_target(takeover):
    """A phantom (track 1, one view) qualifies from frame 0; the gymnast (track 2, three views)
    from frame 10. Delta = 10: the phantom is identified at frame 5, the gymnast takes over at
    frame 15 (6 of the last 10 frames better seen). With the take-over's look-back, frames
    10-14 (the frames its challenge counted) are the gymnast's too; without it, the phantom's."""
    counts = {}
    sel = TargetSelector(identify_frames=10, reidentify=True, counts=counts)
    fill = TargetBackfill(60, takeover=counts if takeover else None)
    spec = {1: (0, [0]), 2: (10, [0, 1, 2])}
    for a in range(0, 40, 5):
        rows = _rows(range(a, a + 5), spec)
        ind = np.ones(len(rows.frame), bool)
        decision = sel.select(a, a + 4, rows.frame, rows.track_id, ind, ind, {}, point_support(rows.wh))
        fill.push(a, decision, rows, sel.pop_takeovers())
    got = fill.pop()
    target = np.full(40, -1)
    target[got.frame] = got.track_id
    assert counts["target_reidentifications"] == 1 and sel.switches == 1
    assert (target[:5] == 1).all()  # the plain back-fill of the phantom's identification
    assert (target[5:10] == 1).all() and (target[15:] == 2).all()
    if takeover:
        assert (target[10:15] == 2).all() and counts["target_frames_taken_over"] == 5
    else:
        assert (target[10:15] == 1).all() and "target_frames_taken_over" not in counts


# ----------------------------------------------------------------------------- against ground truth
@pytest.fixture(scope="module")
def rings_lift():
    """Still rings, four views (a suite routine of seed 2): the coach lifts the gymnast to the
    rings; a track beside her is identified first, and the gymnast's takes over."""
    return simulate_routine("still_rings", n_cam=4, seed=2108521801, seconds=25)


def _far_frames(res, sim):
    """Performing frames whose target point lies more than 0.5 m from the gymnast's centre."""
    lo, hi = np.array(sim.scene.performance_space[:3]), np.array(sim.scene.performance_space[3:])
    inside = np.all((sim.centre[0] >= lo) & (sim.centre[0] <= hi), axis=1) & sim.performing
    rows = np.isin(res.target.frame, sim.frames[inside])
    err = np.linalg.norm(res.target.xyz[rows] - sim.centre[0][res.target.frame[rows] - sim.frames[0]], axis=1)
    return set(res.target.frame[rows][err > 0.5].tolist())


def test_cascade_plus_follows_the_gymnast_sooner_after_a_take_over(rings_lift, monkeypatch):
    """The tracks are the same with and without the take-over's look-back; it makes no frame far
    from the gymnast, and at least 30 near (measured: 34 of the 56 it gives back were far; in
    the rest the old target, the track beside her, was near her too)."""
    sim = rings_lift
    on = track_detections(sim.rig, sim.scene, sim.detections, mode=RECIPES["cascade+"])
    monkeypatch.setattr(identify, "_take_over", lambda *a, **k: None)
    off = track_detections(sim.rig, sim.scene, sim.detections, mode=RECIPES["cascade+"])
    assert np.array_equal(on.tracks.xyz, off.tracks.xyz) and np.array_equal(on.tracks.track_id, off.tracks.track_id)
    given = on.summary["target_frames_taken_over"]
    assert on.summary["target_reidentifications"] >= 1 and given >= 10
    far_on, far_off = _far_frames(on, sim), _far_frames(off, sim)
    assert far_on <= far_off and len(far_off) - len(far_on) >= 30
