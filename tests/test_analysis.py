"""The analysis stage against hand-built skeletons and the simulator's own motion and elements."""

from __future__ import annotations

import json

import numpy as np
import pytest

import gymtrack
from gymtrack.analysis import analyse
from gymtrack.analysis.joints import USED
from gymtrack.analysis.kinematics import centre_of_mass, frame_angles
from gymtrack.errors import InputError
from gymtrack.formats.elements import read_angles, read_elements
from gymtrack.formats.scene import preset_scene
from gymtrack.poses import HOW_TRIANGULATED, Poses3D
from gymtrack.simulate import body as B
from gymtrack.simulate.motion import MotionBuilder
from gymtrack.skeletons import COCO17, custom_skeleton

IDX = {n: k for k, n in enumerate(USED)}


def poses_of(kp: np.ndarray, frames=None, skeleton=COCO17, reproj=0.0) -> Poses3D:
    n, J = kp.shape[:2]
    frames = np.arange(1, n + 1) if frames is None else frames
    return Poses3D(frames, np.ones(n), kp, np.ones((n, J)), np.full((n, J), 4), np.full((n, J), reproj),
                   np.full((n, J), HOW_TRIANGULATED, np.int8), skeleton)


def coco_of(body: B.BodyModel, centre, angles, yaw, pitch, twist) -> np.ndarray:
    pts, _ = body.world_points(centre, angles, yaw, pitch, twist)
    return pts[:, :17]


# ------------------------------------------------------------------ angles on hand-built skeletons
def test_angles_of_a_hand_built_skeleton():
    X = np.full((1, len(USED), 3), np.nan)
    put = lambda n, p: X[0, IDX[n]].__setitem__(slice(None), p)  # noqa: E731
    put("left_shoulder", (0, 0.2, 1.5)); put("right_shoulder", (0, -0.2, 1.5))
    put("left_hip", (0, 0.1, 1.0)); put("right_hip", (0, -0.1, 1.0))
    put("left_knee", (0.5, 0.1, 1.0))      # thigh forward, horizontal: hip angle 90
    put("left_ankle", (0.5, 0.1, 0.5))     # shank down: knee angle 90
    put("right_knee", (0, -0.1, 0.5)); put("right_ankle", (0, -0.1, 0.0))  # straight leg
    put("left_elbow", (0, 0.2, 1.2)); put("left_wrist", (0.3, 0.2, 1.2))  # upper arm down, elbow 90
    put("right_elbow", (0, -0.2, 1.8)); put("right_wrist", (0, -0.2, 2.1))  # arm straight up: shoulder 180
    a = {k: v[0] for k, v in frame_angles(X).items()}
    assert a["left_hip"] == pytest.approx(90, abs=1e-9)
    assert a["left_knee"] == pytest.approx(90, abs=1e-9)
    assert a["right_knee"] == pytest.approx(180, abs=1e-9)
    assert a["left_elbow"] == pytest.approx(90, abs=1e-9)
    lean = np.degrees(np.arctan2(0.1, 0.5))  # hip -> shoulder leans 0.1 m out over 0.5 m
    assert a["right_shoulder"] == pytest.approx(180 - lean, abs=1e-9)  # arm straight up
    assert a["left_shoulder"] == pytest.approx(lean, abs=1e-9)  # arm hanging down
    # split: left hip->ankle (0.5, 0, -0.5), right (0, 0, -1): 45 deg
    assert a["split"] == pytest.approx(45, abs=1e-9)
    # inclination: A (0.25, 0, 0.25) -> S (0, 0, 1.5)
    assert a["inclination"] == pytest.approx(np.degrees(np.arctan2(0.25, 1.25)), abs=1e-9)


def test_split_uses_knees_where_an_ankle_is_missing_and_handstand_inclination():
    body = B.BodyModel(1.7)
    ang = B.posture_angles(B.SPLIT)[None]
    kp = coco_of(body, np.zeros((1, 3)), ang, [0.0], [np.pi], [0.0])  # inverted
    X = kp[:, [COCO17.joints.index(n) for n in USED]]
    a = frame_angles(X)
    straight = coco_of(body, np.zeros((1, 3)), B.posture_angles(B.ARMS_UP)[None], [0.0], [np.pi], [0.0])
    assert frame_angles(straight[:, [COCO17.joints.index(n) for n in USED]])["inclination"][0] == pytest.approx(180, abs=1e-6)
    assert a["split"][0] == pytest.approx(95 + 75, abs=1e-6)  # hips flexed +95 and -75
    X[0, IDX["left_ankle"]] = np.nan
    assert frame_angles(X)["split"][0] == pytest.approx(170, abs=1e-6)


