"""The routine simulator (gymtrack.simulate) against physics, geometry and the paper's setting.

Checks are on what must be true of a real recording, not on the simulator's own numbers:
cameras as specified, the target inside the performance space and no faster than physics
allows, flights that obey gravity, the plane deviation asked per apparatus, boxes that are
projections of the body, the n_cam semantics, and the failure the paper is about (two opposite
views triangulate badly along the line joining them). Short routines keep the file fast.
"""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.analysis.joints import USED
from gymtrack.analysis.kinematics import centre_of_mass
from gymtrack.apparatus import APPARATUS_NAMES, get_apparatus
from gymtrack.errors import InputError
from gymtrack.scene import in_box
from gymtrack.geometry.triangulation import triangulate
from gymtrack.geometry.views import line_of_sight_angle
from gymtrack.simulate import body as B
from gymtrack.simulate import simulate_n_cams, simulate_routine
from gymtrack.simulate.motion import OFF_PLANE, PHASE_NAMES, SKILL
from gymtrack.simulate.venue import apparatus_centre

G = 9.81
SECONDS = 20.0


@pytest.fixture(scope="module")
def sims():
    """One 20 s routine per apparatus, all four views allowed to see the target."""
    return {a: simulate_routine(a, n_cam=4, seed=11, seconds=SECONDS) for a in APPARATUS_NAMES}


@pytest.fixture(scope="module")
def ncam_sims():
    """The same parallel-bars performance seen with n_cam = 2, 3, 4."""
    return simulate_n_cams("parallel_bars", seed=5, seconds=SECONDS)


# ----------------------------------------------------------------------------- cameras
@pytest.mark.parametrize("apparatus", APPARATUS_NAMES)
def test_cameras_as_specified(sims, apparatus):
    sim = sims[apparatus]
    rig = sim.rig
    assert rig.names == ("cam0", "cam1", "cam2", "cam3")
    centre = apparatus_centre(get_apparatus(apparatus))
    for cam in rig:
        assert cam.size == (1920, 1080)
        C = cam.centre
        assert 8.0 <= np.linalg.norm(C - centre) <= 15.0, cam
        assert 2.0 <= C[2] <= 5.0, cam
        hfov = np.degrees(2 * np.arctan(cam.size[0] / 2 / cam.K[0, 0]))
        assert 50.0 <= hfov <= 70.0, (cam, hfov)
        assert abs(cam.dist[0]) <= 0.05 and cam.has_distortion
        uv = cam.project(centre)
        assert cam.depth(centre) > 0 and cam.in_image(uv), (cam, uv)
    # cam0 / cam1: the square-on opposite pair, one on each side of the gymnast's plane
    n = np.asarray(get_apparatus(apparatus).plane_normal)
    s0, s1 = (rig[0].centre - centre) @ n, (rig[1].centre - centre) @ n
    assert s0 * s1 < 0 and min(abs(s0), abs(s1)) > 7.0
    assert line_of_sight_angle(rig[0].centre, rig[1].centre, centre) > 165.0
    # cam2 / cam3 are the other, diagonal pair: on opposite sides too, and off the normal
    s2, s3 = (rig[2].centre - centre) @ n, (rig[3].centre - centre) @ n
    assert s2 * s3 < 0
    assert line_of_sight_angle(rig[0].centre, rig[2].centre, centre) < 150.0


# ----------------------------------------------------------------------------- the target's motion
def _com(sim) -> np.ndarray:
    """(T, 3) the target's centre of mass: the analysis' de Leva reading of its true joints."""
    k = int(np.flatnonzero(sim.person_id == sim.target_id)[0])
    X = sim.keypoints[k][:, [B.COCO_JOINTS.index(n) for n in USED]]
    return centre_of_mass(X)[0]


