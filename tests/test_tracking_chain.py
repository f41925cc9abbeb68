"""The recipe's ``chain`` (gymtrack.tracking.chain): an identification's look-back goes on to the
track its track continues. Hand-worked predecessors, the back-fill with and without it, and
cascade+ with and without it on a simulated vault whose run-up track breaks at the take-off."""

from __future__ import annotations

from collections import defaultdict

import numpy as np
import pytest

from gymtrack.modes import RECIPES
from gymtrack.simulate.routine import simulate_routine
from gymtrack.tracking.chain import GATE, chain_back, predecessor
from gymtrack.tracking.identify import backfill
from gymtrack.tracking.offline import track_detections


def _points():
    """Track 1 runs along x at 0.2 m a frame over frames 0-9 and its end box is held (frames 10-12
    repeat frame 9's point); track 2 is born at frame 16 where track 1's run leads (x = 1.8 + 7 *
    0.2 = 3.2); track 3 stands at x = 2.5 until frame 14 (0.7 m from track 2's birth: within the
    gate, but farther than track 1's prediction); track 4 passes by and goes on after frame 16;
    track 5, where track 2 is born, ended too long before (frame 0)."""
    rows = []
    for f in range(13):
        rows.append((f, 1, 0.2 * min(f, 9)))
    for f in range(16, 30):
        rows.append((f, 2, 3.2 + 0.2 * (f - 16)))
    for f in range(0, 15):
        rows.append((f, 3, 2.5))
    for f in range(5, 30):
        rows.append((f, 4, 3.3))
    rows.append((0, 5, 3.2))
    rows.sort()
    index = np.array([r[0] for r in rows])
    tid = np.array([r[1] for r in rows])
    xyz = np.zeros((len(rows), 3))
    xyz[:, 0] = [r[2] for r in rows]
    xyz[:, 2] = 1.0
    return index, tid, xyz


def test_the_predecessor_is_the_nearest_prediction_of_a_track_that_ended_in_the_gap():
    index, tid, xyz = _points()
    assert predecessor(index, tid, xyz, 2, gap=15) == (1, 12)
    # without track 1 the standing track 3 is the nearest within the gate
    keep = tid != 1
    assert predecessor(index[keep], tid[keep], xyz[keep], 2, gap=15) == (3, 14)
    # a gap shorter than track 1's break (frames 13-15) leaves track 3; shorter still, none
    assert predecessor(index, tid, xyz, 2, gap=3) == (3, 14)
    assert predecessor(index, tid, xyz, 2, gap=1) == (-1, -1)
    # moved beyond the gate: none
    far = xyz.copy()
    far[tid == 2, 1] += GATE + 0.8
    assert predecessor(index, tid, far, 2, gap=15) == (-1, -1)


def test_backfill_with_the_chain_hands_the_run_up_its_frames():
    """Track 2 is identified at frame 25: the look-back (20 frames) reaches frame 5. Without the
    chain only track 2's frames 16-24 are back-filled; with it, track 1's frames 5-12 too."""
    index, tid, xyz = _points()
    F = 30
    base = np.full(F, -1)
    base[25:] = 2
    plain = backfill(base.copy(), index, tid, 20)
    assert (plain[16:25] == 2).all() and (plain[:16] == -1).all()
    counts = defaultdict(int)
    got = backfill(base.copy(), index, tid, 20, chain=(xyz, 15, counts))
    assert (got[16:25] == 2).all() and (got[5:13] == 1).all() and (got[13:16] == -1).all() and (got[:5] == -1).all()
    assert counts["target_frames_chained"] == 8
    # chain_back alone: what is pointed already stays
    decision = np.full(F, -1)
    pointed = np.zeros(F, bool)
    pointed[8] = True
    assert chain_back(decision, pointed, index, tid, xyz, 2, 5, 15) == 7 and decision[8] == -1


@pytest.fixture(scope="module")
def vault_take_off():
    """A vault seen by two opposite views (suite routine of seed 0, r0): the run-up's track breaks
    over the table and a new track is born in the second flight; Eq. 13 identifies only the new one."""
    return simulate_routine("vault", n_cam=2, seed=3141116543, seconds=25)


def test_chain_gives_the_target_its_run_up(vault_take_off):
    sim = vault_take_off
    plus = RECIPES["cascade+"]
    on, off = (track_detections(sim.rig, sim.scene, sim.detections, mode=m) for m in (plus, plus.without("chain")))
    assert np.array_equal(on.tracks.track_id, off.tracks.track_id) and np.array_equal(on.tracks.xyz, off.tracks.xyz)
    assert on.summary["target_frames_chained"] > 0 and "target_frames_chained" not in off.summary
    space = np.asarray(sim.scene.performance_space, float)
    inside = np.all((sim.centre[0] >= space[:3]) & (sim.centre[0] <= space[3:]), axis=1)
    perf = sim.frames[inside & sim.performing]

    def near(res):  # performing frames whose target lies within 0.5 m of the gymnast's centre
        rows = np.isin(res.target.frame, perf)
        err = np.linalg.norm(res.target.xyz[rows] - sim.centre[0][res.target.frame[rows] - sim.frames[0]], axis=1)
        return int(np.count_nonzero(err < 0.5))

    # (measured: 80 and 48 of 91)
    assert near(on) >= 0.8 * len(perf) and near(on) >= near(off) + 20