def test_centre_of_mass_of_a_standing_body_and_its_fallback():
    body = B.BodyModel(1.7)
    kp = coco_of(body, np.array([[1.0, 2.0, 1.0]]), B.posture_angles(B.STAND)[None], [0.3], [0.0], [0.0])
    X = kp[:, [COCO17.joints.index(n) for n in USED]]
    com, fb = centre_of_mass(X)
    # a standing adult's centre of mass: over the feet, at 0.53-0.58 of the height
    feet = X[0, [IDX["left_ankle"], IDX["right_ankle"]]].mean(0)
    assert not fb[0]
    assert np.linalg.norm(com[0, :2] - feet[:2]) < 0.05
    assert 0.53 * 1.7 < com[0, 2] - (feet[2] - 0.04 * 1.7) < 0.59 * 1.7
    X[0, IDX["left_wrist"]] = np.nan
    com2, fb2 = centre_of_mass(X)
    assert fb2[0] and np.allclose(com2[0], X[0, [IDX["left_hip"], IDX["right_hip"]]].mean(0))


# ------------------------------------------------------------------ somersault and twist against the simulator
@pytest.fixture(scope="module")
def double_tuck_full():
    """A handstand hold on the floor, then a tucked double back salto with a full twist, and landing."""
    body = B.BodyModel(1.65)
    rng = np.random.default_rng(0)
    b = MotionBuilder(body, 60.0, rng)
    b.place((2.0, 0.0), 0.0, np.pi / 2)  # beside the bar of the scene below
    b.stand(0.5, 0.0)
    b.push(0.0, 0.15, B.posture_angles(B.STAND))
    start = b.n
    end_c = b.body.centre_on_feet(np.array([[2.0, 1.2]]), 0.0, B.posture_angles(B.STAND)[None], [b.yaw], [-4 * np.pi], [2 * np.pi])[0]
    tuck = B.posture_angles(B.TUCK)
    b.flight(end_c, b.flight_frames(b.centre[2], end_c[2], 2.6), -4 * np.pi, twist_end=2 * np.pi,
             angle_keys=[(0.25, tuck), (0.75, tuck), (1.0, B.posture_angles(B.STAND))])
    stop = b.n
    b.stand(1.0, 0.0)
    m = b.build()
    kp = coco_of(body, m.centre, m.angles, m.yaw, m.pitch, m.twist)
    return m, kp, start, stop


def test_somersault_and_twist_follow_the_simulators_pitch_and_twist(double_tuck_full):
    m, kp, start, stop = double_tuck_full
    scene = preset_scene("horizontal_bar").model_copy(update={"fps": 60.0})  # plane normal +x, body faces +y
    a = analyse(poses_of(kp), scene, samples=0, cutoff_hz=None)
    # facing +y, the body's left axis is -x: a pitch about it is minus a rotation about +x
    som_true = -np.degrees(m.pitch - m.pitch[0])
    tw_true = np.degrees((m.twist + m.yaw) - (m.twist + m.yaw)[0])
    ok = np.isfinite(a["somersault"])
    assert ok.mean() > 0.95  # inverted and tucked frames included
    assert np.max(np.abs(a["somersault"][ok] - som_true[ok])) < 3.0
    assert np.max(np.abs(a["twist"][ok] - tw_true[ok])) < 3.0
    fl = a.flights
    assert len(fl) == 1
    f = fl[0]
    assert (f["saltos"], f["twists"], f["shape"]) == (2.0, 1.0, "tuck")
    # the flight's frames are the simulator's ballistic ones (1-based frames)
    ballistic = np.flatnonzero(m.flight) + 1
    assert (f["start_frame"], f["end_frame"]) == (ballistic[0], ballistic[-1])
    assert f["min_hip"] < 90 and f["min_knee"] < 90
    assert [e["frame"] for e in a.of_kind("landing")] == [f["end_frame"] + 1]


@pytest.mark.parametrize("normal", [(0.0, 1.0, 0.0), (1.0, 0.0, 0.0), (-0.6, 0.8, 0.0)])
def test_the_somersault_axis_is_the_plane_normal_but_the_pommel_horses_length(normal):
    """Laid on a scene's plane, every preset's somersault axis is the plane's normal n, but the pommel
    horse's is its length, n x z (the preset turned with the plane, its sign following n)."""
    from gymtrack.placement import scene_geometry
    from gymtrack.scene import PlaneSpec

    n = np.asarray(normal)
    for app in ("pommel_horse", "balance_beam", "horizontal_bar"):
        scene = preset_scene(app).model_copy(update={"planes": (PlaneSpec(point=(0.0, 0.0, 0.0), normal=normal),)})
        want = np.cross(n, [0.0, 0.0, 1.0]) if app == "pommel_horse" else n
        assert np.allclose(scene_geometry(scene).somersault_axis, want, atol=1e-12), app


