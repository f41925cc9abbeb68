"""The analysis stage on measured-like skeletons: left/right swaps, wrong lines, noise, lost poses.

Each test corrupts the simulator's true motion the way a measured skeleton is wrong (Ronchi and
Perona's left/right inversions, a joint mislocated, a pose of someone else) and checks the
measure against the simulator's own choreography.
"""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.analysis import analyse
from gymtrack.analysis.rotation import unwrap_axial
from gymtrack.formats.scene import preset_scene
from gymtrack.poses import HOW_TRIANGULATED, Poses3D
from gymtrack.simulate import body as B
from gymtrack.simulate.motion import MotionBuilder
from gymtrack.skeletons import COCO17

FLIP = np.asarray(COCO17.flip)
LEGS = [COCO17.joints.index(n) for n in ("left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle")]


def poses_of(kp: np.ndarray, reproj: float = 0.0) -> Poses3D:
    n, J = kp.shape[:2]
    return Poses3D(np.arange(1, n + 1), np.ones(n), kp, np.ones((n, J)), np.full((n, J), 4), np.full((n, J), reproj),
                   np.full((n, J), HOW_TRIANGULATED, np.int8), COCO17)


@pytest.fixture(scope="module")
def twisting_double():
    """Stand, a piked double back salto with a full twist, stand (60 fps, beside the bar)."""
    body = B.BodyModel(1.65)
    b = MotionBuilder(body, 60.0, np.random.default_rng(0))
    b.place((2.0, 0.0), 0.0, np.pi / 2)
    b.stand(0.5, 0.0)
    b.push(0.0, 0.15, B.posture_angles(B.STAND))
    start = b.n
    end_c = b.body.centre_on_feet(np.array([[2.0, 1.2]]), 0.0, B.posture_angles(B.STAND)[None], [b.yaw], [-4 * np.pi],
                                  [2 * np.pi])[0]
    pike = B.posture_angles(B.PIKE)
    b.flight(end_c, b.flight_frames(b.centre[2], end_c[2], 2.6), -4 * np.pi, twist_end=2 * np.pi,
             angle_keys=[(0.25, pike), (0.75, pike), (1.0, B.posture_angles(B.STAND))])
    stop = b.n
    b.stand(1.0, 0.0)
    m = b.build()
    pts, _ = body.world_points(m.centre, m.angles, m.yaw, m.pitch, m.twist)
    return pts[:, :17], start, stop


SCENE = preset_scene("horizontal_bar").model_copy(update={"fps": 60.0})


def _flight(kp):
    fl = analyse(poses_of(kp), SCENE, samples=0, cutoff_hz=None).flights
    assert len(fl) == 1
    return fl[0]


def test_unwrap_axial_ignores_half_turn_flips_and_bridges_untrusted_frames():
    t = np.arange(60) / 30.0
    true = 2 * np.pi * 3.0 * t  # 3 rev/s: 36 deg a frame
    rng = np.random.default_rng(1)
    flip = rng.random(60) < 0.3
    meas = np.angle(np.exp(1j * (true + np.pi * flip)))  # a left/right swap turns the line by 180 deg
    trusted = np.ones(60, bool)
    trusted[[10, 30, 45]] = False  # one frame each: 72 deg turned across it, under the 90 deg bound
    meas[[10, 30, 45]] = rng.uniform(-np.pi, np.pi, 3)  # junk where untrusted
    u = unwrap_axial(meas, trusted)
    np.testing.assert_allclose(u, true - true[0], atol=1e-9)
    # a plain unwrap of the same angles loses or gains half turns at the flips
    assert np.max(np.abs(np.unwrap(meas) - meas[0] - (true - true[0]))) > 1.0