@pytest.mark.parametrize("apparatus", APPARATUS_NAMES)
def test_target_stays_in_performance_space_and_obeys_physics(sims, apparatus):
    sim = sims[apparatus]
    c = sim.target_centre
    perf = sim.performing
    if apparatus == "vault":  # judged from the springboard: hurdle, flights and landing, 1.5-4 s
        assert 1.5 * sim.fps <= perf.sum() <= 4.0 * sim.fps
        run_up = np.flatnonzero(sim.phase == PHASE_NAMES.index("run_up"))
        assert len(run_up) and run_up.max() < np.flatnonzero(perf).min()  # the run-up comes first
        assert in_box(c[run_up], np.asarray(sim.scene.performance_space)).all()  # on the runway
    else:
        assert perf.mean() > 0.3  # most of a 20 s routine is the performance
    assert in_box(c[perf], np.asarray(sim.scene.performance_space)).all()
    assert 1.45 <= sim.height[0] <= 1.75
    # Speed: the centre of mass' kinetic energy cannot exceed what the gymnast generates (sprint
    # for the vault, a push or a few running steps otherwise) plus the potential energy lost from
    # its highest point. (The box centre moves about the centre of mass as the body turns and folds.)
    m = _com(sim)
    v = np.linalg.norm(np.diff(m, axis=0), axis=1) * sim.fps
    v_self = 9.0 if apparatus == "vault" else 4.0
    z_low = np.minimum(m[1:, 2], m[:-1, 2])
    bound = np.sqrt(v_self**2 + 2 * G * (m[:, 2].max() - z_low))
    assert np.all(v <= bound + 0.3), (v.max(), np.flatnonzero(v > bound + 0.3)[:5])
    # (the run-up's gait stands the body on its lowest foot point, which drops the centre of mass
    # up to 0.2 m for a frame as the feet change: a gait artefact, left out of the top speed)
    run = sim.phase[1:] == PHASE_NAMES.index("run_up")
    assert v[~run].max() < (10.0 if apparatus in ("vault", "uneven_bars") else 8.5)
    if apparatus == "vault":  # the run-up reaches sprinting speed
        assert np.median(v[np.flatnonzero(run)[-15:]]) > 7.0
    # the body's extent contains its centre; feet on the floor while standing or walking
    assert np.all(sim.top_z[0] > c[:, 2]) and np.all(sim.bottom_z[0] < c[:, 2])
    upright = np.isin(sim.posture[0], [B.STAND, B.WALK]) & ~perf
    if upright.any():
        assert np.allclose(sim.bottom_z[0, upright], 0.0, atol=1e-9)
        assert np.all(np.abs(sim.top_z[0, upright] - sim.height[0]) < 0.1 * sim.height[0])


@pytest.mark.parametrize("apparatus", APPARATUS_NAMES)
def test_flights_follow_gravity(sims, apparatus):
    sim = sims[apparatus]
    c, fl = _com(sim), sim.flight
    assert fl.any(), "every routine has a mount or dismount flight"
    trip = fl[:-2] & fl[1:-1] & fl[2:]
    acc = (c[2:] - 2 * c[1:-1] + c[:-2]) * sim.fps**2
    assert trip.sum() >= 5
    np.testing.assert_allclose(acc[trip], np.tile([0.0, 0.0, -G], (int(trip.sum()), 1)), atol=1e-6)


def _deviation(sim) -> np.ndarray:
    app = get_apparatus(sim.apparatus)
    return np.abs((sim.target_centre - np.asarray(app.plane_point)) @ np.asarray(app.plane_normal))


@pytest.mark.parametrize("apparatus", APPARATUS_NAMES)
def test_plane_deviation_per_apparatus(sims, apparatus):
    sim = sims[apparatus]
    dev = _deviation(sim)
    sk = sim.phase == SKILL
    p95, p50 = np.quantile(dev[sk], 0.95), np.median(dev[sk])
    if apparatus in ("balance_beam", "still_rings", "vault"):
        assert p50 < 0.05 and p95 < 0.08, (p50, p95)  # a few centimetres
    elif apparatus == "pommel_horse":
        # circles and flairs: the centre keeps swinging 0.2-0.4 m off the plane
        assert 0.1 < p95 <= 0.45 and dev[sk].std() > 0.05, (p95, dev[sk].std())
    elif apparatus in ("horizontal_bar", "uneven_bars"):
        assert dev[sk].max() <= 0.5 and p95 > 0.05, (dev[sk].max(), p95)  # drift along the bar, up to 0.5 m
    else:  # parallel bars: between the rails, off the plane only in a marked moment on one rail
        assert p95 < 0.15
        off = sim.phase == OFF_PLANE
        if off.any():
            assert 0.25 < dev[off].max() <= 0.5