def test_a_salto_over_the_pommel_horse_is_counted_about_its_length():
    """A layout turning forward once while facing across the horse (as its handstand dismount turns):
    about the horse's length the somersault follows the body's pitch; about the plane's normal (the
    beam's axis), which lies in the plane of the turn, it only jumps between 0 and 180 deg."""
    body = B.BodyModel(1.7)
    n = 91
    pitch = np.linspace(0.0, 2 * np.pi, n)
    ang = np.repeat(B.posture_angles(B.LAYOUT)[None], n, 0)
    kp = coco_of(body, np.tile([0.0, 2.0, 1.5], (n, 1)), ang, np.full(n, np.pi / 2), pitch, np.zeros(n))  # faces +y
    a = analyse(poses_of(kp), preset_scene("pommel_horse"), samples=0, cutoff_hz=None)
    # facing +y the body's left axis is -x: a pitch about it is minus a turn about +x
    assert np.max(np.abs(a["somersault"] + np.degrees(pitch))) < 1e-6
    beam = analyse(poses_of(kp), preset_scene("balance_beam"), samples=0, cutoff_hz=None)
    ok = np.isfinite(beam["somersault"])
    assert np.max(np.abs(beam["somersault"][ok] + np.degrees(pitch[ok]))) > 60


def test_handstand_hold_and_its_deviation():
    body = B.BodyModel(1.6)
    n = 90
    lean = np.radians(8.0)
    kp = coco_of(body, np.tile([0.0, 0.0, 1.0], (n, 1)), np.tile(B.posture_angles(B.ARMS_UP), (n, 1)),
                 np.zeros(n), np.full(n, np.pi - lean), np.zeros(n))
    kp[..., 2] -= np.nanmin(kp[..., 2]) - 0.02  # hands on the floor
    a = analyse(poses_of(kp), preset_scene("balance_beam").model_copy(update={"apparatus": None}), samples=8)
    holds = a.of_kind("hold")
    assert len(holds) == 1
    h = holds[0]
    assert h["position"] == "handstand"
    assert h["duration_s"] >= 2.5
    # A->S leans like the body axis (the arms up are straight): deviation ~8 deg
    assert h["deviation"] == pytest.approx(8.0, abs=1.5)
    assert "deviation_sd" in h


# ------------------------------------------------------------------ uncertainty
def test_sd_grows_with_joint_error_and_matches_a_monte_carlo():
    body = B.BodyModel(1.7)
    n = 40
    ang = np.tile(B.posture_angles(B.CROUCH), (n, 1))
    kp = coco_of(body, np.tile([0.0, 0.0, 1.0], (n, 1)), ang, np.zeros(n), np.zeros(n), np.zeros(n))
    scene = preset_scene("vault")
    small = analyse(poses_of(kp, reproj=1.0), scene, samples=64, cutoff_hz=None)
    big = analyse(poses_of(kp, reproj=8.0), scene, samples=64, cutoff_hz=None)
    assert np.median(big["left_knee_sd"]) > 2 * np.median(small["left_knee_sd"])
    # the reported sd is the spread of the knee over skeletons redrawn with the joints' sigma
    sigma = np.sqrt(0.01 ** 2 + (0.008 * 8.0) ** 2) * np.sqrt(2 / 4)
    rng = np.random.default_rng(123)
    knees = [analyse(poses_of(kp + rng.normal(0, sigma, kp.shape), reproj=8.0), scene, samples=0, cutoff_hz=None)["left_knee"]
             for _ in range(60)]
    spread = np.std(np.stack(knees), axis=0)
    assert np.median(big["left_knee_sd"]) == pytest.approx(np.median(spread), rel=0.25)


# ------------------------------------------------------------------ bad input
def test_missing_joints_are_named_and_the_rest_is_computed():
    body = B.BodyModel(1.7)
    n = 30
    kp = coco_of(body, np.tile([0.0, 0.0, 1.0], (n, 1)), np.tile(B.posture_angles(B.STAND), (n, 1)),
                 np.zeros(n), np.zeros(n), np.zeros(n))
    keep = [j for j in COCO17.joints if j not in ("left_ankle", "right_ankle")]
    sk = custom_skeleton(keep)
    p = poses_of(kp[:, [COCO17.joints.index(j) for j in keep]], skeleton=sk)
    a = analyse(p, preset_scene("balance_beam"), samples=0)
    assert "left_ankle" in a.missing["left_knee"] and "right_ankle" in a.missing["inclination"]
    assert np.isnan(a["left_knee"]).all() and np.isnan(a["inclination"]).all()
    assert np.isfinite(a["left_hip"]).all() and np.isfinite(a["split"]).all()  # split from the knees


