"""The reach rule (gymtrack.tracking.reach): a raised point away from the apparatus counts for
Eq. 13 only for a flight's length, and only while its height spans what a ballistic flight
must; hand-worked runs on the presets, the simulated gymnasts' own flights, the target stage
giving a phantom up, and cascade+ with and without it on a simulated vault (the recipe's test of
the ingredient switched off alone, kept beside the rule's own tests)."""

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
from gymtrack.tracking.ballistic import G
from gymtrack.tracking.reach import LEVEL_MARGIN, MAX_FLIGHT_SECONDS, REACH, ReachLimit
from gymtrack.tracking.target import TargetStage
from gymtrack.tracking.types import Tracks3D

FPS = 30.0
N = int(round(MAX_FLIGHT_SECONDS * FPS))  # 45 frames
#: a level point counts for 11 frames: 10 frames (1/3 s) after its first, a flight spans at least
#: g / 8 / 9 = 0.136 m, within the 0.15 m margin; 11 frames after, 0.165 m: beyond it
LEVEL = 11


def _ballistic(f, apex_frame, z_apex=3.0):
    """Heights of a centre in free fall with its apex at ``apex_frame`` (frames at FPS)."""
    return z_apex - G / 2 * ((np.asarray(f) - apex_frame) / FPS) ** 2


def test_compiled_distance_is_the_placements_on_turned_and_moved_apparatus():
    """The reach rule's compiled distance against :func:`gymtrack.placement.apparatus_distance`
    (the numpy original) on every preset, turned by a random yaw and moved, and with no
    apparatus; points near and far, inside blocks, and one with a NaN."""
    from dataclasses import replace

    from gymtrack.tracking._kernels.target import apparatus_distance as compiled

    rng = np.random.default_rng(11)
    for app in ("uneven_bars", "horizontal_bar", "parallel_bars", "still_rings", "pommel_horse", "balance_beam", "vault", None):
        geo = scene_geometry(preset_scene(app)) if app else scene_geometry(preset_scene("vault"))
        if app is None:
            geo = replace(geo, bar_a=np.zeros((0, 3)), bar_b=np.zeros((0, 3)), bar_r=np.zeros(0), box_lo=np.zeros((0, 3)),
                          box_hi=np.zeros((0, 3)))
        geo = replace(geo, yaw=float(rng.uniform(-np.pi, np.pi)), shift=rng.normal(0, 0.5, 3))
        X = rng.uniform(-2.5, 2.5, (500, 3)) + [0, 0, 1.5]
        X[7, 2] = np.nan
        want = apparatus_distance(X, geo)
        got = compiled(X, *ReachLimit(geo, 0.3, FPS)._surfaces)
        assert np.array_equal(np.isnan(got), np.isnan(want)) and np.array_equal(np.isinf(got), np.isinf(want))
        ok = np.isfinite(want)
        assert np.allclose(got[ok], want[ok], atol=1e-12)
        if app is not None:
            assert (want[ok] < REACH).sum() > 20  # near points are tested too


def test_the_level_count_is_the_bound_less_the_margin():
    assert G * ((LEVEL - 1) / FPS) ** 2 / 8 <= LEVEL_MARGIN < G * (LEVEL / FPS) ** 2 / 8


def _limit(app="uneven_bars"):
    scene = preset_scene(app)
    return ReachLimit(scene_geometry(scene), scene.target.h_bot, FPS), scene


def test_a_raised_point_far_from_the_bars_counts_for_a_flights_length_across_calls():
    """Track 1 falls freely 1.0 m up and more at the edge of the space (y = -2.79, about 2 m from
    the low bar): its first 45 frames count, none after, the run carried over the calls. Track 3
    stands still there (the phantom of a two-camera routine): level, its first 11 frames count.
    Track 2 hangs below the high bar the whole time: every frame counts."""
    lim, scene = _limit()
    geo = scene_geometry(scene)
    phantom, hang = np.array([0.0, -2.79, 1.6]), np.array([0.0, geo.bar_a[1, 1], geo.bar_a[1, 2] - 1.1])
    assert apparatus_distance(phantom[None], geo)[0] > REACH > apparatus_distance(hang[None], geo)[0]
    got = []
    for a in range(0, 120, 5):  # calls of 5 frames
        f = np.arange(a, a + 5)
        frame = np.repeat(f, 3)
        tid = np.tile([1, 2, 3], len(f))
        xyz = np.where((tid == 2)[:, None], hang, phantom)
        xyz[tid == 1, 2] = _ballistic(f, 22)
        got.append((frame, tid, lim.grounded(frame, tid, xyz, np.full(len(frame), 1.0))))
    frame, tid, ok = (np.concatenate(x) for x in zip(*got))
    assert ok[tid == 2].all()
    assert np.array_equal(ok[tid == 1], np.arange(120) < N)
    assert np.array_equal(ok[tid == 3], np.arange(120) < LEVEL)


