"""The reach rule (gymtrack.tracking.reach): a raised point away from the apparatus counts for
Eq. 13 only for a flight's length; hand-worked runs on the presets, and the target stage giving
a phantom up, and cascade+ with and without it on a simulated vault (the recipe's test of the
ingredient switched off alone, kept beside the rule's own tests)."""

from __future__ import annotations

import numpy as np
import pytest

from conftest import ring_rig

from gymtrack.detections import Detections
from gymtrack.formats.scene import preset_scene
from gymtrack.modes import RECIPES
from gymtrack.placement import apparatus_distance, scene_geometry
from gymtrack.simulate.routine import simulate_routine
from gymtrack.tracking.offline import track_detections
from gymtrack.tracking.reach import MAX_FLIGHT_SECONDS, REACH, ReachLimit
from gymtrack.tracking.target import TargetStage
from gymtrack.tracking.types import Tracks3D

FPS = 30.0
N = int(round(MAX_FLIGHT_SECONDS * FPS))  # 45 frames


def _limit(app="uneven_bars"):
    scene = preset_scene(app)
    return ReachLimit(scene_geometry(scene), scene.target.h_bot, FPS), scene


def test_a_raised_point_far_from_the_bars_counts_for_a_flights_length_across_calls():
    """Track 1 stands still 1.0 m up at the edge of the space (y = -2.79, about 2 m from the low
    bar: the phantom of a two-camera routine): its first 45 frames count, none after, the run
    carried over the calls. Track 2 hangs below the high bar the whole time: every frame counts."""
    lim, scene = _limit()
    geo = scene_geometry(scene)
    phantom, hang = np.array([0.0, -2.79, 1.6]), np.array([0.0, geo.bar_a[1, 1], geo.bar_a[1, 2] - 1.1])
    assert apparatus_distance(phantom[None], geo)[0] > REACH > apparatus_distance(hang[None], geo)[0]
    got = []
    for a in range(0, 120, 25):  # five calls of 25 frames (the last 20)
        f = np.arange(a, min(a + 25, 120))
        frame = np.repeat(f, 2)
        tid = np.tile([1, 2], len(f))
        xyz = np.where((tid == 1)[:, None], phantom, hang)
        got.append((frame, tid, lim.grounded(frame, tid, xyz, np.full(len(frame), 1.0))))
    frame, tid, ok = (np.concatenate(x) for x in zip(*got))
    assert ok[tid == 2].all()
    assert np.array_equal(ok[tid == 1], np.arange(120) < N)


def test_a_grounded_point_ends_the_run_and_a_flight_counts_again():
    """Raised away for 40 frames (counted), one frame low (the run ends), raised away again for 50:
    its first 45 count. The bottom at h_bot or below, or NaN, is not raised."""
    lim, scene = _limit("vault")
    f = np.arange(91)
    bottom = np.full(91, 1.0)
    bottom[40] = scene.target.h_bot  # (not above it)
    xyz = np.tile([3.5, 0.0, 1.5], (91, 1))  # 2.9 m beyond the table's far end
    ok = lim.grounded(f, np.zeros(91, np.int64), xyz, bottom)
    want = np.ones(91, bool)
    want[41 + N:] = False
    assert np.array_equal(ok, want)
    assert lim.grounded(np.array([200]), np.array([0]), xyz[:1], np.array([np.nan]))[0]


def test_rows_of_many_tracks_in_any_order_and_a_scene_without_apparatus():
    """Rows shuffled: each keeps its own verdict. A scene without an apparatus: every point counts.
    A run not seen for longer than a flight is forgotten (its track starts a new run)."""
    lim, _ = _limit()
    rng = np.random.default_rng(0)
    frame = np.repeat(np.arange(60), 3)
    tid = np.tile([4, 7, 9], 60)
    xyz = np.tile([0.0, -2.79, 1.6], (180, 1))
    xyz[tid == 7] = [0.0, 0.0, 1.5]  # between the bars
    order = rng.permutation(180)
    ok = lim.grounded(frame[order], tid[order], xyz[order], np.ones(180))
    back = np.empty(180, bool)
    back[order] = ok
    assert back[tid == 7].all()
    for t in (4, 9):
        assert np.array_equal(back[tid == t], np.arange(60) < N)
    assert len(lim) == 2
    later = lim.grounded(np.array([60 + N + 1]), np.array([4]), xyz[:1], np.ones(1))
    assert later[0] and len(lim) == 1
    scene = preset_scene("uneven_bars").model_copy(update={"apparatus": None})
    free = ReachLimit(scene_geometry(scene), 0.6, FPS)
    assert free.grounded(frame, tid, xyz, np.ones(180)).all()