def test_giant_and_ring_geometry(sims):
    """Giants circle ~1.0-1.1 m around the bar; on the rings the hang is at ~1.8-1.9 m."""
    for a, grip_z in (("horizontal_bar", 2.8), ("uneven_bars", 2.5)):
        sim = sims[a]
        c = sim.target_centre
        m = (sim.phase == SKILL) & (sim.posture[0] == B.ARMS_UP) & ~sim.flight
        bar_y = 0.0 if a == "horizontal_bar" else 0.75
        r = np.hypot(c[m, 1] - bar_y, c[m, 2] - grip_z)
        on_high = r < 1.3  # uneven bars: frames on the high bar
        assert on_high.sum() > 30
        assert 0.85 < np.median(r[on_high]) < 1.15, np.median(r[on_high])
    rings = sims["still_rings"]
    z = rings.target_centre[(rings.phase == SKILL) & ~rings.flight, 2]
    assert 1.65 < z.min() < 1.95


# ----------------------------------------------------------------------------- bodies and boxes
def test_boxes_are_projections_of_the_body(sims):
    sim = sims["pommel_horse"]
    tb = sim.true_boxes
    H = np.array([1080.0])
    for c, cam in enumerate(sim.rig):
        # exact: every COCO joint projects inside the true box
        p, t = np.nonzero(np.isfinite(tb.depth[c]))
        uv = cam.project(sim.keypoints[p, t])  # (N, 17, 2)
        box = tb.box[c, p, t]
        assert np.all(uv[..., 0] >= box[:, None, 0] - 1e-6) and np.all(uv[..., 0] <= box[:, None, 2] + 1e-6)
        assert np.all(uv[..., 1] >= box[:, None, 1] - 1e-6) and np.all(uv[..., 1] <= box[:, None, 3] + 1e-6)
        # upright people: the box top is the projection of the body's top above the centre, the
        # bottom that of the bottom. Exactly so only in a level view: cameras look down, so the
        # nearer foot reaches lower in the image; hence the looser bound at the bottom.
        up = np.isin(sim.posture, [B.STAND, B.WALK, B.SALUTE]) & (tb.inside[c] >= 0.999)
        p, t = np.nonzero(up)
        X = sim.centre[p, t]
        top = cam.project(np.column_stack([X[:, :2], sim.top_z[p, t]]))[:, 1]
        bot = cam.project(np.column_stack([X[:, :2], sim.bottom_z[p, t]]))[:, 1]
        box = tb.box[c, p, t]
        h = box[:, 3] - box[:, 1]
        assert np.quantile(np.abs(top - box[:, 1]) / h, 0.99) < 0.04, cam.name
        assert np.median(np.abs(top - box[:, 1])) < 1.0
        assert np.quantile(np.abs(bot - box[:, 3]) / h, 0.99) < 0.07, cam.name
        assert np.all(box[:, 3] - box[:, 1] < H)


def test_opposite_views_see_different_points(sims):
    """Box centres of two opposite views are different 3D points: even noiseless true boxes of a
    body with depth (circles on the pommel horse) triangulate off the body centre along the line
    between the cameras, more than with all four views."""
    sim = sims["pommel_horse"]
    m = sim.performing & (sim.posture[0] != B.STAND)
    uv = np.stack([cam.undistort(sim.gt_box[c, 0, m, :2]) for c, cam in enumerate(sim.rig)], axis=1)
    P = sim.rig.projections
    X4, _ = triangulate(P, uv)
    X2, _ = triangulate(P[:2], uv[:, :2])
    gt = sim.target_centre[m]
    u = np.diff(sim.rig.centres[:2], axis=0)[0]
    u /= np.linalg.norm(u)
    e4, e2 = np.abs((X4 - gt) @ u), np.abs((X2 - gt) @ u)
    assert np.mean(e2) > 1.5 * np.mean(e4) and np.mean(e2) > 0.05, (np.mean(e2), np.mean(e4))