def test_a_level_run_is_judged_on_its_span_from_its_first_frame():
    """A point rising 1 cm a frame: the bound less the margin (g tau^2 / 8 - 0.15 m) needs 0.117 m
    at frame 14, where it has spanned 0.14 m (counted), and 0.157 m at frame 15, where it has
    spanned 0.15 m (not counted). Once level, a run does not count again though it later spans
    more (a jump of 2 m at frame 30)."""
    lim, _ = _limit()
    f = np.arange(40)
    z = 1.6 + 0.01 * f
    z[30:] += 2.0
    ok = lim.grounded(f, np.zeros(40, np.int64), np.c_[np.zeros(40), np.full(40, -2.79), z], np.ones(40))
    need = G * (f / FPS) ** 2 / 8 - LEVEL_MARGIN
    first_level = int(np.flatnonzero((z[:30] - z[0]) < need[:30] - 1e-12)[0])
    assert first_level == 15
    assert np.array_equal(ok, f < first_level)


def test_a_grounded_point_ends_the_run_and_a_flight_counts_again():
    """Raised away for 40 frames (counted), one frame low (the run ends), raised away again for 50:
    its first 45 count. The bottom at h_bot or below, or NaN, is not raised. The centre falls
    freely in each run (ballistic: never too level)."""
    lim, scene = _limit("vault")
    f = np.arange(91)
    bottom = np.full(91, 1.0)
    bottom[40] = scene.target.h_bot  # (not above it)
    xyz = np.tile([3.5, 0.0, 1.5], (91, 1))  # 2.9 m beyond the table's far end
    xyz[:, 2] = np.where(f < 40, _ballistic(f, 20), _ballistic(f, 66))
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
    for t in (4, 9):  # standing still: level
        assert np.array_equal(back[tid == t], np.arange(60) < LEVEL)
    assert len(lim) == 2
    later = lim.grounded(np.array([60 + N + 1]), np.array([4]), xyz[:1], np.ones(1))
    assert later[0] and len(lim) == 1
    scene = preset_scene("uneven_bars").model_copy(update={"apparatus": None})
    free = ReachLimit(scene_geometry(scene), 0.6, FPS)
    assert free.grounded(frame, tid, xyz, np.ones(180)).all()


def _vault_tracks(F=300, level=True):
    """A phantom (track 1) 1.0 m up 2.9 m beyond the vault table from frame 0 -- standing still
    (``level``) or with one point 2.8 m higher at frame 1 (as a wrong pair's rays can give; its
    run then spans more than a flight's length needs) -- and the gymnast (track 2): a run-up on the floor, on and over
    the table (raised, within reach) from frame 250, and the landing beyond it."""
    f = np.arange(F)
    x = np.interp(f, [0, 250, 262, 275, 290], [-20.0, -1.0, 0.0, 2.0, 3.5])
    bottom2 = np.interp(f, [0, 245, 252, 262, 275, 285, 290], [0.0, 0.0, 0.5, 1.4, 1.2, 0.5, 0.0])
    xyz2 = np.c_[x, np.zeros(F), bottom2 + 0.8]
    frame = np.repeat(f, 2)
    tid = np.tile([1, 2], F)
    xyz = np.empty((2 * F, 3))
    xyz[0::2], xyz[1::2] = [3.5, 0.0, 1.6], xyz2
    if not level:
        xyz[2, 2] += 2.8
    bottom = np.empty(2 * F)
    bottom[0::2], bottom[1::2] = 1.0, bottom2
    top = bottom + 1.6
    n = 2 * F
    return Tracks3D(frame, tid, xyz, top, bottom, np.zeros(n, np.int8), np.full(n, 2, np.int8))


def _stage_targets(reach, level):
    scene = preset_scene("vault", fps=FPS)
    rig = ring_rig([0, 180])
    stage = TargetStage(rig, scene, reach=reach)
    tracks = _vault_tracks(level=level)
    parts = []
    for a in range(0, 300, 10):
        m = (tracks.frame >= a) & (tracks.frame < a + 10)
        parts.append(stage.update(a, a + 9, tracks.select(m), Detections.empty(rig.names), {})[0])
    parts.append(stage.finish()[0])
    got = np.full(300, -1)
    for t in parts:
        got[t.frame] = t.track_id
    return got, stage.counts


