"""Lifting MVOR's real OpenPose keypoints (a few frames; skipped when the data is absent).

MVOR: Srivastav et al., MICCAI-LABELS 2018, arXiv:1808.08180 (CC BY-NC-SA 4.0), read from
shared/data/mvor, never copied here.
"""

from pathlib import Path

import numpy as np
import pytest

from gymtrack.eval.pose_mvor import body_plane, lift_mvor, mvor_errors, mvor_markdown, one_body_one_person, run_mvor_pose
from gymtrack.formats.mvor import MVOR_SKELETON

from conftest import random_rig

MVOR = Path(__file__).resolve().parents[2] / "shared" / "data" / "mvor"
if not (MVOR / "camma_mvor_2018.json").is_file():
    MVOR = Path("/work/shared/data/mvor")
needs_data = pytest.mark.skipif(not (MVOR / "camma_mvor_2018.json").is_file(), reason="MVOR data (shared/data/mvor) is absent")


@pytest.fixture(scope="module")
def mv():
    from gymtrack.formats.mvor import read_mvor

    return read_mvor(MVOR, detectors=("openpose",), max_match_px=np.inf)


@needs_data
def test_robust_beats_dlt_on_real_openpose_keypoints(mv):
    r = lift_mvor(mv, "openpose", frames=np.arange(60))
    assert len(r["gt"]) > 50
    common = np.isfinite(r["dlt"]).all(-1) & np.isfinite(r["robust"]).all(-1)
    d, b = mvor_errors(r["dlt"], r["gt"], common), mvor_errors(r["robust"], r["gt"], common)
    assert d["joints_common"] > 100
    # on the same joints, dropping disagreeing views must help against wrong detections
    assert b["mpjpe_common_mm"] < d["mpjpe_common_mm"]
    assert b["mpjpe_mm"] < d["mpjpe_mm"]
    # a sane scale: metres, not millimetres, and most joints within half a metre
    assert 30 < b["median_mm"] < 300 and b["over_500mm"] < 0.25
    # the room's up: unit, and mostly against camera 1's y (y points down in its image)
    assert np.linalg.norm(mv.up) == pytest.approx(1.0) and mv.up[1] < -0.5


def _person(rng):
    rig = random_rig(rng, 3)
    X = np.array([0.0, 0.0, 1.0]) + rng.normal(0, 0.2, (10, 3))  # a person's 10 joints, z up
    kp = np.zeros((3, 10, 3))
    for c, cam in enumerate(rig):
        kp[c, :, :2], kp[c, :, 2] = cam.project(X), 0.9
    return rig, X, kp


def test_lone_joints_plane_is_vertical_through_the_person_and_faces_its_view(rng):
    rig, X, kp = _person(rng)
    kp[:2, 7:, 2] = 0.0  # joints 7-9 only in view 2
    est = np.where(np.arange(10)[:, None] < 7, X, np.nan)
    up = np.array([0.0, 0.0, 1.0])
    centre, n = body_plane(rig, kp, est, up, 0.0, np.full(10, np.nan))
    np.testing.assert_allclose(centre, np.median(X[:7], axis=0))
    los = centre - rig[2].centre
    los[2] = 0.0
    np.testing.assert_allclose(n, los / np.linalg.norm(los), atol=1e-12)
    assert body_plane(rig, kp, np.where(np.isfinite(est), est, X), up, 0.0, np.full(10, np.nan)) is None  # all placed


def test_a_person_one_view_sees_is_centred_at_its_joints_usual_heights(rng):
    rig, X, kp = _person(rng)
    kp[1:, :, 2] = 0.0  # view 0 only: nothing triangulated
    up = np.array([0.0, 0.0, 1.0])
    centre, _ = body_plane(rig, kp, np.full((10, 3), np.nan), up, 0.0, X[:, 2])  # the true heights
    np.testing.assert_allclose(centre, np.median(X, axis=0), atol=1e-9)  # every ray meets its height at its joint


def test_one_body_one_person_leaves_a_shared_detection_to_the_person_it_fits(rng):
    rig, X, kp = _person(rng)
    Y = X + np.array([0.8, 0.3, 0.0])
    kq = np.zeros_like(kp)
    for c, cam in enumerate(rig):
        kq[c, :, :2], kq[c, :, 2] = cam.project(Y), 0.9
    kq[0] = kp[0]  # person 2's view 0 holds person 1's body (the file repeats a detection)
    both = np.stack([kp, kq])
    assert one_body_one_person(rig, MVOR_SKELETON, both, np.array([5, 5])) == 1
    assert (both[1, 0, :, 2] == 0).all() and (both[0, 0, :, 2] == 0.9).all()
    np.testing.assert_array_equal(both[1, 1:], kq[1:])


def test_errors_by_hand():
    gt = np.zeros((1, 3, 3))
    est = np.array([[[0.1, 0, 0], [np.nan] * 3, [0, 0.6, 0]]])
    e = mvor_errors(est, gt)
    assert e["joints_gt"] == 3 and e["joints_estimated"] == 2
    assert e["mpjpe_mm"] == pytest.approx(350.0) and e["over_500mm"] == pytest.approx(0.5)


def test_section_without_data_says_why(tmp_path):
    d = run_mvor_pose(tmp_path)
    assert d["available"] is False and "MVOR" in mvor_markdown(d)


@needs_data
def test_snapshot_rules_lower_the_error_and_say_what_they_declined(mv):
    frames = np.arange(150)
    on = lift_mvor(mv, "openpose", frames=frames, methods=("robust",))
    off = lift_mvor(mv, "openpose", frames=frames, methods=("robust",), decline=False, bones=False)
    e_on, e_off = mvor_errors(on["robust"], on["gt"]), mvor_errors(off["robust"], off["gt"])
    assert e_on["mpjpe_mm"] < e_off["mpjpe_mm"]
    # every joint robust no longer estimates is one it declined, and counted
    lost = np.isfinite(off["robust"]).all(-1) & ~np.isfinite(on["robust"]).all(-1)
    assert 0 < lost.sum() <= on["joints_declined"] and off["joints_declined"] == 0
    # the pooled lengths (no ground truth) are an adult's: forearm and upper arm 15-40 cm
    L = dict(zip(map(tuple, np.asarray(MVOR_SKELETON.bones).reshape(-1, 2)), on["bone_lengths_m"]))
    j = {n: i for i, n in enumerate(MVOR_SKELETON.joints)}
    for a, b in (("left_elbow", "left_wrist"), ("right_shoulder", "right_elbow")):
        key = (j[a], j[b]) if (j[a], j[b]) in L else (j[b], j[a])
        assert 0.15 < L[key] < 0.40