# ----------------------------------------------------------------------------- people
@pytest.mark.parametrize("apparatus", APPARATUS_NAMES)
def test_people_around_the_apparatus(sims, apparatus):
    sim = sims[apparatus]
    roles = list(sim.role)
    assert roles.count("target") == 1 and sim.person_id[0] == sim.target_id == 1
    assert 1 <= roles.count("coach") <= 2 and 2 <= roles.count("judge") <= 4
    assert roles.count("gymnast") + roles.count("spectator") >= 2
    assert len(set(sim.person_id.tolist())) == len(sim.person_id)
    vis = sim.gt_visible.sum(axis=1)  # (C, T) people visible per view and frame
    assert 5 <= np.median(vis) <= 20 and vis.min() >= 3 and vis.max() <= 25, (np.median(vis), vis.min(), vis.max())
    # judges sit: their bodies are much lower than standing people's
    judge = sim.role == "judge"
    ext = sim.top_z - sim.bottom_z
    assert np.nanmax(ext[judge]) < 1.45
    # judges stay outside the performance space
    space = np.asarray(sim.scene.performance_space)
    jc = sim.centre[judge].reshape(-1, 3)
    assert not in_box(jc, space).any()


def test_coaches_step_into_the_performance_space(sims):
    """Coaches lift the gymnast onto the rings / the high bar from inside the performance space."""
    for a in ("still_rings", "horizontal_bar"):
        sim = sims[a]
        space = np.asarray(sim.scene.performance_space)
        coach = np.flatnonzero(sim.role == "coach")
        inside = in_box(sim.centre[coach], space).any(axis=0)  # (T,)
        assert inside.any(), a
        # the lift: a coach within a metre of the target while it rises to the hang
        d = np.linalg.norm(sim.centre[coach][:, :, :2] - sim.target_centre[None, :, :2], axis=-1).min(axis=0)
        lift = [e for e in sim.events if e.kind == "lift"]
        assert lift and d[lift[0].start:lift[0].stop].min() < 1.0


# ----------------------------------------------------------------------------- detector and n_cam
def _target_views(sim) -> np.ndarray:
    """(T, C) the target detected per view, from the detections and the true boxes alone: the
    oracle matching of :mod:`gymtrack.eval.gt` (per frame and view, Hungarian on IoU >= 0.5
    between detections and the true boxes of everyone)."""
    from gymtrack.eval.gt import match_detections_to_gt

    d = sim.detections
    m = match_detections_to_gt(d, sim.ground_truth())
    # the simulator knows which person each detection came from: the matching must agree, on the
    # target's boxes above all (two bystanders one behind the other in a view may swap)
    agree = m.person_id == sim.det_person
    tgt = (m.person_id == sim.target_id) | (sim.det_person == sim.target_id)
    assert np.mean(agree[tgt]) > 0.99 and np.mean(agree) > 0.97
    out = np.zeros((sim.n_frames, len(sim.rig)), bool)
    t = m.person_id == sim.target_id
    out[d.frame[t] - 1, d.camera[t].astype(int)] = True
    return out