@pytest.mark.parametrize("reach", [False, True])
def test_the_target_stage_gives_a_phantom_up_and_takes_the_gymnast_in_her_flight(reach):
    """Eq. 13 identifies the phantom (not level) in its first frames (the gymnast runs on the floor:
    her bottom is below h_bot). Without the rule it is held for the whole routine; with it, it
    leaves once a flight's length has passed, nobody is the target on the run-up, and the gymnast
    is identified on the table (with the frames the identification looked back on: the
    back-fill) and kept through the landing."""
    got, counts = _stage_targets(reach, level=False)
    assert (got[:30][got[:30] >= 0] == 1).all() and (got[30:45] == 1).all()  # identified from its first frames
    if not reach:
        assert (got[30:] == 1).all()
        return
    assert counts["target_points_out_of_reach"] == 300 - N
    assert (got[N + 30:200] == -1).all()  # left within Delta frames of its flight's length
    assert (got[260:] == 2).all()  # (with the frames her identification looked back on, from 206)


def test_a_level_phantom_is_never_the_target():
    """Standing still, the phantom counts for its first 11 frames only: fewer than the Delta / 2
    Eq. 13 needs, so it is never identified; the gymnast is, as above. Without the rule it is
    the target from its first frames."""
    got, counts = _stage_targets(True, level=True)
    assert counts["target_points_out_of_reach"] == 300 - LEVEL
    assert not (got == 1).any() and (got[260:] == 2).all()
    off, _ = _stage_targets(False, level=True)
    assert (off[30:] == 1).all()


def test_the_simulated_gymnasts_flights_count_whole():
    """The true centre and bottom of simulated gymnasts (a high bar, uneven bars and rings
    routine): every raised point away from the bars, all in flights (releases, dismounts) of at
    most a flight's length, counts -- none is judged too level."""
    runs = 0
    for app, seed in (("horizontal_bar", 11), ("uneven_bars", 12), ("still_rings", 13)):
        sim = simulate_routine(app, n_cam=2, seed=seed, seconds=20)
        live = sim.alive[0]
        f, xyz, bottom = sim.frames[live], sim.centre[0][live], sim.bottom_z[0][live]
        lim = ReachLimit(scene_geometry(sim.scene), sim.scene.target.h_bot, sim.fps)
        away = (bottom > sim.scene.target.h_bot) & (apparatus_distance(xyz, lim.geometry) > REACH)
        runs += int(np.count_nonzero(away[1:] & ~away[:-1]))
        assert lim.grounded(f, np.zeros(len(f), np.int64), xyz, bottom).all(), app
    assert runs >= 3


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
    # (``reidentify`` off in both runs: without reach its take-over now hands the gymnast the
    # target and takes back the 46 frames before it, so cascade+ without reach is near her too)
    plus = RECIPES["cascade+"].without("reidentify")
    on, off = (track_detections(rig, scene, det, mode=m) for m in (plus, plus.without("reach")))
    # only the target changes -- and through it the tracks of the ingredients that follow the
    # target (``lone``, ``regain``): without them the tracks are the same
    alone = plus.without("lone").without("regain")
    a, b = (track_detections(rig, scene, det, mode=m) for m in (alone, alone.without("reach")))
    assert np.array_equal(a.tracks.track_id, b.tracks.track_id) and np.array_equal(a.tracks.xyz, b.tracks.xyz)
    assert on.summary["target_points_out_of_reach"] > 0 and "target_points_out_of_reach" not in off.summary
    inside = np.all((sim.centre[0] >= np.array(sim.scene.performance_space[:3]))
                    & (sim.centre[0] <= np.array(sim.scene.performance_space[3:])), axis=1)
    perf = sim.frames[inside & sim.performing]  # (the vault itself: the last strides, the flights, the landing)

    def near(res):  # performing frames whose target lies within 0.5 m of the gymnast's centre
        rows = np.isin(res.target.frame, perf)
        err = np.linalg.norm(res.target.xyz[rows] - sim.centre[0][res.target.frame[rows] - sim.frames[0]], axis=1)
        return int(np.count_nonzero(err < 0.5))

    assert near(on) >= 0.9 * len(perf) and near(on) - near(off) >= 0.2 * len(perf)  # (90 and 2 of 90)