def test_no_poses_no_hips_and_no_plane():
    scene = preset_scene("horizontal_bar")
    with pytest.raises(InputError, match="no 3D poses"):
        analyse(Poses3D.empty(COCO17), scene)
    sk = custom_skeleton(["nose", "left_shoulder", "right_shoulder"])
    with pytest.raises(InputError, match="no hip joint"):
        analyse(poses_of(np.zeros((5, 3, 3)), skeleton=sk), scene)
    body = B.BodyModel(1.7)
    kp = coco_of(body, np.tile([0.0, 0.0, 1.0], (20, 1)), np.tile(B.posture_angles(B.STAND), (20, 1)),
                 np.zeros(20), np.zeros(20), np.zeros(20))
    bare = scene.model_copy(update={"apparatus": None, "planes": ()})
    a = analyse(poses_of(kp), bare, samples=0)
    assert "apparatus plane" in a.missing["somersault"] and "no apparatus" in a.missing["circle"]
    assert np.isnan(a["somersault"]).all() and np.isfinite(a["left_knee"]).all()


# ------------------------------------------------------------------ the simulator's own elements
@pytest.fixture(scope="module")
def routine(tmp_path_factory):
    from gymtrack.simulate import simulate_routine

    d = tmp_path_factory.mktemp("an")
    sim = simulate_routine("balance_beam", n_cam=4, seed=0, seconds=30, out=d / "r")
    return sim, d / "r"


def test_the_true_skeleton_reproduces_the_choreographys_flights(routine):
    sim, path = routine
    from gymtrack.eval.judging import truth_poses

    gt = read_elements(path / "gt" / "elements.json")
    a = analyse(truth_poses(sim.frames, sim.keypoints[0], 1), sim.scene, samples=0, cutoff_hz=None)
    want = [e for e in gt["elements"] if e["kind"] == "flight"]
    got = a.flights
    assert len(got) == len(want) >= 3
    for w, g in zip(want, got):
        assert (g["saltos"], g["twists"], g["shape"]) == (w["saltos"], w["twists"], w["shape"])
        assert (g["start_frame"], g["end_frame"]) == (w["start_frame"], w["end_frame"])
    lw = [e["frame"] for e in gt["elements"] if e["kind"] == "landing"]
    assert [e["frame"] for e in a.of_kind("landing")] == lw


def test_a_pommel_horse_mount_and_dismount_keep_the_choreographys_frames(tmp_path):
    """The mount's hands come within the 0.10 m touch distance of the pommels 2 frames before they
    reach them, and the dismount's hands stay within it a frame after they leave: the flights still
    run over the simulator's ballistic frames exactly (the take-off and landing settled)."""
    from gymtrack.eval.judging import truth_poses
    from gymtrack.simulate import simulate_routine

    sim = simulate_routine("pommel_horse", n_cam=4, seed=0, seconds=12, out=tmp_path / "r")
    gt = read_elements(tmp_path / "r" / "gt" / "elements.json")
    a = analyse(truth_poses(sim.frames, sim.keypoints[0], 1), sim.scene, samples=0, cutoff_hz=None)
    want = [(e["start_frame"], e["end_frame"]) for e in gt["elements"] if e["kind"] == "flight"]
    assert len(want) == 2 and [(e["start_frame"], e["end_frame"]) for e in a.flights] == want
    assert a.summary["flight_rows_settled"] >= 3


def test_written_files_read_back(routine, tmp_path):
    sim, _ = routine
    from gymtrack.eval.judging import truth_poses

    a = gymtrack.analyse(truth_poses(sim.frames, sim.keypoints[0], 1), sim.scene, samples=4)
    a.write(tmp_path / "analysis")
    cols = read_angles(tmp_path / "analysis" / "angles.csv")
    np.testing.assert_array_equal(cols["frame"], a.frame)
    np.testing.assert_allclose(cols["left_knee"], a["left_knee"], atol=0.006)
    assert set(cols["support"]) <= {"none", "floor", "apparatus"} and "none" in set(cols["support"])
    doc = json.loads((tmp_path / "analysis" / "elements.json").read_text())
    assert doc["apparatus"] == "balance_beam" and len(doc["elements"]) == len(a.elements)
    assert all("apex_z_sd" in e for e in doc["elements"] if e["kind"] == "flight")
