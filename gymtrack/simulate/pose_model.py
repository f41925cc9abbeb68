"""A simulated top-down 2D pose model (HRNet-like) run on the boxes a tracking method output.

Paper: Section III-D, last paragraph of "Identify Target Gymnast for Pose Estimation": HRNet runs
on the target's expanded box ``b_buf`` in every view and the 3D pose is triangulated from its 2D
keypoints; Fig. 7 shows how a biased box misdirects the pose. The model sees
only what the method's crop shows, so each method's ``b_buf`` decides the pose error.

Per crop (vectorised over crops; the geometry is in :mod:`.pose_view`):

1. **Whose body.** The person the crop holds most (projected body overlap, see
   :func:`.pose_view.choose_person`); that may be a coach rather than the target. A crop with no
   body gives a junk pose with low scores, as a real model does; no box gives no pose.
2. **Localisation noise**, isotropic Gaussian per joint, per coordinate
   ``tau_j = s * g_j * sqrt(level^2 + (level_resolution * R)^2)``: ``s`` the COCO object scale
   (``sqrt`` of the body's area, from the camera's focal length, the body height and its depth),
   ``g_j`` the per-joint difficulty (wrists and ankles worst), ``R`` how much smaller the body is
   in the model's 256x192 input than in the standard crop (1.25 x the body box).
   Calibration: with COCO's OKS (``kappa_j = 2 sigma_j``, COCO keypoint evaluation), the noise
   at ``R = 1`` gives OKS-AP 74.4, HRNet-W32 256x192 on COCO val2017 (Sun et al., CVPR 2019,
   Table 1; RTMPose-m is 75.8, Jiang et al. 2023); at ``R = 2`` (half the input resolution) it
   gives 66.9, HRNet-W32 at 128x96 (Zhang et al., DARK, CVPR 2020, input-size study).
   :func:`coco_oks_ap` recomputes both and the tests check them.
   ``g_j``: from HRNet-W32's per-joint PCKh@0.5 on MPII test (Sun et al. 2019: head 98.6,
   shoulder 96.9, elbow 92.8, wrist 89.0, hip 91.5, knee 89.0, ankle 85.7), with a Rayleigh error
   ``tau_j ~ 1 / sqrt(-2 ln(1 - PCKh_j))``, relative to the shoulder.
3. **Self-occlusion**: a joint whose line of sight passes through the body's own capsules
   (torso, limbs, head) gets ``occluded_noise`` more error and a lower score.
4. **Unusual poses**: HRNet trains with rotations of +-45 deg only (Sun et al. 2019, Sec. 4.1),
   so a body rotated further in the image (inverted in a handstand or a salto) is out of the
   training distribution; state-of-the-art models under-perform on such poses (Drolet-Roy et
   al., trampoline pose estimation, 2026). No published figure pins the size of the drop for
   HRNet, so ``rotated_noise``, ``swap_rotated`` and ``score_rotated`` are assumptions, stated
   as such, and the same for every method.
5. **Left/right swaps** of the whole body or of the legs (the "inversion" error of Ronchi and
   Perona, ICCV 2017), more likely seen from behind and when rotated.
6. **The crop border**: a heatmap model answers inside its crop: a joint outside is clamped to
   the border with a low score; a joint inside the crop but off the image (the padding) gets
   the same low score.

Scores are heatmap-peak-like, in [0, 1]: ~0.88 visible, ~0.45 occluded, ~0.12 outside the crop,
lower when the pose is rotated and when that joint's error is large. Random numbers are keyed by
(seed, frame, camera, person), so one seed gives the same output bit for bit and two methods'
crops on the same body see the same model errors.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..detections import Detections
from ..errors import InputError
from ..geometry.camera import Rig
from ..poses import Poses2D
from ..skeletons import COCO17
from . import pose_view as V

# COCO keypoint sigmas (pycocotools, COCO keypoint evaluation), COCO-17 order.
COCO_SIGMAS = np.array([.026, .025, .025, .035, .035, .079, .079, .072, .072, .062, .062, .107, .107, .087, .087, .089, .089])
# HRNet-W32 per-joint PCKh@0.5 on MPII test (Sun et al. 2019), COCO-17 order (face joints = head).
_MPII_PCKH = np.array([.986] * 5 + [.969] * 2 + [.928] * 2 + [.890] * 2 + [.915] * 2 + [.890] * 2 + [.857] * 2)
_G = 1.0 / np.sqrt(-2.0 * np.log(1.0 - _MPII_PCKH))
LEGS = np.arange(11, 17)


@dataclass(frozen=True)
class PoseModelParams:
    """Every level of the simulated pose model (defaults: HRNet-W32 256x192; see the module
    docstring for the sources; "assumed" marks levels no published figure fixes)."""

    level: float = 0.0371  #: base std of a shoulder / s; calibrated: OKS-AP 74.4 (HRNet-W32, COCO val)
    level_resolution: float = 0.0139  #: heatmap-resolution term x R; calibrated: AP 66.9 at 128x96 (DARK)
    joint_factor: tuple[float, ...] = tuple(float(v) for v in np.round(_G / _G[5], 3))  #: g_j from HRNet's MPII PCKh per joint
    body_area_m2: float = 0.45  #: COCO segment area of a standing 1.70 m person (~1.7 m x 0.45 m x 0.6 fill), assumed
    input_hw: tuple[int, int] = (256, 192)  #: HRNet-W32's input (Sun et al. 2019)
    crop_fill: float = 0.8  #: the body fills 1/1.25 of the standard crop (Xiao et al. 2018 / HRNet protocol)
    body_grow: float = 0.1  #: joints box -> body box, per side, fraction of its height (head top, feet)
    occluded_noise: float = 1.5  #: occluded joints: error x (1 + this); assumed (COCO v=1 joints are guessed)
    upright_deg: float = 45.0  #: rotation the model trained on (HRNet augmentation +-45 deg)
    rotated_noise: float = 1.0  #: error x (1 + this * rotated), rotated 0..1 (1 = upside down); assumed
    swap_base: float = 0.02  #: whole-body left/right swap per pose, seen from the front; assumed (Ronchi & Perona: a few %)
    swap_back: float = 0.12  #: + this x back-facing (1 = seen straight from behind); assumed
    swap_rotated: float = 0.15  #: + this x rotated; assumed
    legs_swap_base: float = 0.02  #: legs-only swap per pose; assumed
    legs_swap_back: float = 0.06  #: + this x back-facing; assumed
    legs_swap_rotated: float = 0.10  #: + this x rotated; assumed
    score_visible: float = 0.88  #: mean score of a visible joint (HRNet heatmap peaks ~0.7-0.95)
    score_occluded: float = 0.45  #: mean score of a self-occluded joint
    score_outside: float = 0.12  #: mean score of a joint clamped to the crop border
    score_sd: float = 0.05  #: spread of the scores
    score_rotated: float = 0.15  #: score - this x rotated
    score_error: float = 0.04  #: score - this x (squared normalised error - 2) / 2: bad joints score lower
    min_overlap: float = 0.05  #: a crop whose best body overlap is below this holds nobody
    junk_score: tuple[float, float] = (0.02, 0.2)  #: score range of a junk pose (a crop with nobody)

    @property
    def g(self) -> np.ndarray:
        return np.asarray(self.joint_factor, dtype=np.float64)


@dataclass(eq=False)
class PoseModelOutput:
    """:class:`~gymtrack.poses.Poses2D` plus what the simulation knows about each pose (N rows).

    person_id: (N,) the person whose joints the pose shows, -1 = nobody (junk pose);
    occluded: (N, 17) self-occluded joints; outside: (N, 17) joints clamped to the crop;
    swapped: (N,) int8 0 none, 1 whole body, 2 legs; back, rotated: (N,) in [0, 1] (see
    :func:`.pose_view.view_of_body`); tau: (N, 17) the per-coordinate noise std, pixels.
    """

    poses: Poses2D
    person_id: np.ndarray
    occluded: np.ndarray
    outside: np.ndarray
    swapped: np.ndarray
    back: np.ndarray
    rotated: np.ndarray
    tau: np.ndarray


def _check(rig: Rig, joints3d, person_id, frames, boxes: Detections):
    joints3d = np.asarray(joints3d, dtype=np.float64)
    person_id = np.asarray(person_id, dtype=np.int64).reshape(-1)
    frames = np.asarray(frames, dtype=np.int64).reshape(-1)
    if joints3d.ndim != 4 or joints3d.shape[2:] != (17, 3):
        raise InputError(f"joints3d must be (P, T, 17, 3) COCO-17 joints, got {joints3d.shape}", field="joints3d")
    if joints3d.shape[:2] != (person_id.size, frames.size):
        raise InputError(f"joints3d is {joints3d.shape[:2]} (P, T) but there are {person_id.size} person ids and "
                         f"{frames.size} frames", field="joints3d")
    if tuple(boxes.camera_names) != tuple(rig.names):
        raise InputError(f"boxes are of cameras {list(boxes.camera_names)}, the rig has {list(rig.names)}", field="boxes.camera_names")
    if np.any(np.diff(frames) <= 0):
        raise InputError("frames must be strictly increasing", field="frames")
    t_idx = np.clip(np.searchsorted(frames, boxes.frame), 0, max(frames.size - 1, 0))
    bad = frames[t_idx] != boxes.frame if frames.size else np.ones(len(boxes), bool)
    if np.any(bad):
        k = int(np.flatnonzero(bad)[0])
        raise InputError(f"{int(bad.sum())} boxes are at frames without 3D joints, e.g. frame {int(boxes.frame[k])} "
                         f"(joints cover {frames.min() if frames.size else '-'}..{frames.max() if frames.size else '-'})",
                         field="boxes.frame")
    return joints3d, person_id, frames, t_idx


def _scale_and_ratio(rig: Rig, X: np.ndarray, cam: np.ndarray, uv: np.ndarray, crop: np.ndarray,
                     p: PoseModelParams) -> tuple[np.ndarray, np.ndarray]:
    """COCO object scale ``s`` (N,) in pixels and the resolution ratio ``R`` (N,) of each crop."""
    f = np.array([c.K[0, 0] for c in rig])[cam]
    H = V.body_height(X)
    depth = np.empty(len(cam))
    for c, camera in enumerate(rig):
        m = cam == c
        depth[m] = camera.depth(np.nanmean(X[m], axis=1)) if m.any() else 0
    s = f * np.sqrt(p.body_area_m2) * (H / 1.70) / np.maximum(depth, V.MIN_DEPTH)
    bb = V.body_boxes(uv, p.body_grow)
    ih, iw = p.input_hw
    k = np.maximum((crop[:, 2] - crop[:, 0]) / iw, (crop[:, 3] - crop[:, 1]) / ih)  # crop px per input px
    body_in = np.maximum((bb[:, 2] - bb[:, 0]) / iw, (bb[:, 3] - bb[:, 1]) / ih) / np.maximum(k, 1e-9)
    R = np.clip(p.crop_fill / np.maximum(body_in, 1e-6), 0.5, 16.0)
    return s, R


def _noise_std(s, R, occ, rotated, p: PoseModelParams) -> np.ndarray:
    """(N, 17) per-coordinate std in pixels."""
    base = s * np.sqrt(p.level ** 2 + (p.level_resolution * R) ** 2) * (1 + p.rotated_noise * rotated)
    return base[:, None] * p.g[None] * (1 + p.occluded_noise * occ)


def _swaps(u: np.ndarray, back: np.ndarray, rotated: np.ndarray, p: PoseModelParams) -> tuple[np.ndarray, np.ndarray]:
    """(N,) int8 swap kind and (N, 17) joint permutation (output joint j shows body joint perm[j])."""
    p_full = p.swap_base + p.swap_back * back + p.swap_rotated * rotated
    p_legs = p.legs_swap_base + p.legs_swap_back * back + p.legs_swap_rotated * rotated
    full = u[:, 0] < p_full
    legs = ~full & (u[:, 1] < p_legs)
    flip = COCO17.flip
    perm = np.where(full[:, None], flip[None], np.arange(17)[None])
    perm[:, LEGS] = np.where(legs[:, None], flip[LEGS][None], perm[:, LEGS])
    return np.where(full, 1, np.where(legs, 2, 0)).astype(np.int8), perm


def run_pose_model(rig: Rig, joints3d: np.ndarray, person_id: np.ndarray, frames: np.ndarray, boxes: Detections,
                   seed: int = 0, params: PoseModelParams = PoseModelParams()) -> PoseModelOutput:
    """:func:`simulate_pose_model` with what the simulation knows about each pose."""
    p = params
    joints3d, person_id, frames, t_idx = _check(rig, joints3d, person_id, frames, boxes)
    N = len(boxes)
    cam = boxes.camera.astype(np.int64)
    b = boxes.box
    crop = np.column_stack([b[:, 0] - b[:, 2] / 2, b[:, 1] - b[:, 3] / 2, b[:, 0] + b[:, 2] / 2, b[:, 1] + b[:, 3] / 2])
    uv_all, depth_all = V.project_people(rig, joints3d, t_idx, cam)
    prow, _ = V.choose_person(uv_all, depth_all, crop, p.body_grow, p.min_overlap)
    has = prow >= 0
    pid = np.where(has, person_id[np.clip(prow, 0, None)], -1) if person_id.size else np.full(N, -1)
    keys = V.crop_keys(seed, boxes.frame, cam, pid)
    h = np.flatnonzero(has)
    X = joints3d[prow[h], t_idx[h]]  # (n, 17, 3)
    uv = uv_all[h, prow[h]]  # (n, 17, 2)
    centres = rig.centres[cam[h]]
    occ = V.self_occluded(X, centres)
    back, rotated = V.view_of_body(X, centres, uv, p.upright_deg)
    s, R = _scale_and_ratio(rig, X, cam[h], uv, crop[h], p)
    tau = _noise_std(s, R, occ, rotated, p)
    kh = keys[h]
    z = V.normals(kh, 0, 34).reshape(-1, 17, 2)
    meas = uv + z * tau[..., None]
    score = np.where(occ, p.score_occluded, p.score_visible) - p.score_rotated * rotated[:, None]
    score = score + p.score_sd * V.normals(kh, 1, 17) - p.score_error * ((z ** 2).sum(-1) - 2.0) / 2.0
    kind, perm = _swaps(V.uniforms(kh, 2, 2), back, rotated, p)
    meas = np.take_along_axis(meas, perm[..., None], axis=1)
    score = np.take_along_axis(score, perm, axis=1)
    # the heatmap lives in the crop: clamp to its border
    c = crop[h]
    lo, hi = c[:, None, :2], c[:, None, 2:]
    outside = np.any((meas < lo) | (meas > hi), axis=-1)
    meas = np.clip(meas, lo, hi)
    size = np.array([c_.size for c_ in rig], float)[cam[h]][:, None, :]
    off_image = np.any((uv < 0) | (uv > size), axis=-1)  # in the crop's padding: a guess
    score = np.where(outside | off_image, p.score_outside + p.score_sd * V.normals(kh, 3, 17), score)
    missing = ~np.all(np.isfinite(meas), axis=-1)  # a joint the ground truth lacks
    kp = np.full((N, 17, 3), np.nan)
    kp[h, :, :2] = np.where(missing[..., None], np.nan, meas)
    kp[h, :, 2] = np.where(missing, 0.0, np.clip(score, 0.0, 1.0))
    # a crop with nobody: a junk pose anywhere in the crop with low scores
    j = np.flatnonzero(~has)
    if j.size:
        uj = V.uniforms(keys[j], 4, 51).reshape(-1, 17, 3)
        cj = crop[j][:, None]
        kp[j, :, 0] = cj[..., 0] + uj[..., 0] * (cj[..., 2] - cj[..., 0])
        kp[j, :, 1] = cj[..., 1] + uj[..., 1] * (cj[..., 3] - cj[..., 1])
        kp[j, :, 2] = p.junk_score[0] + uj[..., 2] * (p.junk_score[1] - p.junk_score[0])
    bbox = np.column_stack([crop[:, 0], crop[:, 1], b[:, 2], b[:, 3]])
    poses = Poses2D(boxes.frame.copy(), cam, boxes.track_id.copy(), kp, bbox, COCO17, tuple(rig.names))

    def full(a, fill, dtype):
        out = np.full((N,) + a.shape[1:], fill, dtype)
        out[h] = a
        return out

    return PoseModelOutput(poses, pid.astype(np.int64), full(occ, False, bool), full(outside, False, bool),
                           full(kind, 0, np.int8), full(back, np.nan, float), full(rotated, np.nan, float),
                           full(tau, np.nan, float))


def simulate_pose_model(rig: Rig, joints3d: np.ndarray, person_id: np.ndarray, frames: np.ndarray, boxes: Detections,
                        seed: int = 0, params: PoseModelParams = PoseModelParams()) -> Poses2D:
    """Run the simulated top-down pose model on every box (crop).

    rig: the cameras (C); joints3d: (P, T, 17, 3) COCO-17 world joints of every person (NaN where
    absent); person_id: (P,); frames: (T,) the frame numbers; boxes: the crops, centre-form
    ``[x, y, w, h]`` raw pixels, ``track_id`` the 3D track they belong to, cameras named as the rig.

    Returns one pose per box, in the boxes' order: ``track_id`` copied, ``bbox`` the crop
    ``[left, top, w, h]``, COCO-17 keypoints ``[x, y, score]`` in raw pixels. No box, no pose.
    Raises InputError for mismatched shapes, cameras or boxes at frames without joints.
    """
    return run_pose_model(rig, joints3d, person_id, frames, boxes, seed, params).poses


def simulate_pose_model_for_routine(routine, boxes: Detections, seed: int = 0,
                                    params: PoseModelParams = PoseModelParams()) -> Poses2D:
    """:func:`simulate_pose_model` for a :class:`~gymtrack.simulate.SimulatedRoutine` or a
    simulated routine folder (``cameras.yaml`` and ``gt/keypoints_3d.csv``, every person)."""
    if isinstance(routine, (str, Path)):
        from ..formats.calibration import read_native
        from ..formats.gt_keypoints import read_keypoints_3d

        folder = Path(routine)
        rig = read_native(folder / "cameras.yaml")
        frames, pid, joints = read_keypoints_3d(folder / "gt" / "keypoints_3d.csv")
        return simulate_pose_model(rig, joints, pid, frames, boxes, seed, params)
    return simulate_pose_model(routine.rig, routine.keypoints, routine.person_id, routine.frames, boxes, seed, params)


def coco_oks_ap(params: PoseModelParams = PoseModelParams(), resolution_ratio: float = 1.0, n: int = 20000, seed: int = 0) -> float:
    """The COCO OKS-AP this noise model scores on upright, front-facing, unoccluded people in a
    crop with resolution ratio ``R``: the calibration of ``level`` and ``level_resolution``.

    AP is approximated by the share of poses with OKS above each threshold 0.50:0.05:0.95,
    averaged (one detection per person; the detector's part of AP is left out). The body is the
    standing pose of :mod:`.body` seen from the front, in units of the object scale ``s``; swaps
    at the front-facing rates cost what they cost on it.
    """
    from . import body as B

    rng = np.random.default_rng(seed)
    bm = B.BodyModel(1.70)
    P = bm.local_points(B.posture_angles(B.STAND)[None])[0, :17]
    uv = P[:, 1:] / np.sqrt(params.body_area_m2)  # frontal view, units of s
    tau = np.sqrt(params.level ** 2 + (params.level_resolution * resolution_ratio) ** 2) * params.g
    err = rng.standard_normal((n, 17, 2)) * tau[None, :, None]
    kind, perm = _swaps(rng.random((n, 2)), np.zeros(n), np.zeros(n), params)
    meas = uv[perm] + np.take_along_axis(err, perm[..., None], axis=1)
    d2 = ((meas - uv[None]) ** 2).sum(-1)
    oks = np.exp(-d2 / (2 * (2 * COCO_SIGMAS) ** 2)).mean(axis=1)
    return float(np.mean([(oks > t).mean() for t in np.arange(0.50, 0.951, 0.05)]))