def test_n_cam_sets_the_views_that_see_the_target(ncam_sims):
    s2, s3, s4 = ncam_sims[2], ncam_sims[3], ncam_sims[4]
    # one performance seen three ways: the same motion, cameras and people
    assert np.array_equal(s2.centre, s4.centre, equal_nan=True) and np.array_equal(s3.rig.projections, s4.rig.projections)
    perf = s4.performing
    frac = {}
    for n, sim in ncam_sims.items():
        v = _target_views(sim)
        assert np.mean(v == sim.target_detected()) > 0.99
        k = v[perf].sum(axis=1)
        frac[n] = np.bincount(k, minlength=5) / k.size
        # the views that (almost) never see the target are exactly those n_cam excludes
        assert np.array_equal(v.mean(axis=0) > 0.01, sim.target_views)
    print("\nfraction of performing frames with the target in 0..4 views:", {n: np.round(f, 3).tolist() for n, f in frac.items()})
    assert frac[4][4] > 0.5 and frac[4][3:].sum() > 0.85 and frac[4][:4].sum() > 0.02  # even n_cam=4 has gaps
    assert frac[3][4] < 0.01 and frac[3][3] > 0.5
    assert frac[2][3:].sum() < 0.01 and frac[2][2] > 0.6
    assert s3.target_views.sum() == 3 and s2.target_views.tolist() == [True, True, False, False]
    # with n_cam = 2 the two views that see the target are an opposite pair
    X = s2.target_centre[perf].mean(axis=0)
    assert line_of_sight_angle(s2.rig[0].centre, s2.rig[1].centre, X) > 160.0
    # other people are still detected in the views blind to the target
    for c in (2, 3):
        assert np.count_nonzero((s2.detections.camera == c) & (s2.det_person > 1)) > 1000


def test_detector_output_is_plausible(sims):
    sim = sims["uneven_bars"]
    d = sim.detections
    W, H = 1920, 1080
    assert d.score.min() >= 0.0 and d.score.max() <= 1.0
    assert np.all(d.track_id == -1) and d.frame.min() >= 1 and d.frame.max() <= sim.n_frames
    tl = d.tlwh
    assert np.all(tl[:, 0] >= -1e-6) and np.all(tl[:, 1] >= -1e-6)
    assert np.all(tl[:, 0] + tl[:, 2] <= W + 1e-6) and np.all(tl[:, 1] + tl[:, 3] <= H + 1e-6)
    fp = sim.det_person < 0
    assert 0.005 < fp.mean() < 0.1  # some false positives
    # occlusion costs detections: people mostly hidden behind nearer ones are rarely found
    tb = sim.true_boxes
    found = np.zeros(tb.depth.shape, bool)
    rows = {int(p): i for i, p in enumerate(sim.person_id)}
    pi = np.array([rows.get(int(p), -1) for p in sim.det_person])
    ok = pi >= 0
    found[d.camera[ok].astype(int), pi[ok], d.frame[ok] - 1] = True
    clear = tb.visible & (tb.occlusion < 0.1)
    hidden = tb.visible & (tb.occlusion > 0.7)
    assert found[clear].mean() > 0.85
    if hidden.sum() > 50:
        assert found[hidden].mean() < 0.5 * found[clear].mean()
    # localisation noise: a few per cent of the box size, not more
    tgt = sim.det_person == 1
    gt = sim.gt_box[d.camera[tgt].astype(int), 0, d.frame[tgt] - 1]
    err = (d.box[tgt, :2] - gt[:, :2]) / gt[:, 2:]
    assert 0.005 < np.median(np.abs(err)) < 0.06


@pytest.mark.parametrize("apparatus", ["balance_beam", "uneven_bars"])
def test_two_opposite_views_triangulate_worse_along_their_line(sims, apparatus):
    """The paper's failure case: with only cam0 and cam1 (lines of sight at ~170 degrees) the
    triangulated centre is far off along the line between them; with all four views it is not."""
    sim = sims[apparatus]
    from gymtrack.eval.gt import box_iou

    d = sim.detections
    T, C = sim.n_frames, 4
    gt = sim.gt_box[:, 0]
    iou = np.nan_to_num(box_iou(d.box, gt[d.camera.astype(int), d.frame - 1]))
    # per frame and view: the detection with the highest IoU with the true target box
    best = np.full((T, C), -1.0)
    uv = np.full((T, C, 2), np.nan)
    order = np.argsort(iou, kind="stable")
    f, c = d.frame[order] - 1, d.camera[order].astype(int)
    keep = iou[order] >= 0.5
    best[f[keep], c[keep]] = iou[order][keep]
    uv[f[keep], c[keep]] = d.box[order][keep, :2]  # the last write is the best one
    und = np.stack([cam.undistort(uv[:, k]) for k, cam in enumerate(sim.rig)], axis=1)
    all4 = np.all(best >= 0.5, axis=1) & sim.performing
    assert all4.sum() > 100
    P = sim.rig.projections
    X4, _ = triangulate(P, und[all4])
    X2, _ = triangulate(P[:2], und[all4][:, :2])
    truth = sim.target_centre[all4]
    u = sim.rig[1].centre - sim.rig[0].centre
    u /= np.linalg.norm(u)
    e4 = np.abs((X4 - truth) @ u)
    e2 = np.abs((X2 - truth) @ u)
    msg = (f"{apparatus}: error along the cam0-cam1 line over {all4.sum()} frames: "
           f"4 views median {np.median(e4):.3f} m, mean {e4.mean():.3f} m; "
           f"cam0+cam1 only median {np.median(e2):.3f} m, mean {e2.mean():.3f} m")
    print("\n" + msg)
    assert np.median(e4) < 0.12, msg
    assert np.median(e2) > 2.0 * np.median(e4) and e2.mean() > 2.5 * e4.mean(), msg


