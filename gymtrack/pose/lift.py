"""3D lifting of one track's multi-view 2D poses: the paper's DLT, and a robust lifting beyond it.

Paper: Section III-D, last paragraph of "Identify Target Gymnast for Pose Estimation": the 2D
poses a top-down model (HRNet) finds in each view's expanded box ``b_buf`` are triangulated
with Eq. 3. ``method="dlt"`` is exactly that, per joint over the views that found it.
``method="robust"`` (the default) goes beyond the paper, in this order:

1. confidence-weighted DLT (:mod:`.dlt`): a view's rows weigh its 2D score over the pose's box
   size (the pixel noise of a top-down model scales with its crop); the all-view solution gives
   each joint's 2D noise level on this track (:func:`noise_level`), and the gate a view must
   meet is a multiple of it (it follows the pose model's noise, the joint's difficulty and the
   calibration's own error; a fixed share of the box rejected a third of the good views);
2. views whose torso shows another body are set aside (:mod:`.identity`; every track lifted); a
   per-frame consensus (:mod:`.consensus`) drops views whose reprojection disagrees and reads a view with left and
   right exchanged -- whole body or legs only -- where that fits clearly better; where no two
   views agree, every view is kept (flagged, low score): robust never estimates fewer joints
   than ``dlt`` because the consensus failed;
3. per joint, the worst view is dropped when its reprojection exceeds the gate (3+ views);
4. the cascade for joints (:mod:`.anchor`): a joint seen by one view, or only by an opposite
   pair, is anchored on the plane through the target's centre parallel to the apparatus
   plane (given ``centre`` and ``plane_normal``), fused with its rays by their uncertainty (the
   plane prior's spread per joint measured on the track where wider than configured);
5. per-track bone lengths (median over well-observed frames) pull weak joints along their
   line of sight (:func:`.anchor.pull_to_bones`); where views disagree or one alone sees a
   joint, the views that agree with the track's neighbouring frames decide (:mod:`.temporal`);
6. temporal smoothing that keeps flight phases sharp (:mod:`.smooth`).

Shapes: T frames, C cameras (the rig's order), J joints. Input keypoints (T, C, J, 3) raw
(distorted) pixels ``[x, y, score]``; outputs (T, J[, 3]). Internally (C, J, T), batch-last.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass, field, fields

import numpy as np

from ..errors import InputError
from ..geometry import Rig
from ..geometry.triangulation import triangulate_views
from ..poses import HOW_FUSED, HOW_NONE, HOW_PLANE, HOW_TRIANGULATED, Poses3D
from ..skeletons import Skeleton
from .anchor import anchor_on_plane, bone_lengths, given_lengths, lines_of_sight, opposite_only, plane_spread, pull_to_bones
from .consensus import leg_joints, settle_ties, view_consensus
from .identity import TorsoIdentity, torso_views
from .dlt import gauss_newton, residuals, weighted_dlt
from .limb_check import LimbCheck, check_arms
from .smooth import smooth_track
from .temporal import TemporalPrior, apply_prior

METHODS = ("dlt", "robust")


@dataclass(frozen=True)
class LiftOptions:
    """Thresholds of the lifting, each with its trade-off.

    min_score: 2D keypoints scored at or below are "not found". Higher drops more wrong joints
        and more right ones (HRNet scores fall to ~0.3 on occluded joints).
    gate_sigmas, gate_frac, gate_min_px: a view disagrees on a joint when its reprojection
        error exceeds ``max(gate_min_px, box * max(gate_frac, gate_sigmas * sigma_j))``, box = the
        larger side of the pose's keypoint extent in that view, ``sigma_j`` the joint's pixel
        noise over the box *measured on this track* (:func:`noise_level`: the residuals of the
        all-view solution, so the gate follows the pose model's noise, the joint's difficulty and
        the calibration's own error). Lower rejects more noise and more good views; a fixed
        share of the box (the floor) rejected a third of the good views of hard poses.
    noise_frac: ``sigma`` of every joint given instead of measured (0 = measure on the track):
        for tracks too short to measure it on (single snapshots), from :func:`.snapshots.measure_noise`
        over many of them.
    flip_ratio: a view is read left/right-swapped when that brings its lateral joints' error
        below this share of the unswapped error. Lower = only clear swaps (a 3/4 view of a
        narrow body looks alike both ways).
    inlier_error: a view agrees with a consensus hypothesis when its mean gate-normalised,
        capped error is below this.
    min_common: joints a hypothesis and a view must share for the view to be judged at all.
    refine_iterations: Gauss-Newton steps of the robust lifting; dlt_refine: of ``dlt``
        (Eq. 3 is the reprojection error, the DLT only its linear start).
    opposite_angle_deg: two views whose lines of sight meet above this are an opposite pair
        (the scene's default); a joint seen only by them goes to the plane.
    plane_sigma_m: the plane prior's standard deviation along its normal, at least: the body's
        joints lie within ~0.3-0.5 m of the plane through its centre; each joint's prior is its
        spread measured on the track where larger (:func:`.anchor.plane_spread`: a pommel horse
        circle sweeps the legs across the plane). Smaller trusts the plane more.
    pixel_sigma_frac: a keypoint's pixel noise as a share of the box (top-down models: ~2-5 %);
        it sets the rays' weight against the plane.
    min_plane_cos: a lone ray this close to parallel to the plane (|cos| to the normal) gets no
        plane point (the intersection runs off to infinity).
    bone_iterations, bone_weight, bone_min_frames: passes of the bone-length pull, the share of
        the way a weak joint moves per pass, and the strong frames a bone needs for its length.
    smooth_half_window: frames each side of the quadratic smoother (0 = off); longer smooths
        more and follows sudden changes (a hand's catch) later. smooth_outlier_m: a joint
        farther than this from its neighbours' fit is replaced by it.
    plane_score_factor: score multiplier of plane-anchored and fused joints (their depth is a
        prior, not a measurement).
    fallback_score_factor: score multiplier of a frame where no two views agreed: it keeps the
        confidence-weighted all-view solution (never fewer joints than ``dlt``), flagged.
    decline_disagreeing, bone_lengths_m: for snapshots (:mod:`.snapshots`): such a frame gives no
        joint (``joints_declined``); bone lengths (per ``skeleton.bones``, NaN = unknown) where the
        track is too short to measure its own.
    """

    min_score: float = 0.2
    gate_sigmas: float = 6.0
    gate_frac: float = 0.04
    noise_frac: float = 0.0
    gate_min_px: float = 4.0
    flip_ratio: float = 0.6
    inlier_error: float = 0.5
    min_common: int = 3
    refine_iterations: int = 2
    dlt_refine: int = 1
    opposite_angle_deg: float = 150.0
    plane_sigma_m: float = 0.25
    pixel_sigma_frac: float = 0.03
    min_plane_cos: float = 0.15
    bone_iterations: int = 3
    bone_weight: float = 0.7
    bone_min_frames: int = 5
    smooth_half_window: int = 2
    smooth_outlier_m: float = 0.15
    plane_score_factor: float = 0.5
    fallback_score_factor: float = 0.3
    decline_disagreeing: bool = False
    bone_lengths_m: tuple[float, ...] | None = None
    arms: LimbCheck | None = None  #: arms against the track's bones and motion (:mod:`.limb_check`); None = off
    temporal: TemporalPrior | None = TemporalPrior()  #: doubtful joints by the track's neighbouring frames (:mod:`.temporal`)
    identity: TorsoIdentity | None = None  #: views showing another body set aside first (:mod:`.identity`); the stage's all-tracks default

    def __post_init__(self) -> None:
        for f in fields(self):
            val = getattr(self, f.name)
            if f.name in ("arms", "temporal", "identity", "decline_disagreeing", "bone_lengths_m"):
                continue
            if isinstance(val, bool) or not isinstance(val, (int, float)) or not np.isfinite(val) or val < 0:
                raise InputError(f"must be a finite number >= 0, got {val!r}", source="LiftOptions", field=f.name)
        if not 0 < self.flip_ratio <= 1:
            raise InputError(f"must be in (0, 1], got {self.flip_ratio}", source="LiftOptions", field="flip_ratio")
        if not 90 < self.opposite_angle_deg <= 180:
            raise InputError(f"must be in (90, 180], got {self.opposite_angle_deg}", source="LiftOptions",
                             field="opposite_angle_deg")
        if self.plane_sigma_m <= 0 or self.pixel_sigma_frac <= 0:
            raise InputError("plane_sigma_m and pixel_sigma_frac must be > 0", source="LiftOptions",
                             field="plane_sigma_m" if self.plane_sigma_m <= 0 else "pixel_sigma_frac")


@dataclass(eq=False)
class Lifted:
    """One track's 3D skeleton per frame, dense over its T frames.

    xyz (T, J, 3) world metres, NaN = not estimated; score (T, J) in [0, 1]; n_views (T, J)
    views that contributed; reproj_px (T, J) their mean reprojection error (undistorted pixels,
    NaN if none); how (T, J) int8 ``gymtrack.poses.HOW_*``; counts: what the lifting did
    (``views_dropped``, ``views_swapped``, ``views_legs_swapped``, ``frames_fallback`` (no two
    views agreed: all kept), ``joints_fallback``, ``frames_relabelled``, ``joint_views_dropped``,
    ``joints_plane``, ``joints_fused``, ``joints_bone_pulled``, ``joints_smoothed_outliers``,
    ``joints_unobservable`` (weak, no position), ``views_foreign``); foreign (T, C): views set aside (:mod:`.identity`).
    """

    xyz: np.ndarray
    score: np.ndarray
    n_views: np.ndarray
    reproj_px: np.ndarray
    how: np.ndarray
    counts: dict[str, int] = field(default_factory=dict)
    foreign: np.ndarray | None = None

    def __len__(self) -> int:
        return len(self.xyz)

    def to_poses3d(self, frames: np.ndarray, track_id: int, skeleton: Skeleton) -> Poses3D:
        """Rows of :class:`gymtrack.poses.Poses3D` for ``frames`` (T,), one per frame with any joint."""
        keep = np.isfinite(self.xyz).all(axis=2).any(axis=1)
        n = int(keep.sum())
        return Poses3D(frame=np.asarray(frames, np.int64)[keep], track_id=np.full(n, track_id, np.int64),
                       xyz=self.xyz[keep], score=self.score[keep], n_views=self.n_views[keep],
                       reproj_px=self.reproj_px[keep], how=self.how[keep], skeleton=skeleton)


def _check(rig, keypoints, skeleton, method, centre, plane_normal, options):
    if not isinstance(rig, Rig):
        raise InputError(f"rig must be a gymtrack.geometry.Rig, got {type(rig).__name__}", field="rig")
    if method not in METHODS:
        raise InputError(f"unknown lifting method {method!r}; use one of {list(METHODS)}", field="method")
    if not isinstance(options, LiftOptions):
        raise InputError(f"options must be LiftOptions, got {type(options).__name__}", field="options")
    kp = np.asarray(keypoints, dtype=np.float64)
    J = len(skeleton.joints)
    if kp.ndim != 4 or kp.shape[1:] != (len(rig), J, 3):
        raise InputError(f"keypoints must be (T, C={len(rig)}, J={J}, 3) [x, y, score] for {len(rig)} cameras and "
                         f"the {skeleton.name} skeleton's {J} joints, got shape {kp.shape}", field="keypoints")
    score = kp[..., 2]
    bad = np.isfinite(score) & (score < 0)
    if bad.any():
        t, c, j = np.argwhere(bad)[0]
        raise InputError(f"scores must be >= 0; {int(bad.sum())} are not, first at frame index {t}, camera "
                         f"{rig[int(c)].name}, joint {skeleton.joints[j]}: {score[t, c, j]}", field="keypoints")
    # real tools write a little above 1 (OpenPose's heatmap peaks): a weight, so clip (counted by the caller)
    if np.nanmax(score, initial=0.0) > 1:
        kp = kp.copy()
        kp[..., 2] = np.minimum(score, 1.0)
    if (centre is None) != (plane_normal is None):
        raise InputError("plane anchoring needs both centre and plane_normal (or neither)",
                         field="centre" if centre is None else "plane_normal")
    if centre is not None:
        centre = np.asarray(centre, dtype=np.float64)
        if centre.shape != (kp.shape[0], 3):
            raise InputError(f"centre must be (T={kp.shape[0]}, 3), got {centre.shape}", field="centre")
        n = np.asarray(plane_normal, dtype=np.float64)
        norm = np.linalg.norm(n) if n.shape == (3,) else np.nan
        if not np.isfinite(norm) or norm < 1e-9:
            raise InputError(f"plane_normal must be a finite non-zero (3,) vector, got {plane_normal!r}",
                             field="plane_normal")
        plane_normal = n / norm
    return kp, centre, plane_normal


def lift_track(rig: Rig, keypoints: np.ndarray, skeleton: Skeleton, method: str = "robust",
               centre: np.ndarray | None = None, plane_normal: np.ndarray | None = None,
               options: LiftOptions = LiftOptions()) -> Lifted:
    """Lift one track's 2D poses to 3D.

    Parameters
    ----------
    rig: the calibrated cameras, in the order of ``keypoints``' camera axis.
    keypoints: (T, C, J, 3) raw pixels ``[x, y, score]``; NaN or score <= ``min_score`` = missing.
    skeleton: the joints' skeleton (J joints; ``flip`` and ``bones`` are used by ``robust``).
    method: ``"dlt"`` (paper Eq. 3 per joint, unweighted) or ``"robust"`` (see the module doc).
    centre: (T, 3) the track's 3D centre (NaN where unknown); plane_normal: (3,) the normal of
        the apparatus plane nearest the target. Both or neither; only ``robust`` uses them.
    options: thresholds (:class:`LiftOptions`).
    """
    kp, centre, normal = _check(rig, keypoints, skeleton, method, centre, plane_normal, options)
    T, C, J = kp.shape[:3]
    u, v, ok, sc = _prepare(rig, kp, options)
    P = rig.projections
    if method == "dlt":
        X, _ = triangulate_views(P, u.reshape(C, -1), v.reshape(C, -1), ok.reshape(C, -1), options.dlt_refine)
        X3 = X.reshape(3, J, T).transpose(2, 1, 0)
        how = np.where(np.isfinite(X3).all(axis=2), HOW_TRIANGULATED, HOW_NONE).astype(np.int8)
        box = _box_size(u, v, ok)
        sigma = noise_level(P, X.reshape(3, -1), u, v, ok.reshape(C, -1).astype(np.float64), box)
        return _finish(P, X3, u, v, ok, sc, how, _gate(box, sigma, options), options, {})
    return _robust(rig, P, u, v, ok, sc, skeleton, centre, normal, options)


def _prepare(rig, kp, options):
    """Undistorted pixels u, v, found mask and scores, each (C, J, T), of keypoints (T, C, J, 3)."""
    score = np.nan_to_num(kp[..., 2], nan=0.0)
    found = np.isfinite(kp[..., :2]).all(axis=3) & (score > options.min_score)
    uv = np.stack([cam.undistort(kp[:, c, :, :2]) for c, cam in enumerate(rig)], axis=1)
    found &= np.isfinite(uv).all(axis=3)
    u, v = (np.ascontiguousarray(uv[..., k].transpose(1, 2, 0)) for k in (0, 1))  # (C, J, T)
    return u, v, found.transpose(1, 2, 0), score.transpose(1, 2, 0)


def _box_size(u, v, ok):
    """(C, T) larger side of the found keypoints' extent per view and frame (the crop's scale)."""
    with np.errstate(invalid="ignore"):
        lo_u, hi_u = np.where(ok, u, np.inf).min(axis=1), np.where(ok, u, -np.inf).max(axis=1)
        lo_v, hi_v = np.where(ok, v, np.inf).min(axis=1), np.where(ok, v, -np.inf).max(axis=1)
    size = np.maximum(hi_u - lo_u, hi_v - lo_v)
    size = np.where((ok.sum(axis=1) >= 2) & np.isfinite(size) & (size > 0), size, np.nan)
    fallback = np.nanmedian(size) if np.isfinite(size).any() else 100.0
    return np.where(np.isfinite(size), size, fallback)


def noise_level(P: np.ndarray, X: np.ndarray, u: np.ndarray, v: np.ndarray, w: np.ndarray, box: np.ndarray,
                min_samples: int = 20, max_ratio: float = 2.5) -> np.ndarray:
    """(J,) each joint's 2D noise (std per coordinate) as a share of the box, measured on the track.

    From the reprojection residuals of X (3, J T) -- e.g. the confidence-weighted all-view
    solution -- in the views with w (C, J T) > 0; box (C, T). A point fit to n views keeps
    ``(2n - 3) / 2n`` of its 2n squared-noise degrees of freedom in the residuals, so residuals
    are scaled back by that; the median of the 2D residual over 1.1774 is the std per coordinate
    (Rayleigh), robust to up to half the samples being outliers (wrong bodies, swaps). A joint
    with fewer than ``min_samples`` samples takes the pooled value of all joints; 0 without any.
    A joint's value stays within ``max_ratio`` of the pooled one: a joint one view gets wrong in
    every frame must not widen its own gate (HRNet's hardest joint, the ankle, is ~1.7 x the
    shoulder's error; occlusion adds more).
    """
    C, J, T = u.shape
    r = residuals(P, X, u.reshape(C, -1), v.reshape(C, -1)).reshape(C, J, T) / box[:, None, :]
    use = (w.reshape(C, J, T) > 0) & np.isfinite(r)
    n = use.sum(axis=0)
    keep = use & (n >= 2)[None]
    dof = np.sqrt(np.maximum(2 * n - 3, 0) / np.maximum(2 * n, 1))
    z = np.where(keep, r / np.where(dof > 0, dof, 1.0)[None], np.nan).transpose(1, 0, 2).reshape(J, -1)
    count = keep.sum(axis=(0, 2))
    if not count.sum():
        return np.zeros(J)
    pooled = float(np.nanmedian(z)) / 1.1774
    with warnings.catch_warnings():  # joints never seen twice: NaN, replaced below
        warnings.simplefilter("ignore", RuntimeWarning)
        per_joint = np.nanmedian(z, axis=1) / 1.1774
    return np.where(count >= min_samples, np.clip(per_joint, pooled / max_ratio, pooled * max_ratio), pooled)


def _gate(box, sigma, options):
    """(C, J, T) pixels: the reprojection error above which a view disagrees on a joint."""
    frac = np.maximum(options.gate_frac, options.gate_sigmas * np.nan_to_num(sigma))
    return np.maximum(options.gate_min_px, box[:, None, :] * frac[None, :, None])


def _all_views(P, u, v, ok, sc, box, opt):
    """The confidence-weighted solution over every view (3, J T), its weights (C, J T) and the
    joints' noise level (J,): the reference the gate is measured on, and the fallback."""
    C = u.shape[0]
    w = np.where(ok, sc / box[:, None, :], 0.0).reshape(C, -1)
    uf, vf = u.reshape(C, -1), v.reshape(C, -1)
    X = gauss_newton(P, weighted_dlt(P, uf, vf, w), uf, vf, w, opt.refine_iterations)
    sigma = np.full(u.shape[1], opt.noise_frac) if opt.noise_frac > 0 else noise_level(P, X, u, v, w, box)
    return X, w, sigma


def _robust(rig, P, u, v, ok, sc, skeleton, centre, normal, opt) -> Lifted:
    C, J, T = u.shape
    flip = np.asarray(skeleton.flip, dtype=np.int64)
    box = _box_size(u, v, ok)
    mine = torso_views(P, u, v, ok, box, list(skeleton.joints), opt.identity)  # a neighbour's pose: set aside
    foreign, ok = ok.any(axis=1) & ~mine, ok & mine[:, None, :]
    X_all, w_all, sigma = _all_views(P, u, v, ok, sc, box, opt)
    gate = _gate(box, sigma, opt)
    legs = leg_joints(skeleton)
    cons = view_consensus(P, u, v, ok, gate, flip, opt.flip_ratio, opt.inlier_error, opt.min_common, legs)
    present = ok.any(axis=1)
    # no two views agreed (e.g. two views of different bodies): keep them all, flagged, rather
    # than give nothing -- robust never estimates fewer joints than dlt because consensus failed
    fallback = ((cons.keep & present).sum(axis=0) < 2) & (present.sum(axis=0) >= 2)
    declined = fallback & opt.decline_disagreeing
    keep = np.where(fallback, present & ~declined, cons.keep)
    sw = np.where(fallback[None, None, :], False, cons.reading(legs))  # (C, J, T)
    swap = sw.any(axis=1)
    counts = {"views_dropped": int((present & ~keep).sum()), "views_swapped": int((sw[:, ~legs].any(axis=1) & swap).sum()),
              "views_legs_swapped": int((~sw[:, ~legs].any(axis=1) & swap).sum()), "frames_fallback": int(fallback.sum()),
              "joints_declined": int(ok[:, :, declined].any(axis=0).sum()), "views_foreign": int(foreign.sum())}
    u, v, ok, sc = (np.where(sw, a[:, flip], a) for a in (u, v, ok, sc))
    use = ok & keep[:, None, :]
    w = np.where(use, sc / box[:, None, :], 0.0).reshape(C, -1)
    uf, vf = u.reshape(C, -1), v.reshape(C, -1)
    X = gauss_newton(P, weighted_dlt(P, uf, vf, w), uf, vf, w, opt.refine_iterations)
    # per joint: drop the worst view when it alone disagrees (3+ views)
    r = np.where(w > 0, residuals(P, X, uf, vf), -np.inf)
    worst = np.argmax(r, axis=0)
    n = np.arange(X.shape[1])
    gate_n = gate.reshape(C, -1)
    drop = ((w > 0).sum(axis=0) >= 3) & (r[worst, n] > gate_n[worst, n])
    if drop.any():
        w[worst[drop], n[drop]] = 0.0
        sub = np.flatnonzero(drop)
        Xs = weighted_dlt(P, uf[:, sub], vf[:, sub], w[:, sub])
        X[:, sub] = gauss_newton(P, Xs, uf[:, sub], vf[:, sub], w[:, sub], opt.refine_iterations)
    counts["joint_views_dropped"] = int(drop.sum())
    if centre is None:  # no plane for the joints the consensus left with one view: all views, flagged
        lost = ((w > 0).sum(axis=0) < 2) & ((w_all > 0).sum(axis=0) >= 2) & ~np.tile(swap.any(axis=0), J)  # points run joint by joint (j T + t)
        lost &= ~np.tile(declined, J)
        X[:, lost], w[:, lost] = X_all[:, lost], w_all[:, lost]
        counts["joints_fallback"] = int(lost.sum())
    use = (w > 0).reshape(C, J, T)
    X3 = X.reshape(3, J, T).transpose(2, 1, 0).copy()  # (T, J, 3)
    relabel = settle_ties(X3, cons.tie & ~fallback, flip)
    if relabel.any():
        X3[relabel] = X3[relabel][:, flip]
        u, v, use, sc = (np.where(relabel, a[:, flip], a) for a in (u, v, use, sc))
    counts["frames_relabelled"] = int(relabel.sum())
    found = np.where(relabel, ok[:, flip], ok)
    X3, use, c_arms = check_arms(P, X3, u, v, use, found, sc, gate, skeleton, opt.arms)
    X3, how, weak, counts2 = _cascade(rig, X3, u, v, use, sc, box, centre, normal, skeleton, opt)
    X3, how, use, c_prior = apply_prior(P, X3, how, u, v, found, use, sc, gate, opt.temporal, ~fallback)
    counts.update(c_arms, **counts2, **c_prior)
    how_w = np.where(how == HOW_TRIANGULATED, 1.0, opt.plane_score_factor)
    mean_sc = np.where(use, sc, 0.0).sum(axis=0).T / np.maximum(use.sum(axis=0).T, 1)
    X3, outliers = smooth_track(X3, mean_sc * how_w, opt.smooth_half_window, opt.smooth_outlier_m)
    counts["joints_smoothed_outliers"] = int(outliers.sum())
    return _finish(P, X3, u, v, use, sc, how, gate, opt, counts, np.where(fallback, opt.fallback_score_factor, 1.0), foreign.T)


def _cascade(rig, X3, u, v, use, sc, box, centre, normal, skeleton, opt):
    """Steps 4-5 of the module doc: the plane anchoring of weak joints and the bone pull."""
    C, J, T = u.shape
    n_views = use.sum(axis=0)  # (J, T)
    finite = np.isfinite(X3).all(axis=2).T  # (J, T)
    with warnings.catch_warnings():  # frames without any joint: NaN, expected
        warnings.simplefilter("ignore", RuntimeWarning)
        ref = np.nanmedian(np.where((n_views >= 2).T[..., None], X3, np.nan), axis=1)
    if centre is not None:
        ref = np.where(np.isfinite(centre).all(axis=1, keepdims=True), centre, ref)
    opposite = opposite_only(rig.centres, ref, use, opt.opposite_angle_deg)
    weak = (n_views == 1) | opposite  # (J, T)
    how = np.where(finite & (n_views >= 2), HOW_TRIANGULATED, HOW_NONE).astype(np.int8)
    counts = {"joints_plane": 0, "joints_fused": 0}
    uf, vf = u.reshape(C, -1), v.reshape(C, -1)
    w = np.where(use, sc, 0.0).reshape(C, -1)
    sel = np.flatnonzero(weak.reshape(-1))
    o, d, o_main, d_main = lines_of_sight(rig, uf[:, sel], vf[:, sel], w[:, sel])
    if centre is not None:
        t_of = sel % T
        good = np.isfinite(centre[t_of]).all(axis=1)
        sel_c = sel[good]
        sigma_px = opt.pixel_sigma_frac * np.repeat(box[:, None, :], J, axis=1).reshape(C, -1)[:, sel_c]
        strong = ((n_views >= 2) & ~weak & finite).T
        spread = plane_spread(X3, strong, centre, normal, opt.plane_sigma_m, opt.bone_min_frames)
        Xa = anchor_on_plane(rig, o, d[:, :, good], d_main[:, good], w[:, sel_c], centre[sel_c % T].T, normal,
                             sigma_px, spread[sel_c // T], opt.min_plane_cos)
        j, t = sel_c // T, sel_c % T
        X3[t, j] = Xa.T
        placed = np.isfinite(Xa).all(axis=0)
        lone = n_views[j, t] == 1
        how[j, t] = np.where(placed, np.where(lone, HOW_PLANE, HOW_FUSED), HOW_NONE)
        counts["joints_plane"] = int((placed & lone).sum())
        counts["joints_fused"] = int((placed & ~lone).sum())
    single = (n_views == 1) & (how == HOW_NONE)  # a lone view without a plane: no depth at all
    X3[single.T] = np.nan
    counts["joints_unobservable"] = int((weak & (how == HOW_NONE) & (n_views > 0)).sum())
    origin = np.full((T, J, 3), np.nan)
    direction = np.full((T, J, 3), np.nan)
    j, t = sel // T, sel % T
    origin[t, j], direction[t, j] = o_main.T, d_main.T
    strong = (how == HOW_TRIANGULATED) & ~weak
    bones = np.asarray(skeleton.bones, np.int64).reshape(-1, 2)
    lengths = np.where(np.isfinite(L := bone_lengths(X3, strong.T, bones, opt.bone_min_frames)), L, given_lengths(opt, skeleton))
    X3, pulled = pull_to_bones(X3, strong.T, (weak & (how != HOW_NONE)).T, origin, direction, bones, lengths,
                               opt.bone_weight, opt.bone_iterations)
    counts["joints_bone_pulled"] = pulled
    return X3, how.T.copy(), weak.T, counts


def _finish(P, X3, u, v, use, sc, how, gate, opt, counts, frame_factor=1.0, foreign=None) -> Lifted:
    """Reprojection errors and scores of the final joints X3 (T, J, 3); gate (C, J, T) pixels;
    frame_factor (T,) or scalar multiplies the scores (fallback frames)."""
    C, J, T = u.shape
    X = X3.transpose(2, 1, 0).reshape(3, -1)
    r = residuals(P, X, u.reshape(C, -1), v.reshape(C, -1)).reshape(C, J, T)
    m = use & np.isfinite(r)
    n_views = m.sum(axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        reproj = np.where(n_views > 0, np.where(m, r, 0.0).sum(axis=0) / n_views, np.nan)
        mean_sc = np.where(m, sc, 0.0).sum(axis=0) / np.maximum(n_views, 1)
        g = np.where(m, gate, 0.0).sum(axis=0) / np.maximum(n_views, 1)
        quality = 1.0 / (1.0 + (reproj / g) ** 2)
    found = np.isfinite(X3).all(axis=2)
    how = np.where(found, how, HOW_NONE).astype(np.int8)
    factor = np.where(how == HOW_TRIANGULATED, 1.0, opt.plane_score_factor) * np.reshape(frame_factor, (-1, 1))
    score = np.where(found & (n_views.T > 0), np.clip(mean_sc.T * np.nan_to_num(quality.T) * factor, 0, 1), 0.0)
    return Lifted(xyz=X3, score=score, n_views=np.where(found, n_views.T, 0).astype(np.int64),
                  reproj_px=np.where(found, reproj.T, np.nan), how=how, counts=counts, foreign=foreign)
