"""Pose metrics of the target gymnast: MPJPE, PA-MPJPE, PCK and the share of frames with a pose.

Paper: Fig. 7 and Section III-D argue that a better track gives a better 3D pose; these metrics
measure that pose against the simulator's ``gt/keypoints_3d.csv`` (COCO-17 joints). The usual
3D human pose definitions (Human3.6M / MPI-INF-3DHP protocols):

* **MPJPE** (mm): mean Euclidean distance over (frame, joint) pairs where both the estimate and
  the ground truth have the joint.
* **PA-MPJPE** (mm): the same after aligning each frame's estimate to its ground truth by a
  similarity transform (rotation, translation and scale; Umeyama's least-squares solution, no
  reflection) over the joints both have; frames with fewer than 3 such joints are left out.
* **PCK@150 mm**: share of ground-truth joints (in the evaluated frames, i.e. the performing
  frames where the output has a pose) whose estimate lies within 150 mm; a joint the output
  did not estimate counts as a miss. **PCK@150 over all frames** (``pck_all``): the same over
  the ground-truth joints of *every* performing frame, so a frame without a pose is all misses:
  the one figure that a method cannot improve by declining hard frames.
* **pose share**: share of the target's performing frames where the output has a pose (at least
  one joint estimated).

* **Common-frame MPJPE** (:func:`common_error`): two outputs' MPJPE over the (frame, joint)
  pairs *both* estimated. Each output's own MPJPE averages over its own frames, and one that
  gives a pose on fewer frames averages over easier ones; comparing two methods' own MPJPE is
  then not like for like. :func:`joint_errors` gives the per-frame, per-joint errors it needs.

Joints are compared by name: the estimate's skeleton is mapped onto the ground truth's joint
names, and joints the estimate's skeleton lacks are not evaluated (PCK included).

:class:`PoseError` holds the additive parts (sums and counts) so that a benchmark can pool
routines exactly; its properties give the means.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, replace
from typing import Sequence

import numpy as np

__all__ = ["PCK_THRESHOLD_M", "PoseError", "CommonError", "procrustes_align", "pose_error", "joint_map",
           "target_pose_error", "joint_errors", "common_error"]

PCK_THRESHOLD_M = 0.150


@dataclass(frozen=True)
class PoseError:
    """Additive parts of the pose metrics (distances in millimetres).

    mpjpe_sum, mpjpe_n: summed joint error and (frame, joint) pairs;
    pa_sum, pa_n: summed Procrustes-aligned joint error and pairs (frames with >= 3 joints);
    pck_hits, pck_joints: GT joints within the threshold, and GT joints evaluated;
    pose_frames, frames: performing frames with an output pose, and performing frames;
    gt_joints_all: GT joints over every performing frame (``pck_all``'s denominator).
    """

    mpjpe_sum: float = 0.0
    mpjpe_n: int = 0
    pa_sum: float = 0.0
    pa_n: int = 0
    pck_hits: int = 0
    pck_joints: int = 0
    pose_frames: int = 0
    frames: int = 0
    gt_joints_all: int = 0

    @property
    def mpjpe(self) -> float:
        return self.mpjpe_sum / self.mpjpe_n if self.mpjpe_n else float("nan")

    @property
    def pa_mpjpe(self) -> float:
        return self.pa_sum / self.pa_n if self.pa_n else float("nan")

    @property
    def pck(self) -> float:
        return self.pck_hits / self.pck_joints if self.pck_joints else float("nan")

    @property
    def pck_all(self) -> float:
        """PCK over every performing frame's GT joints: a frame without a pose counts as misses."""
        return self.pck_hits / self.gt_joints_all if self.gt_joints_all else float("nan")

    @property
    def pose_share(self) -> float:
        return self.pose_frames / self.frames if self.frames else float("nan")

    def __add__(self, other: "PoseError") -> "PoseError":
        return PoseError(**{k: v + getattr(other, k) for k, v in asdict(self).items()})

    def as_dict(self) -> dict:
        return asdict(self)


def procrustes_align(pred: np.ndarray, gt: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Align each frame's ``pred`` to ``gt`` by a similarity transform over its ``valid`` joints.

    pred, gt: (F, J, 3); valid: (F, J) bool (frames need >= 3 valid joints, others give NaN).
    Returns (F, J, 3) the aligned prediction (Umeyama 1991: R, s, t minimising
    ``sum ||s R p + t - g||^2``, det R = +1).
    """
    pred = np.asarray(pred, np.float64)
    gt = np.asarray(gt, np.float64)
    w = valid.astype(np.float64)[..., None]
    n = w.sum(axis=1)  # (F, 1)
    nn = np.maximum(n, 1.0)
    p0 = np.where(valid[..., None], pred, 0.0)
    g0 = np.where(valid[..., None], gt, 0.0)
    mp = (p0 * w).sum(axis=1) / nn
    mg = (g0 * w).sum(axis=1) / nn
    pc = (p0 - mp[:, None]) * w
    gc = (g0 - mg[:, None]) * w
    cov = np.einsum("fji,fjk->fik", gc, pc) / nn[:, :, None]  # (F, 3, 3) = sum g p^T / n
    u, sig, vt = np.linalg.svd(cov)
    d = np.sign(np.linalg.det(u @ vt))
    d = np.where(d == 0, 1.0, d)
    fix = np.ones((len(pred), 3))
    fix[:, 2] = d
    r = u @ (fix[:, :, None] * vt)
    var_p = (pc ** 2).sum(axis=(1, 2)) / nn[:, 0]
    s = (sig * fix).sum(axis=1) / np.where(var_p > 0, var_p, 1.0)
    t = mg - s[:, None] * np.einsum("fik,fk->fi", r, mp)
    out = s[:, None, None] * np.einsum("fik,fjk->fji", r, pred) + t[:, None, :]
    out[n[:, 0] < 3] = np.nan
    return out


def pose_error(pred: np.ndarray, gt: np.ndarray, frames: int | None = None, threshold: float = PCK_THRESHOLD_M) -> PoseError:
    """The pose metrics of matched frames.

    pred: (F, J, 3) estimated joints, metres, NaN = not estimated; gt: (F, J, 3) true joints,
    metres, NaN = absent, joints in the same order. Every row of ``pred`` is a frame where the
    output has a pose. frames: performing frames (for the pose share; default F).
    """
    pred = np.asarray(pred, np.float64)
    gt = np.asarray(gt, np.float64)
    if pred.shape != gt.shape or pred.ndim != 3 or pred.shape[2] != 3:
        raise ValueError(f"pred and gt must both be (F, J, 3), got {pred.shape} and {gt.shape}")
    has_p = np.all(np.isfinite(pred), axis=-1)
    has_g = np.all(np.isfinite(gt), axis=-1)
    both = has_p & has_g
    d = np.linalg.norm(np.where(both[..., None], pred - gt, 0.0), axis=-1)
    aligned = procrustes_align(pred, gt, both)
    pa_ok = both & np.isfinite(aligned).all(axis=-1)
    da = np.linalg.norm(np.where(pa_ok[..., None], aligned - gt, 0.0), axis=-1)
    pose_frames = int(np.count_nonzero(has_p.any(axis=1)))
    return PoseError(
        mpjpe_sum=float(1000.0 * d[both].sum()), mpjpe_n=int(both.sum()),
        pa_sum=float(1000.0 * da[pa_ok].sum()), pa_n=int(pa_ok.sum()),
        pck_hits=int(np.count_nonzero(both & (d <= threshold))), pck_joints=int(has_g.sum()),
        pose_frames=pose_frames, frames=int(len(pred) if frames is None else frames),
    )


def joint_map(pred_joints: Sequence[str], gt_joints: Sequence[str]) -> tuple[np.ndarray, np.ndarray]:
    """``(pi, gi)``: index pairs of the joints both skeletons name (by name, GT order)."""
    pos = {n: k for k, n in enumerate(pred_joints)}
    pairs = [(pos[n], g) for g, n in enumerate(gt_joints) if n in pos]
    if not pairs:
        return np.zeros(0, np.int64), np.zeros(0, np.int64)
    pi, gi = zip(*pairs)
    return np.asarray(pi, np.int64), np.asarray(gi, np.int64)


def target_pose_error(pose_frame: np.ndarray, pose_xyz: np.ndarray, pose_joints: Sequence[str],
                      gt_frames: np.ndarray, gt_xyz: np.ndarray, gt_joints: Sequence[str],
                      perf_frames: np.ndarray, threshold: float = PCK_THRESHOLD_M) -> PoseError:
    """The target's pose metrics on its performing frames.

    pose_frame: (M,) frames of the output target pose (one row per frame at most);
    pose_xyz: (M, J, 3) metres, NaN = not estimated, joints named ``pose_joints``;
    gt_frames: (T,) frames of the ground truth; gt_xyz: (T, G, 3) the target's true joints
    (NaN = absent), named ``gt_joints``; perf_frames: the target's performing frames.
    """
    pose_frame = np.asarray(pose_frame, np.int64)
    if np.unique(pose_frame).size != pose_frame.size:
        raise ValueError("the target pose has more than one row for a frame")
    gt_frames = np.asarray(gt_frames, np.int64)
    perf = np.intersect1d(np.asarray(perf_frames, np.int64), gt_frames)
    pi, gi = joint_map(pose_joints, gt_joints)
    rows = np.flatnonzero(np.isin(pose_frame, perf))
    pred = np.asarray(pose_xyz, np.float64)[rows][:, pi]
    has = np.all(np.isfinite(pred), axis=-1).any(axis=1)
    rows, pred = rows[has], pred[has]
    gt = np.asarray(gt_xyz, np.float64)[_gt_rows(gt_frames, pose_frame[rows])][:, gi]
    e = pose_error(pred, gt, frames=perf.size, threshold=threshold)
    all_gt = np.asarray(gt_xyz, np.float64)[_gt_rows(gt_frames, perf)][:, gi]
    return replace(e, gt_joints_all=int(np.all(np.isfinite(all_gt), axis=-1).sum()))


def _gt_rows(gt_frames: np.ndarray, frames: np.ndarray) -> np.ndarray:
    if np.all(np.diff(gt_frames) > 0):
        return np.searchsorted(gt_frames, frames)
    return np.array([np.flatnonzero(gt_frames == f)[0] for f in frames], np.int64)


def joint_errors(pose_frame: np.ndarray, pose_xyz: np.ndarray, pose_joints: Sequence[str], gt_frames: np.ndarray,
                 gt_xyz: np.ndarray, gt_joints: Sequence[str], perf_frames: np.ndarray) -> np.ndarray:
    """(F, G) millimetres: the error of each ground-truth joint (G, ``gt_joints`` order) on each
    performing frame (F, sorted, those the ground truth has); NaN where the output did not
    estimate it, the ground truth lacks it, or the output has no row for that frame.
    Arguments as :func:`target_pose_error`."""
    pose_frame = np.asarray(pose_frame, np.int64)
    gt_frames = np.asarray(gt_frames, np.int64)
    perf = np.intersect1d(np.asarray(perf_frames, np.int64), gt_frames)
    pi, gi = joint_map(pose_joints, gt_joints)
    G = len(gt_joints)
    pred = np.full((perf.size, G, 3), np.nan)
    o = np.argsort(pose_frame, kind="stable")
    k = np.clip(np.searchsorted(pose_frame[o], perf), 0, max(len(o) - 1, 0))
    hit = (pose_frame[o][k] == perf) if len(o) else np.zeros(perf.size, bool)
    pred[np.ix_(np.flatnonzero(hit), gi)] = np.asarray(pose_xyz, np.float64)[o[k[hit]]][:, pi]
    gt = np.asarray(gt_xyz, np.float64)[_gt_rows(gt_frames, perf)]
    return 1000.0 * np.linalg.norm(pred - gt, axis=-1)


@dataclass(frozen=True)
class CommonError:
    """Additive parts of two outputs' MPJPE over the (frame, joint) pairs both estimated (mm).

    a_sum, b_sum: summed errors of output a and b; n: the common pairs; frames: frames where both
    have a pose. ``a`` and ``b`` are their MPJPEs, ``ratio`` = a / b (like for like).
    """

    a_sum: float = 0.0
    b_sum: float = 0.0
    n: int = 0
    frames: int = 0

    @property
    def a(self) -> float:
        return self.a_sum / self.n if self.n else float("nan")

    @property
    def b(self) -> float:
        return self.b_sum / self.n if self.n else float("nan")

    def __add__(self, other: "CommonError") -> "CommonError":
        return CommonError(**{k: v + getattr(other, k) for k, v in asdict(self).items()})

    def as_dict(self) -> dict:
        return asdict(self)


def common_error(err_a: np.ndarray, err_b: np.ndarray) -> CommonError:
    """The common-frame MPJPE parts of two :func:`joint_errors` arrays (F, G) of the same frames."""
    err_a, err_b = np.asarray(err_a, np.float64), np.asarray(err_b, np.float64)
    if err_a.shape != err_b.shape:
        raise ValueError(f"the two outputs' errors must be over the same frames and joints, got {err_a.shape} and {err_b.shape}")
    both = np.isfinite(err_a) & np.isfinite(err_b)
    frames = np.isfinite(err_a).any(axis=1) & np.isfinite(err_b).any(axis=1)
    return CommonError(float(err_a[both].sum()), float(err_b[both].sum()), int(both.sum()), int(frames.sum()))