# ----------------------------------------------------------------------------- inputs
def test_bad_arguments_are_named():
    with pytest.raises(InputError, match="unknown apparatus 'trampoline'"):
        simulate_routine("trampoline")
    with pytest.raises(InputError, match="n_cam must be 2, 3 or 4"):
        simulate_routine("vault", n_cam=1)
    with pytest.raises(InputError, match=r"a vault routine needs at least 5 s \(a run-up of at least 5 m, the vault"):
        simulate_routine("vault", seconds=2)
    with pytest.raises(InputError, match="seed must be"):
        simulate_routine("vault", seed=-3)


# ----------------------------------------------------------------------------- lengths
def test_a_five_second_vault_is_one_whole_vault_and_is_tracked():
    """5 s of vault: standing at the start of the run-up, the run-up, board and table, the
    post-flight and the landing, all inside the routine; the tracker finds the target on it."""
    from gymtrack.simulate.phases import DISMOUNT, LANDING, RUN_UP, SKILL
    from gymtrack.tracking.offline import track_detections

    sim = simulate_routine("vault", n_cam=4, seed=3, seconds=5)
    assert sim.n_frames == 150
    ph = sim.phase
    firsts = [int(np.flatnonzero(ph == p)[0]) for p in (RUN_UP, SKILL, DISMOUNT, LANDING)]
    assert firsts == sorted(firsts) and firsts[0] < 15  # in this order, the run-up from the start
    assert np.flatnonzero(ph == LANDING)[-1] < sim.n_frames - 1  # the landing is over before the end
    assert sim.target_centre[sim.flight, 2].max() > 2.0  # the post-flight peaks above 2 m
    res = track_detections(sim.rig, sim.scene, sim.detections)
    perf = sim.frames[sim.performing]
    assert np.isin(perf, res.target.frame).mean() > 0.8


@pytest.mark.parametrize("apparatus", APPARATUS_NAMES)
def test_shortest_routine_of_each_apparatus_holds_a_performance(apparatus):
    from gymtrack.simulate.lengths import PERFORMANCE_SECONDS, ROUTINE_NEEDS

    need = ROUTINE_NEEDS[apparatus][0]
    sim = simulate_routine(apparatus, n_cam=3, seed=1, seconds=need)  # ROUTINE_NEEDS: 12 seeds' entries + 1 s
    assert sim.n_frames == round(need * sim.fps)
    assert sim.performing.sum() / sim.fps >= (PERFORMANCE_SECONDS if apparatus != "vault" else 1.0)
    with pytest.raises(InputError, match=f"a {apparatus} routine needs at least {need:g} s"):
        simulate_routine(apparatus, seconds=need - 0.5)


def test_longest_routine_is_an_hour_as_far_as_memory_allows(monkeypatch):
    from gymtrack.simulate import lengths

    with pytest.raises(InputError, match="at most 3600 .one hour., got 3601"):
        simulate_routine("vault", seconds=3601)
    monkeypatch.setattr(lengths, "_available_memory", lambda: 2e9)
    with pytest.raises(InputError, match=r"simulating 3600 s needs about \d+\.\d GB of memory .*; 2\.0 GB are available"):
        simulate_routine("balance_beam", seconds=3600)