def test_left_right_swaps_do_not_change_the_twist_count(twisting_double):
    kp, start, stop = twisting_double
    assert (_flight(kp)["saltos"], _flight(kp)["twists"]) == (2.0, 1.0)
    rng = np.random.default_rng(2)
    bad = kp.copy()
    air = np.arange(start, stop)
    whole = rng.choice(air, size=len(air) // 5, replace=False)
    bad[whole] = kp[whole][:, FLIP]  # whole-body inversions
    legs = rng.choice(np.setdiff1d(air, whole), size=len(air) // 6, replace=False)
    bad[np.ix_(legs, LEGS)] = kp[legs][:, FLIP[LEGS]]  # legs-only inversions: the pelvis line turns 180 deg
    f = _flight(bad)
    assert (f["saltos"], f["twists"]) == (2.0, 1.0)


def test_frames_whose_lines_disagree_are_not_read(twisting_double):
    kp, start, stop = twisting_double
    bad = kp.copy()
    lh, rh = COCO17.joints.index("left_hip"), COCO17.joints.index("right_hip")
    mid = 0.5 * (kp[:, lh] + kp[:, rh])
    # a run of frames with the hips mislocated: the pelvis line turned 90 deg about the long axis
    rows = np.arange(start + (stop - start) // 3, start + (stop - start) // 3 + 4)
    for r in rows:
        S = 0.5 * (kp[r, COCO17.joints.index("left_shoulder")] + kp[r, COCO17.joints.index("right_shoulder")])
        L = (S - mid[r]) / np.linalg.norm(S - mid[r])
        v = kp[r, lh] - mid[r]
        w = np.cross(L, v)  # v turned 90 deg about L
        bad[r, lh], bad[r, rh] = mid[r] + w, mid[r] - w
    a = analyse(poses_of(bad), SCENE, samples=0, cutoff_hz=None)
    assert a["twist_lines_disagree"][rows].all()
    f = a.flights[0]
    assert (f["saltos"], f["twists"]) == (2.0, 1.0)


# ------------------------------------------------------------------ flights on measured-like heights
def _heights(n1=10, gap=2, n2=10, fps=30.0, bounce=False, seed=0):
    """A ballistic centre of mass (v0 4 m/s) with a short 'contact' of ``gap`` rows inside; ``bounce``:
    the contact reverses the fall (a springboard)."""
    n = n1 + gap + n2
    t = np.arange(n) / fps
    z = 1.0 + 4.0 * t - 9.81 / 2 * t ** 2
    if bounce:
        tb = t[n1 + gap // 2]
        zb = 1.0 + 4.0 * tb - 9.81 / 2 * tb ** 2
        after = t > tb
        z[after] = zb + 3.0 * (t[after] - tb) - 9.81 / 2 * (t[after] - tb) ** 2
    z += np.random.default_rng(seed).normal(0, 0.01, n)
    sup = np.zeros(n, np.int8)
    sup[n1:n1 + gap] = 2
    return np.arange(n), sup, z, np.full(n, 0.01)


def test_a_contact_that_leaves_the_parabola_unbroken_is_bridged():
    from gymtrack.analysis.contacts import bridge_contacts
    from gymtrack.analysis.flights import find_flights

    frame, sup, z, sd = _heights()
    out, n = bridge_contacts(frame, sup, 30.0, z, sd)
    assert n == 1 and (out == 0).all()
    fl, _ = find_flights(frame, out, 30.0, z, z, sd)
    assert fl == [(0, len(frame) - 1)]
    # a springboard's contact changes the vertical speed: two flights stay two
    frame, sup, z, sd = _heights(gap=3, bounce=True)
    out, n = bridge_contacts(frame, sup, 30.0, z, sd)
    assert n == 0 and (out == sup).all()


def test_a_contact_is_bridged_where_the_joints_box_stays_on_the_parabola():
    """The box centre read as :func:`find_flights` reads it: a centre of mass 5 cm off the parabola
    (limbs moving in a body whose box centre flies ballistically, the simulator's) keeps the
    contact alone; the box centre on it bridges it; a box centre that a push moved keeps it."""
    from gymtrack.analysis.contacts import bridge_contacts

    frame, sup, box, sd = _heights(seed=1)
    com = box + 0.05 * np.sin(np.linspace(0, 3 * np.pi, len(box)))
    assert bridge_contacts(frame, sup, 30.0, com, sd)[1] == 0
    out, n = bridge_contacts(frame, sup, 30.0, com, sd, box)
    assert n == 1 and (out == 0).all()
    _, _, pushed, _ = _heights(bounce=True, seed=1)
    assert bridge_contacts(frame, sup, 30.0, com, sd, pushed)[1] == 0


def test_an_airborne_run_with_a_hand_in_the_bars_reach_throughout_is_no_flight():
    """A noisy wrist taken off the bar for 0.2 s in a giant (every row within 0.10 m + 2 sd of the
    bar) is a hidden grip; a release, whose hands leave that reach, stays a flight."""
    from gymtrack.analysis.flights import find_flights
    from gymtrack.analysis.joints import USED, I
    from gymtrack.analysis.support import hands_may_hold
    from gymtrack.placement import scene_geometry

    geo = scene_geometry(preset_scene("horizontal_bar"))  # the bar along x at z = 2.8
    n = 8
    X = np.full((n, len(USED), 3), np.nan)
    X[:, I["left_wrist"]] = [0.0, 0.0, 2.8 + 0.014 + 0.25]  # 0.25 m over the bar
    sigma = np.full((n, len(USED)), 0.05)
    assert not hands_may_hold(X, sigma, geo).any()  # 0.25 > 0.10 + 2 x 0.05
    sigma[:, I["left_wrist"]] = 0.1
    assert hands_may_hold(X, sigma, geo).all()
    frame, sup, z, sd = _heights(n1=n, gap=0, n2=0)
    hold = hands_may_hold(X, sigma, geo)
    fl, lifted = find_flights(frame, sup, 30.0, z, z, sd, may_hold=hold)
    assert fl == [] and lifted == [(0, n - 1)]
    hold[3] = False  # one row out of reach: the hand left the bar
    assert find_flights(frame, sup, 30.0, z, z, sd, may_hold=hold)[0] == [(0, n - 1)]


def test_an_airborne_run_whose_take_off_and_landing_are_unseen_is_no_flight():
    from gymtrack.analysis.flights import find_flights

    frame, sup, z, sd = _heights(gap=0)
    com = np.column_stack([np.zeros_like(z), np.zeros_like(z), z])
    sup = sup.copy()
    sup[[0, -1]] = 1  # standing before and after: a flight
    fl, _ = find_flights(frame, sup, 30.0, z, z, sd, com)
    assert fl == [(1, len(frame) - 2)]
    far = com.copy()
    far[1:-1, 0] += 9.0  # the airborne rows are someone 9 m away (a lost track)
    fl, lifted = find_flights(frame, sup, 30.0, z, z, sd, far)
    assert fl == [] and lifted == [(1, len(frame) - 2)]


def test_a_badly_measured_row_weighs_little_in_the_ballistic_fit():
    from gymtrack.analysis.flights import fall_rate

    t = np.arange(10) / 30.0
    z = 1.0 + 3.0 * t - 9.81 / 2 * t ** 2
    z[0] -= 0.3  # one row measured 30 cm low (one view, a high reprojection error)
    sd = np.full(10, 0.01)
    sd[0] = 0.3
    a_plain, _ = fall_rate(t, z, 0.01)
    a_w, a_sd = fall_rate(t, z, sd)
    assert abs(a_plain + 9.81) > 0.5 * 9.81  # the bad row bends the plain fit out of the ballistic band
    assert abs(a_w + 9.81) < 3 * a_sd + 0.5


# ------------------------------------------------------------------ shape on noisy joints
def _salto(hip_flexion: float):
    """A single back salto at 30 fps, legs straight, hips flexed by ``hip_flexion`` deg all through."""
    body = B.BodyModel(1.65)
    b = MotionBuilder(body, 30.0, np.random.default_rng(0))
    b.place((2.0, 0.0), 0.0, np.pi / 2)
    b.stand(0.5, 0.0)
    shape = B.posture_angles(B.LAYOUT)
    shape[[0, 1]] = hip_flexion
    b.push(0.0, 0.15, shape)
    end_c = b.body.centre_on_feet(np.array([[2.0, 1.0]]), 0.0, B.posture_angles(B.STAND)[None], [b.yaw], [-2 * np.pi],
                                  [0.0])[0]
    b.flight(end_c, b.flight_frames(b.centre[2], end_c[2], 2.4), -2 * np.pi,
             angle_keys=[(0.2, shape), (0.8, shape), (1.0, B.posture_angles(B.STAND))])
    b.stand(1.0, 0.0)
    m = b.build()
    pts, _ = body.world_points(m.centre, m.angles, m.yaw, m.pitch, m.twist)
    return pts[:, :17]


@pytest.mark.parametrize("flexion, shape", [(0.0, "layout"), (55.0, "open")])
def test_shape_on_noisy_joints_with_a_few_badly_measured_knees(flexion, shape):
    kp = _salto(flexion)
    scene = preset_scene("horizontal_bar")
    truth = analyse(poses_of(kp), scene, samples=0, cutoff_hz=None).flights
    assert [f["shape"] for f in truth] == [shape]
    a, b = truth[0]["start_frame"] - 1, truth[0]["end_frame"] - 1  # rows (frames are 1-based)
    knee = COCO17.joints.index("left_knee")
    for seed in range(4):
        rng = np.random.default_rng(seed)
        noisy = kp + rng.normal(0, 0.02, kp.shape)
        sigma = np.full(kp.shape[:2], 0.02)
        r0 = rng.integers(a + (b - a) // 4, b - (b - a) // 4 - 2)
        rows = np.arange(r0, r0 + 3)
        # three middle frames whose knee the pose stage placed 30 cm off the leg's line (a knee angle
        # near 110 deg), and knew it (sd 30 cm)
        hip, ankle, rhip = (COCO17.joints.index(n) for n in ("left_hip", "left_ankle", "right_hip"))
        perp = np.cross(kp[rows, ankle] - kp[rows, hip], kp[rows, hip] - kp[rows, rhip])
        noisy[rows, knee] += 0.30 * perp / np.linalg.norm(perp, axis=1, keepdims=True)
        sigma[rows, knee] = 0.30
        fl = analyse(poses_of(noisy), scene, samples=0, joint_sigma=sigma).flights
        assert [f["shape"] for f in fl] == [shape], seed


# ------------------------------------------------------------------ filtering per support segment
def test_each_support_segment_takes_its_own_cut_off():
    from scipy.signal import butter, filtfilt

    from gymtrack.analysis.filtering import filter_joints, segment_cutoffs, segments

    rng = np.random.default_rng(3)
    frame = np.arange(90)
    sup = np.r_[np.ones(30), np.zeros(30), np.full(30, 2)].astype(np.int8)  # floor, airborne, apparatus
    X = rng.normal(0, 0.03, (90, 15, 3)) + np.linspace(0, 1, 90)[:, None, None]
    segs = segments(frame, sup)
    cuts = segment_cutoffs(segs, sup, 8.0, 6.0)
    assert cuts == [6.0, 8.0, 6.0]
    out = filter_joints(X, segs, 30.0, cuts)
    for (s0, s1), fc in zip(segs, cuts):  # scipy directly, segment by segment
        b, a = butter(2, fc / 15.0)
        np.testing.assert_allclose(out[s0:s1], filtfilt(b, a, X[s0:s1], axis=0, padlen=9), atol=1e-12)
    assert segment_cutoffs(segs, sup, None, 6.0) == [None] * 3
    np.testing.assert_array_equal(filter_joints(X, segs, 30.0, [None] * 3), X)


def test_rotation_window_keeps_the_take_off_side_when_the_poses_stop_at_landing():
    """A vault's second flight: 100 deg turned on the table before take-off, 890 in the air, and the
    poses lost right after landing; the rules count from the most upright frame before take-off."""
    from gymtrack.analysis.flights import flight_elements

    fps, n_pre, n_air = 30.0, 20, 30
    M = n_pre + n_air  # the poses stop with the flight's last frame
    frame = np.arange(M)
    som = np.r_[np.linspace(0, 100, n_pre), np.linspace(100, 990, n_air)]
    incl = np.abs(((som + 180) % 360) - 180)  # 0 upright
    one = np.ones(M)
    cols = {k: v[None] for k, v in {"somersault": som, "twist": 0 * one, "inclination": incl, "com_x": 0 * one,
                                      "com_y": 0 * one, "com_z": one, "left_hip": 170 * one, "right_hip": 170 * one,
                                      "left_knee": 170 * one, "right_knee": 170 * one, "split": 10 * one}.items()}
    sup = np.r_[np.full(n_pre, 2), np.zeros(n_air)].astype(np.int8)
    fl = flight_elements(frame, cols, sup, fps, [(n_pre, n_pre + n_air - 1)])
    assert fl[0]["rotation_window"] == "landing" and fl[0]["rotation_from_frame"] <= 2  # upright within 10 deg
    assert fl[0]["saltos"] == 2.75


def test_frames_whose_twist_lines_the_pose_stage_knew_were_bad_are_not_read(twisting_double):
    kp, start, stop = twisting_double
    bad = kp.copy()
    sigma = np.full(kp.shape[:2], 0.01)
    names = ("left_shoulder", "right_shoulder", "left_hip", "right_hip")
    ls, rs, lh, rh = (COCO17.joints.index(n) for n in names)
    r0 = start + (stop - start) // 2
    # two frames whose shoulders and hips were both put 60 and 120 deg round the long axis (the lines
    # agree, so the agreement test passes them), with the sds the pose stage gave them (40 cm)
    for r, turn in ((r0, np.radians(60)), (r0 + 1, np.radians(120))):
        S, H = 0.5 * (kp[r, ls] + kp[r, rs]), 0.5 * (kp[r, lh] + kp[r, rh])
        L = (S - H) / np.linalg.norm(S - H)
        for a, b, c in ((ls, rs, S), (lh, rh, H)):
            v = kp[r, a] - c
            w = v * np.cos(turn) + np.cross(L, v) * np.sin(turn) + L * (L @ v) * (1 - np.cos(turn))
            bad[r, a], bad[r, b] = c + w, c - w
        sigma[r, [ls, rs, lh, rh]] = 0.40
    a = analyse(poses_of(bad), SCENE, samples=0, cutoff_hz=None, joint_sigma=sigma)
    f = a.flights[0]
    assert (f["saltos"], f["twists"]) == (2.0, 1.0)


def _lift(late_rows: int = 3, seed: int = 0):
    """A coach lifting a gymnast to the rings, as the pose stage measured it: the true centre of mass
    rises from 1.0 m at 1.2 m/s, slowed by 1.5 m/s^2 (the lift's push, not gravity), for 0.5 s, then
    the hands grip; the skeleton stays standing 0.45 m aside (the coach's body) for the lift's first
    0.2 s and catches up with the body over ``late_rows`` rows. Returns frame, support, com (M, 3), sd."""
    n_stand, n_lift, n_grip = 10, 16, 5
    t = np.arange(n_lift) / 30.0
    true = np.zeros((n_stand + n_lift + n_grip, 3))
    true[:, 2] = 1.0
    true[n_stand:n_stand + n_lift, 2] = 1.0 + 1.2 * t - 0.75 * t ** 2
    true[n_stand + n_lift:, 2] = true[n_stand + n_lift - 1, 2] + 0.01 * np.arange(1, n_grip + 1)
    com = true.copy()
    late = n_stand + 6  # the skeleton left standing aside for 0.2 s of the lift (0.2 m below the body)
    com[n_stand:late] = [0.45, 0.0, 1.0]
    w = np.linspace(0, 1, late_rows + 2)[1:-1, None]  # the catch-up rows
    com[late:late + late_rows] = (1 - w) * com[late - 1] + w * true[late + late_rows]
    com += np.random.default_rng(seed).normal(0, 0.01, com.shape)
    sup = np.full(len(com), 1, np.int8)  # floor
    sup[late:n_stand + n_lift] = 0  # the measured skeleton leaves the floor at the catch-up
    sup[n_stand + n_lift:] = 2  # the grip
    return np.arange(len(com)), sup, com, np.full(len(com), 0.02)


def test_a_coach_lift_measured_late_is_no_flight_where_a_thrown_body_is():
    """The heights of the lift's catch-up fit -g (the vertical test alone reads a flight), but the
    body's centre swings sideways and back: no thrown body does that. A real flight with the same
    noise -- a parabola with g, 1 m/s forward -- stays a flight."""
    from gymtrack.analysis.flights import G, fall_rate, find_flights

    frame, sup, com, sd = _lift()
    a, b = 16, 25
    az, _ = fall_rate(frame[a:b + 1] / 30.0, com[a:b + 1, 2], sd[a:b + 1])
    assert abs(az + G) <= 0.5 * G  # the vertical test alone is fooled
    fl, _ = find_flights(frame, sup, 30.0, com[:, 2], com[:, 2], sd)
    assert fl == [(a, b)]
    fl, lifted = find_flights(frame, sup, 30.0, com[:, 2], com[:, 2], sd, com, box_xy=com[:, :2], somersault=np.zeros(len(com)))
    assert fl == [] and lifted == [(a, b)]
    # a thrown body: the same rows, a parabola with g and a steady horizontal speed
    t = (frame - a) / 30.0
    thrown = np.column_stack([1.0 * t, 0.2 * t, 1.0 + 3.0 * t - G / 2 * t ** 2])
    thrown[:a] = thrown[a]
    thrown += np.random.default_rng(1).normal(0, 0.01, thrown.shape)
    fl, lifted = find_flights(frame, sup, 30.0, thrown[:, 2], thrown[:, 2], sd, thrown, box_xy=thrown[:, :2],
                                somersault=np.zeros(len(com)))
    assert fl == [(a, b)] and lifted == []


def test_a_quarter_second_contact_at_the_apex_is_bridged_past_blips_a_hang_is_not():
    """A jump to the parallel bars' support: the hands pass the rails near the apex, where the body
    rises slowly, and the wrists read within reach of a rail for 7 rows (0.23 s), with a 2-row
    airborne blip among them; the centre of mass stays on its parabola: one flight. The same rows
    with the body stopped there (a hang: the bar holds it, its height constant) stay a contact."""
    from gymtrack.analysis.contacts import bridge_contacts

    frame, sup, z, sd = _heights(n1=12, gap=7, n2=6, seed=2)
    sup[14:16] = 0  # the blip: 12..13 contact, 14..15 airborne, 16..18 contact
    out, n = bridge_contacts(frame, sup, 30.0, z, sd)
    assert n == 1 and (out == 0).all()
    held = z.copy()
    held[12:] = z[12] + np.random.default_rng(3).normal(0, 0.01, len(z) - 12)
    held[19:] -= 9.81 / 2 * (np.arange(len(z) - 19) / 30.0) ** 2  # released again after the hang
    assert bridge_contacts(frame, sup, 30.0, held, sd)[1] == 0


def test_a_pivot_and_a_pivot_back_are_two_turns():
    """A half turn one way (180 -> 0 deg over 25 rows), a pause of 4 rows, a half turn back (0 ->
    180) on the beam, upright and in place: two turns of 180 deg with opposite directions (the
    rows between them, closer than a turn's 0.2 s pause, joined them into one of 0 deg before)."""
    from gymtrack.analysis.elements import turns

    smooth = lambda n: 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, n))  # noqa: E731
    deg = np.concatenate([np.full(10, 180.0), 180 - 180 * smooth(25), np.zeros(4), 180 * smooth(25), np.full(10, 180.0)])
    M = len(deg)
    frame = np.arange(M)
    got = turns(frame, np.radians(deg), np.full(M, 2, np.int8), np.zeros(M), np.zeros((M, 3)), 30.0)
    assert [(t["degrees"], t["direction"]) for t in got] == [(180.0, -1), (180.0, 1)]
    assert got[0]["end_frame"] < got[1]["start_frame"]


def test_a_quarter_turns_slow_ends_count():
    """An 86 deg quarter turn (the simulator's floor turn before a mount, true skeleton: 85.3) whose
    heading speeds up and slows down smoothly: the rows turning faster than 30 deg/s cover only about
    78 deg of it, so the turn is measured from rest to rest (the slow ends of the same turn) and
    read as 90 deg, as the ground truth counts it."""
    from gymtrack.analysis.elements import turns

    smooth = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, 13))
    deg = np.concatenate([np.full(10, -185.0), -185 - 86 * smooth, np.full(12, -271.0)])
    M = len(deg)
    got = turns(np.arange(M), np.radians(deg), np.full(M, 1, np.int8), np.zeros(M), np.zeros((M, 3)), 30.0)
    assert [(t["degrees"], t["direction"]) for t in got] == [(90.0, -1)] and abs(got[0]["turn_deg"] + 86) < 2


def test_a_turn_the_data_end_on_is_not_read():
    """A quarter turn with 12 still rows after it is read; the same turn with 4 rows after it (the
    recording stops 0.13 s after it) is not: whether the body stayed on the spot (0.3 s after a
    turn) cannot be told, and a gymnast turning to walk off must not read as a turn element."""
    from gymtrack.analysis.elements import turns

    smooth = 0.5 - 0.5 * np.cos(np.linspace(0, np.pi, 13))
    deg = np.concatenate([np.full(10, 0.0), 90 * smooth, np.full(12, 90.0)])

    def read(d):
        M = len(d)
        return turns(np.arange(M), np.radians(d), np.full(M, 1, np.int8), np.zeros(M), np.zeros((M, 3)), 30.0)

    assert [t["degrees"] for t in read(deg)] == [90.0]
    assert read(deg[:-8]) == []
