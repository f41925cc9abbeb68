"""The simulated top-down pose model: calibration against the cited AP figures, noise at the
stated level, self-occlusion, swaps from behind and upside down, the crop border, crop
confusion, no box no pose, determinism and the routine-folder path."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from gymtrack.detections import Detections
from gymtrack.errors import InputError
from gymtrack.geometry import Camera, Rig
from gymtrack.geometry.camera import look_at
from gymtrack.simulate import body as B
from gymtrack.simulate import simulate_routine
from gymtrack.simulate.pose_model import (
    PoseModelParams, coco_oks_ap, run_pose_model, simulate_pose_model, simulate_pose_model_for_routine,
)

F = 1500.0
NO_SWAP = replace(PoseModelParams(), swap_base=0, swap_back=0, swap_rotated=0, legs_swap_base=0, legs_swap_back=0,
                  legs_swap_rotated=0)
LS, RS, LW, LH, RH, LA = 5, 6, 9, 11, 12, 15


def _rig(dist_m: float = 10.0) -> Rig:
    R, t = look_at(np.array([dist_m, 0.0, 1.2]), np.array([0.0, 0.0, 1.0]))
    K = np.array([[F, 0, 960.0], [0, F, 540.0], [0, 0, 1.0]])
    return Rig([Camera("cam0", (1920, 1080), K, R, t)])


def _body(T: int, yaw: float = 0.0, pitch: float = 0.0, xy=(0.0, 0.0), height: float = 1.70, posture=B.STAND) -> np.ndarray:
    """(T, 17, 3) a still body; yaw 0 faces the camera at +x, pi turns its back to it."""
    bm = B.BodyModel(height)
    n = np.ones(T)
    ang = np.repeat(B.posture_angles(posture)[None], T, 0)
    centre = np.column_stack([np.full(T, xy[0]), np.full(T, xy[1]), np.full(T, 1.0)])
    pts, _ = bm.world_points(centre, ang, yaw * n, pitch * n, 0 * n)
    return pts[:, :17]


def _standard_crops(rig: Rig, kp: np.ndarray, fill: float = 1.25) -> np.ndarray:
    """(T, 4) centre-form crops of the HRNet protocol: the body box made 3:4 and grown 1.25x."""
    uv = rig[0].project(kp)
    lo, hi = uv.min(1), uv.max(1)
    pad = 0.1 * (hi[:, 1] - lo[:, 1])
    w, h = hi[:, 0] - lo[:, 0] + 2 * pad, hi[:, 1] - lo[:, 1] + 2 * pad
    h = np.maximum(h, w * 256 / 192)
    w = h * 192 / 256
    return np.column_stack([(lo[:, 0] + hi[:, 0]) / 2, (lo[:, 1] + hi[:, 1]) / 2, fill * w, fill * h])


def _run(rig, joints, crops, pid=(1,), seed=0, params=PoseModelParams(), frames=None, track=7):
    T = joints.shape[1]
    frames = np.arange(1, T + 1) if frames is None else frames
    boxes = Detections.from_arrays(frames, 0, crops, rig.names, track_id=np.full(len(frames), track))
    return run_pose_model(rig, joints, np.array(pid), np.arange(1, T + 1), boxes, seed, params)


def _err(rig, out, kp):
    return np.linalg.norm(out.poses.keypoints[..., :2] - rig[0].project(kp), axis=-1)


def test_calibration_reproduces_the_cited_ap():
    p = PoseModelParams()
    assert coco_oks_ap(p, 1.0) == pytest.approx(0.744, abs=0.012)  # HRNet-W32 256x192, COCO val
    assert coco_oks_ap(p, 2.0) == pytest.approx(0.669, abs=0.012)  # HRNet-W32 128x96 (DARK)
    assert coco_oks_ap(replace(p, level=2 * p.level), 1.0) < 0.5  # the AP responds to the level


def test_noise_matches_the_stated_level():
    rig, T = _rig(), 3000
    kp = _body(T)
    out = _run(rig, kp[None], _standard_crops(rig, kp), params=NO_SWAP)
    p = NO_SWAP
    # tau by hand: s = f sqrt(area) (H / 1.70) / depth, R = 1 in the standard crop
    s = F * np.sqrt(p.body_area_m2) / rig[0].depth(kp[0].mean(0))
    tau_sh = s * np.hypot(p.level, p.level_resolution)
    assert np.median(out.tau[:, LS]) == pytest.approx(tau_sh, rel=0.03)
    assert not out.occluded[:, [LS, RS, LW, LA]].any()
    err = _err(rig, out, kp)
    # Rayleigh: median = tau sqrt(2 ln 2)
    for j in (LS, LW, LA):
        assert np.median(err[:, j]) == pytest.approx(out.tau[0, j] * np.sqrt(2 * np.log(2)), rel=0.08), j
    g = np.asarray(p.joint_factor)
    assert g[LW] > g[LS] and g[LA] > g[LH] > g[LS]  # wrists, ankles worst (MPII PCKh)
    assert np.median(err[:, LA]) > 1.2 * np.median(err[:, LS])
    # a body half as large in its crop has more error (heatmap resolution)
    out2 = _run(rig, kp[None], _standard_crops(rig, kp, fill=2.5), params=NO_SWAP)
    assert np.median(_err(rig, out2, kp)[:, LS]) > 1.1 * np.median(err[:, LS])
    vis = out.poses.keypoints[..., 2]
    assert 0.8 < vis.mean() < 0.95 and vis.min() >= 0 and vis.max() <= 1


def test_self_occlusion_from_the_side_and_behind():
    rig, T = _rig(), 400
    side = _body(T, yaw=np.pi / 2)  # its right side faces the camera
    out = _run(rig, side[None], _standard_crops(rig, side), params=NO_SWAP)
    assert out.occluded[:, LS].all() and out.occluded[:, LH].all()
    assert not out.occluded[:, RS].any() and not out.occluded[:, 14].any()  # right knee (the right hip is behind the hanging arm)
    sc = out.poses.keypoints[..., 2]
    assert sc[:, LS].mean() < sc[:, RS].mean() - 0.25
    err = _err(rig, out, side)
    assert np.median(err[:, LS]) > 1.8 * np.median(err[:, RS])
    back = _body(T, yaw=np.pi)
    ob = _run(rig, back[None], _standard_crops(rig, back), params=NO_SWAP)
    assert ob.occluded[:, 0].all()  # the nose, behind the head
    front = _run(rig, _body(T)[None], _standard_crops(rig, _body(T)), params=NO_SWAP)
    assert not front.occluded[:, :3].any() and front.back.max() < 0.05 and ob.back.min() > 0.95


def test_swaps_more_from_behind_and_upside_down():
    rig, T = _rig(), 4000
    rates = {}
    for name, yaw, pitch in (("front", 0.0, 0.0), ("back", np.pi, 0.0), ("inverted", 0.0, np.pi)):
        kp = _body(T, yaw=yaw, pitch=pitch)
        out = _run(rig, kp[None], _standard_crops(rig, kp))
        rates[name] = (out.swapped > 0).mean()
        full = out.swapped == 1
        if full.any():  # a whole-body swap puts "left_shoulder" on the right shoulder
            uv = rig[0].project(kp)
            d_right = np.linalg.norm(out.poses.keypoints[full, LS, :2] - uv[full, RS], axis=-1)
            d_left = np.linalg.norm(out.poses.keypoints[full, LS, :2] - uv[full, LS], axis=-1)
            assert np.median(d_right) < np.median(d_left)
    p = PoseModelParams()
    assert rates["front"] == pytest.approx(p.swap_base + (1 - p.swap_base) * p.legs_swap_base, abs=0.012)
    assert rates["back"] > rates["front"] + 0.12
    assert rates["inverted"] > rates["front"] + 0.15


def test_joints_outside_the_crop_are_clamped_with_low_scores():
    rig, T = _rig(), 200
    kp = _body(T)
    crops = _standard_crops(rig, kp, fill=1.0)
    crops[:, 1] -= 0.3 * crops[:, 3]  # the crop moves up: the feet fall below it
    out = _run(rig, kp[None], crops)
    bottom = crops[:, 1] + crops[:, 3] / 2
    assert out.outside[:, LA].all()
    np.testing.assert_allclose(out.poses.keypoints[:, LA, 1], bottom)
    assert out.poses.keypoints[:, LA, 2].max() < 0.3 and out.poses.keypoints[:, LS, 2].mean() > 0.7
    # feet off the image but inside the crop (its padding): low scores, not clamped
    c0 = _rig()[0]
    low = Rig([Camera("cam0", (1920, 600), c0.K, c0.R, c0.t)])  # a short image: the feet fall below it
    o2 = _run(low, kp[None], _standard_crops(low, kp))
    feet_off = low[0].project(kp)[:, LA, 1] > 600
    assert feet_off.all() and not o2.outside[:, LA].any() and o2.poses.keypoints[:, LA, 2].max() < 0.3
    x = out.poses.keypoints[..., 0]
    assert np.all((x >= crops[:, :1] - crops[:, 2:3] / 2 - 1e-9) & (x <= crops[:, :1] + crops[:, 2:3] / 2 + 1e-9))


def test_a_crop_holding_another_person_gives_that_persons_joints():
    rig, T = _rig(), 50
    a = _body(T, xy=(0.0, -0.9))
    b = _body(T, xy=(-2.0, 0.9), height=1.8)
    joints = np.stack([a, b])
    ca, cb = _standard_crops(rig, a), _standard_crops(rig, b)
    mostly_b = 0.3 * ca + 0.7 * cb  # the track's box drifted onto B
    boxes = np.concatenate([ca, cb, mostly_b])
    frames = np.tile(np.arange(1, T + 1), 3)
    bx = Detections.from_arrays(frames, 0, boxes, rig.names, track_id=np.full(3 * T, 5))
    out = run_pose_model(rig, joints, np.array([11, 22]), np.arange(1, T + 1), bx, seed=1, params=NO_SWAP)
    assert np.all(out.person_id[:T] == 11) and np.all(out.person_id[T:] == 22)
    uvb = rig[0].project(b)
    err_b = np.linalg.norm(out.poses.keypoints[2 * T:, :, :2] - uvb, axis=-1)
    assert np.median(err_b) < 10.0 and np.all(out.poses.track_id == 5)


def test_no_box_no_pose_and_empty_crops_give_junk():
    rig, T = _rig(), 20
    kp = _body(T)
    empty = Detections.empty(rig.names)
    poses = simulate_pose_model(rig, kp[None], np.array([1]), np.arange(1, T + 1), empty)
    assert len(poses) == 0 and poses.keypoints.shape == (0, 17, 3)
    crops = _standard_crops(rig, kp)
    nobody = crops.copy()
    nobody[:, 0] += 700  # nobody there
    out = _run(rig, kp[None], np.concatenate([crops[:5], nobody[:5]]), frames=np.r_[1:6, 1:6])
    assert len(out.poses) == 10 and np.array_equal(out.person_id, [1] * 5 + [-1] * 5)
    assert out.poses.keypoints[5:, :, 2].max() <= 0.2 and out.poses.keypoints[:5, :, 2].mean() > 0.7
    np.testing.assert_allclose(out.poses.bbox[:5, 2:], crops[:5, 2:])
    np.testing.assert_allclose(out.poses.bbox[:5, :2], crops[:5, :2] - crops[:5, 2:] / 2)


def test_deterministic_and_independent_of_the_other_boxes():
    rig, T = _rig(), 60
    kp = _body(T)
    crops = _standard_crops(rig, kp)
    a = _run(rig, kp[None], crops, seed=4)
    b = _run(rig, kp[None], crops, seed=4)
    c = _run(rig, kp[None], crops, seed=5)
    assert np.array_equal(a.poses.keypoints, b.poses.keypoints)
    assert not np.allclose(a.poses.keypoints, c.poses.keypoints)
    # the same crop on the same body, among other boxes in another order: the same answer
    sub = _run(rig, kp[None], crops[::-1][:10], seed=4, frames=np.arange(T, T - 10, -1))
    np.testing.assert_array_equal(sub.poses.keypoints, a.poses.keypoints[::-1][:10])


def test_bad_input_is_reported():
    rig, T = _rig(), 10
    kp = _body(T)
    crops = _standard_crops(rig, kp)
    with pytest.raises(InputError, match="frames without 3D joints"):
        _run(rig, kp[None], crops, frames=np.arange(5, 5 + T))
    boxes = Detections.from_arrays(np.arange(1, T + 1), 0, crops, ("other",))
    with pytest.raises(InputError, match="cameras"):
        simulate_pose_model(rig, kp[None], np.array([1]), np.arange(1, T + 1), boxes)
    with pytest.raises(InputError, match=r"\(P, T, 17, 3\)"):
        simulate_pose_model(rig, kp[None, :, :5], np.array([1]), np.arange(1, T + 1), boxes)


def test_routine_folder_and_memory_agree(tmp_path):
    sim = simulate_routine("pommel_horse", n_cam=4, seed=2, seconds=10.0, out=tmp_path)
    c, t = np.nonzero(np.isfinite(sim.gt_box[:, 0, :, 0]))
    b = sim.gt_box[c, 0, t].copy()
    b[:, 2:] = 1.3 * b[:, 2:].max(1, keepdims=True)  # square b_buf-like crops on the target
    boxes = Detections.from_arrays(sim.frames[t], c, b, sim.rig.names, track_id=np.ones(t.size))
    mem = simulate_pose_model_for_routine(sim, boxes, seed=3)
    disk = simulate_pose_model_for_routine(tmp_path, boxes, seed=3)
    assert len(mem) == len(boxes) == len(disk)
    # joints written to the mm: the same poses but for the rare draw at a threshold (a swap, an occlusion)
    same = np.all(np.abs(disk.keypoints[..., :2] - mem.keypoints[..., :2]) < 1.0, axis=(1, 2))
    assert same.mean() > 0.99
    true = np.stack([sim.rig[ci].project(sim.keypoints[0, ti]) for ci, ti in zip(c, t)])
    med = np.median(np.linalg.norm(mem.keypoints[..., :2] - true, axis=-1))
    assert 1.0 < med < 0.1 * np.median(sim.gt_box[c, 0, t, 3])


def test_closest_points_of_segments_against_brute_force():
    from gymtrack.simulate.pose_view import closest_on_segments

    rng = np.random.default_rng(0)
    p0, p1, q0, q1 = (rng.normal(size=(200, 3)) for _ in range(4))
    q1[:20] = q0[:20]  # points (the head sphere)
    q1[20:40] = q0[20:40] + 0.3 * (p1[20:40] - p0[20:40])  # parallel
    s, t, d = closest_on_segments(p0, p1, q0, q1)
    g = np.linspace(0, 1, 401)
    P = p0[:, None] + g[None, :, None] * (p1 - p0)[:, None]
    Q = q0[:, None] + g[None, :, None] * (q1 - q0)[:, None]
    brute = np.linalg.norm(P[:, :, None] - Q[:, None, :], axis=-1).min(axis=(1, 2))
    np.testing.assert_allclose(d, brute, atol=2e-3)
    np.testing.assert_allclose(np.linalg.norm(p0 + s[:, None] * (p1 - p0) - q0 - t[:, None] * (q1 - q0), axis=-1), d, atol=1e-9)