def _vault_tracks(F=300):
    """A phantom (track 1) standing still 1.0 m up 2.9 m beyond the vault table from frame 0, and
    the gymnast (track 2): a run-up on the floor, on and over the table (raised, within reach)
    from frame 250, and the landing beyond it."""
    f = np.arange(F)
    x = np.interp(f, [0, 250, 262, 275, 290], [-20.0, -1.0, 0.0, 2.0, 3.5])
    bottom2 = np.interp(f, [0, 245, 252, 262, 275, 285, 290], [0.0, 0.0, 0.5, 1.4, 1.2, 0.5, 0.0])
    xyz2 = np.c_[x, np.zeros(F), bottom2 + 0.8]
    frame = np.repeat(f, 2)
    tid = np.tile([1, 2], F)
    xyz = np.empty((2 * F, 3))
    xyz[0::2], xyz[1::2] = [3.5, 0.0, 1.6], xyz2
    bottom = np.empty(2 * F)
    bottom[0::2], bottom[1::2] = 1.0, bottom2
    top = bottom + 1.6
    n = 2 * F
    return Tracks3D(frame, tid, xyz, top, bottom, np.zeros(n, np.int8), np.full(n, 2, np.int8))


@pytest.mark.parametrize("reach", [False, True])
def test_the_target_stage_gives_a_phantom_up_and_takes_the_gymnast_in_her_flight(reach):
    """Eq. 13 identifies the phantom in its first frames (the gymnast runs on the floor: her
    bottom is below h_bot). Without the rule it is held for the whole routine; with it, it leaves
    once a flight's length has passed, nobody is the target on the run-up, and the gymnast is
    identified on the table (with the frames the identification looked back on: the back-fill)
    and kept through the landing."""
    scene = preset_scene("vault", fps=FPS)
    rig = ring_rig([0, 180])
    stage = TargetStage(rig, scene, reach=reach)
    tracks = _vault_tracks()
    parts = []
    for a in range(0, 300, 10):
        m = (tracks.frame >= a) & (tracks.frame < a + 10)
        parts.append(stage.update(a, a + 9, tracks.select(m), Detections.empty(rig.names), {})[0])
    parts.append(stage.finish()[0])
    got = np.full(300, -1)
    for t in parts:
        got[t.frame] = t.track_id
    assert (got[:30][got[:30] >= 0] == 1).all() and (got[30:45] == 1).all()  # identified from its first frames
    if not reach:
        assert (got[30:] == 1).all()
        return
    assert stage.counts["target_points_out_of_reach"] == 300 - N
    assert (got[N + 30:200] == -1).all()  # left within Delta frames of its flight's length
    assert (got[260:] == 2).all()  # (with the frames her identification looked back on, from 206)


# ----------------------------------------------------------------------------- the recipe, switched off alone
@pytest.fixture(scope="module")
def vault_phantom():
    """A vault seen by two opposite views (a suite routine of seed 2): an opposite pair's rays
    meet the plane 1-2 m up, 2.9 m beyond the table, for the whole routine; Eq. 13 identifies
    that point before the gymnast leaves the floor."""
    sim = simulate_routine("vault", n_cam=2, seed=674825418, seconds=25)
    return sim.rig, sim.scene, sim.detections, sim


def test_reach_gives_up_a_phantom_in_the_air_and_finds_the_gymnast(vault_phantom):
    rig, scene, det, sim = vault_phantom
    plus = RECIPES["cascade+"]
    on, off = (track_detections(rig, scene, det, mode=m) for m in (plus, plus.without("reach")))
    # only the target changes
    assert np.array_equal(on.tracks.track_id, off.tracks.track_id) and np.array_equal(on.tracks.xyz, off.tracks.xyz)
    assert on.summary["target_points_out_of_reach"] > 0 and "target_points_out_of_reach" not in off.summary
    inside = np.all((sim.centre[0] >= np.array(sim.scene.performance_space[:3]))
                    & (sim.centre[0] <= np.array(sim.scene.performance_space[3:])), axis=1)
    perf = sim.frames[inside & sim.performing]  # (the vault itself: the last strides, the flights, the landing)

    def near(res):  # performing frames whose target lies within 0.5 m of the gymnast's centre
        rows = np.isin(res.target.frame, perf)
        err = np.linalg.norm(res.target.xyz[rows] - sim.centre[0][res.target.frame[rows] - sim.frames[0]], axis=1)
        return int(np.count_nonzero(err < 0.5))

    assert near(on) >= 0.9 * len(perf) and near(off) <= 0.6 * len(perf)
