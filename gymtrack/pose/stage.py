"""The pose stage: 2D poses in the tracker's boxes -> the 3D pose of the target (or every track).

Paper: Section III-D, last paragraph ("Identify Target Gymnast for Pose Estimation") and Fig. 7:
the expanded boxes ``b_buf`` are the crops a top-down pose model runs on, and the 3D pose is
triangulated from its keypoints in every view; a biased track gives biased crops and a
misdirected pose. This module is the glue around the parts:

1. :func:`gymtrack.pose.assign.assign_poses` gives every pose without a ``track_id`` the 3D track
   whose box (per-view box or ``b_buf``) it overlaps;
2. the poses of one *sequence* -- the target (one row per target frame, following the tracks the
   target followed; the default) or one 3D track (``all_tracks=True``) -- go into the dense
   ``(T, C, J, 3)`` array :func:`gymtrack.pose.lift.lift_track` takes (T = the sequence's frames,
   C = the rig's views in rig order), with the sequence's 3D centre ``(T, 3)`` and the normal of
   the apparatus plane nearest to it (``scene.planes``) for the plane anchoring;
3. the lifted joints become :class:`gymtrack.poses.Poses3D` rows (frames with at least one joint).

Every input pose is accounted for (:attr:`PoseStageResult.counts`): rejected / unassigned by the
assignment; of the assigned ones, ``used`` in a lifted sequence, ``foreign_torso`` (placed, but
set aside by the lifting: its torso shows another body, :mod:`gymtrack.pose.identity`),
``duplicate`` (another pose of the same track, frame and view had the higher mean score) or
``not_lifted`` (its track or frame is not one that was lifted, e.g. a coach's pose without
``all_tracks``).
"""

from __future__ import annotations

import time
import warnings
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Sequence

import numpy as np

from ..detections import Detections
from ..errors import GymtrackWarning, InputError
from ..scene import Scene
from ..geometry.camera import Rig
from ..poses import HOW_NAMES, HOW_NONE, Poses2D, Poses3D
from ..tracking.types import Target, Tracks3D, TrackResult
from .assign import GIVEN, Assignment, assign_poses
from .exclusive import exclusive_bodies, foreign_bodies
from .identity import TorsoIdentity
from .lift import LiftOptions, lift_track
from .skeleton_check import ASYMMETRY_MAX, BONE_CV_MAX, skeleton_consistency

__all__ = ["NoTargetError", "check_liftable", "PoseStageResult", "Sequence3D", "nearest_plane_normal", "target_sequence", "track_sequences",
           "dense_keypoints", "lift_poses", "pose_model_boxes", "read_track_result"]

LIFT_METHODS: tuple[str, ...] = ("dlt", "robust")


class NoTargetError(InputError):
    """The track output has no target frame, and only the target was asked for."""

    def __init__(self) -> None:
        super().__init__("the track output has no target frames, so there is no target to lift: see the 'target' "
                         "lines of summary.json and the track command's warnings for why (often the scene's target "
                         "heights h_top / h_bot, its performance_space, or the calibration's units); give --all-tracks "
                         "to lift every 3D track instead", field="target")


@dataclass(frozen=True, eq=False)
class Sequence3D:
    """One thing to lift: frames (T,) increasing, track_id (T,) the 3D track per frame, centre (T, 3)."""

    frame: np.ndarray
    track_id: np.ndarray
    centre: np.ndarray


@dataclass(frozen=True, eq=False)
class PoseStageResult:
    """What :func:`lift_poses` made.

    poses3d: the 3D poses, one row per (frame, track) with at least one joint estimated.
    assignment: every input pose with its status and track id.
    counts: read, given, assigned, unassigned, rejected (+ kinds), used, duplicate, not_lifted.
    seconds: time spent lifting (assignment and grouping included).
    set_aside: (N,) bool per input pose: assigned, then set aside by the lifting (``foreign_torso``).
    """

    poses3d: Poses3D
    assignment: Assignment
    counts: dict = field(default_factory=dict)
    seconds: float = 0.0
    set_aside: np.ndarray | None = None

    @property
    def poses2d(self) -> Poses2D:
        """Every input pose, ``track_id`` filled where assigned."""
        return self.assignment.poses

    def how_counts(self) -> dict[str, int]:
        """Estimated joints per way of estimation (triangulated / plane / fused)."""
        ok = np.all(np.isfinite(self.poses3d.xyz), axis=-1)
        c = np.bincount(self.poses3d.how[ok].astype(np.int64), minlength=len(HOW_NAMES))
        return {name: int(c[k]) for k, name in enumerate(HOW_NAMES) if k != HOW_NONE}

    def summary(self) -> dict:
        """Counts for the command's summary: poses, frames with a pose, tracks, joints per ``how``."""
        p = self.poses3d
        return {**self.counts, "frames_with_pose": int(np.unique(p.frame).size), "tracks_with_pose": int(np.unique(p.track_id).size),
                "poses_3d": len(p), **{f"joints_{k}": v for k, v in self.how_counts().items()}, "seconds": round(self.seconds, 3)}


def nearest_plane_normal(scene: Scene, centre: np.ndarray) -> np.ndarray | None:
    """(3,) unit normal of the scene plane nearest (median distance) to the centres (T, 3); None without planes."""
    if not scene.planes:
        return None
    c = np.asarray(centre, np.float64).reshape(-1, 3)
    c = c[np.all(np.isfinite(c), axis=1)]
    if not len(c):
        return np.asarray(scene.planes[0].normal, np.float64)
    d = [np.median(np.abs((c - np.asarray(p.point)) @ np.asarray(p.normal))) for p in scene.planes]
    return np.asarray(scene.planes[int(np.argmin(d))].normal, np.float64)


def target_sequence(target: Target) -> Sequence3D:
    """The target as one sequence: its frames, the track it followed per frame, its smoothed centre."""
    o = np.argsort(target.frame, kind="stable")
    return Sequence3D(target.frame[o], target.track_id[o], target.xyz[o])


def track_sequences(tracks: Tracks3D) -> list[Sequence3D]:
    """One sequence per 3D track id (its frames in order)."""
    o = np.lexsort((tracks.frame, tracks.track_id))
    tid = tracks.track_id[o]
    cuts = np.flatnonzero(np.r_[True, tid[1:] != tid[:-1], True])
    return [Sequence3D(tracks.frame[o[a:b]], tid[a:b], tracks.xyz[o[a:b]]) for a, b in zip(cuts[:-1], cuts[1:])]


def dense_keypoints(seq: Sequence3D, poses: Poses2D, n_cameras: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The poses of one sequence as the dense array ``lift_track`` takes.

    poses: assigned poses (``track_id`` >= 0), ``camera`` in rig order.
    Returns ``(keypoints (T, C, J, 3), used (N,) bool, duplicate (N,) bool)``: NaN where a view has
    no pose; ``used`` marks the rows placed, ``duplicate`` the rows of the sequence that lost to a
    pose of the same frame and view with a higher mean score.
    """
    T, J = len(seq.frame), len(poses.skeleton.joints)
    kp = np.full((T, n_cameras, J, 3), np.nan)
    kp[..., 2] = 0.0
    n = len(poses)
    used, dup = np.zeros(n, bool), np.zeros(n, bool)
    if not T or not n:
        return kp, used, dup
    t = np.clip(np.searchsorted(seq.frame, poses.frame), 0, T - 1)
    mine = (seq.frame[t] == poses.frame) & (seq.track_id[t] == poses.track_id)
    rows = np.flatnonzero(mine)
    if not rows.size:  # the sequence has no pose (--all-tracks with poses of some tracks only)
        return kp, used, dup
    s = np.where(poses.found()[rows], poses.keypoints[rows, :, 2], 0.0).mean(axis=1)
    order = rows[np.lexsort((-s, poses.camera[rows], t[rows]))]
    key = t[order] * n_cameras + poses.camera[order]
    first = np.r_[True, key[1:] != key[:-1]]
    keep, lost = order[first], order[~first]
    kp[t[keep], poses.camera[keep]] = poses.keypoints[keep]
    used[keep], dup[lost] = True, True
    return kp, used, dup


def _rig_order(poses: Poses2D, rig: Rig) -> Poses2D:
    """The poses with ``camera`` re-indexed to the rig's order (by camera name)."""
    if tuple(poses.camera_names) == tuple(rig.names):
        return poses
    missing = [n for n in poses.camera_names if n not in rig.names]
    if missing:
        raise InputError(f"the poses have camera {missing[0]!r}, which the calibration does not have "
                         f"(its cameras: {', '.join(rig.names)})", field="camera")
    remap = np.array([rig.names.index(n) for n in poses.camera_names], np.int64)
    return Poses2D(poses.frame, remap[poses.camera], poses.track_id, poses.keypoints, poses.bbox, poses.skeleton, rig.names)


def check_liftable(result: TrackResult, poses: Poses2D, all_tracks: bool) -> None:
    """Raise a clear InputError when lifting cannot give anything: no 2D poses at all, or no target
    frames when only the target is asked for (:class:`NoTargetError`). :func:`lift_poses` itself
    returns an empty result then (a benchmark row, a demo table); commands call this first."""
    if not len(poses):
        raise InputError("no 2D poses to lift: the keypoint files hold no poses (check that the pose model ran and "
                         "wrote its output where --keypoints points)", field="keypoints")
    if not all_tracks and not len(result.target.frame):
        raise NoTargetError()


def lift_poses(result: TrackResult, rig: Rig, scene: Scene, poses: Poses2D, all_tracks: bool = False,
               method: str = "robust", plane: bool = True, options: LiftOptions | None = None,
               min_iou: float = 0.3, joints: bool = True) -> PoseStageResult:
    """The pose stage on a tracker result: assign, group per sequence, lift.

    result: the tracker's output (``tracks``, ``boxes``, ``target``, ``target_boxes``), e.g. from
        :func:`gymtrack.tracking.offline.track_detections` or :func:`read_track_result`.
    poses: the 2D poses of the routine (any camera order; matched to ``rig`` by name).
    all_tracks: lift every 3D track (rows per (frame, track)); default: the target only. With
        ``all_tracks`` and no ``options``, views whose torso shows another body are set aside
        (:mod:`gymtrack.pose.identity`).
    method: ``dlt`` (paper Eq. 3 per joint) | ``robust``; plane: with ``robust``, pass the centre
        and the nearest plane's normal (False: the ablation "robust without plane anchoring").
    min_iou: the assignment's gate; joints: also assign by the joints' epipolar agreement where
        boxes overlap (:mod:`gymtrack.pose.assign_joints`), and leave a body two tracks' poses
        found in one view to the track it fits (:mod:`gymtrack.pose.exclusive`).
    """
    if method not in LIFT_METHODS:
        raise InputError(f"unknown lifting method {method!r}; choose one of {', '.join(LIFT_METHODS)}", field="--lift")
    t0 = time.perf_counter()
    # a neighbour's body in a track's crop: set aside where every track is lifted (a crowd); the
    # target alone keeps every view (on the suites the rule set aside the gymnast's own views too)
    options = options or LiftOptions(identity=TorsoIdentity() if all_tracks else None)
    poses = _rig_order(poses, rig)
    clipped = int((poses.keypoints[..., 2] > 1).sum())
    if clipped:  # OpenPose's heatmap peaks reach a little above 1: a weight, so clip
        poses = replace(poses, keypoints=np.concatenate([poses.keypoints[..., :2],
                                                         np.minimum(poses.keypoints[..., 2:], 1.0)], axis=-1))
    boxes = _rig_boxes(Detections.concat([result.boxes, result.target_boxes]), rig)
    a = assign_poses(poses, boxes, min_iou=min_iou, frame_range=_frame_range(result), rig=rig if joints else None)
    known = np.unique(np.concatenate([result.tracks.track_id, result.target.track_id, boxes.track_id]))
    unknown = (a.status == GIVEN) & ~np.isin(a.poses.track_id, known)
    if unknown.any():
        ids = np.unique(a.poses.track_id[unknown])
        warnings.warn(f"{int(unknown.sum())} poses name a track_id the track output does not have "
                      f"({', '.join(map(str, ids[:5]))}{'...' if ids.size > 5 else ''}); they are not lifted: were they "
                      "written for another track run?", GymtrackWarning, stacklevel=2)
    # one body, one person: a pose two tracks' crops both found stays with the track it fits
    same = exclusive_bodies(a.poses, rig, np.where(unknown, -1, a.poses.track_id)) if joints else np.zeros(len(a.poses), bool)
    tid = np.where(unknown | same, -1, a.poses.track_id)
    foreign = np.zeros(len(tid), bool)
    if joints and all_tracks:  # a crop holding another track's body: its pose goes to that track
        t = result.tracks
        moved = foreign_bodies(a.poses, rig, tid, t.frame, t.track_id, t.xyz)
        foreign, tid = moved != tid, moved
        a = replace(a, poses=replace(a.poses, track_id=np.where(unknown | same, a.poses.track_id, tid)))
    mine = np.flatnonzero(tid >= 0)
    assigned = a.poses.subset(mine)
    seqs = track_sequences(result.tracks) if all_tracks else [target_sequence(result.target)]
    used, dup, aside = np.zeros(len(assigned), bool), np.zeros(len(assigned), bool), np.zeros(len(assigned), bool)
    parts, no_pose = [], 0
    for seq in seqs:
        if not len(seq.frame):
            continue
        kp, u, d = dense_keypoints(seq, assigned, len(rig))
        used |= u
        dup |= d
        if not u.any():
            no_pose += 1
            continue
        anchor = method == "robust" and plane
        normal = nearest_plane_normal(scene, seq.centre) if anchor else None
        lifted = lift_track(rig, kp, assigned.skeleton, method=method, centre=seq.centre if normal is not None else None,
                            plane_normal=normal, options=options)
        if lifted.foreign is not None:  # placed, then set aside by the lifting as another body's
            r = np.flatnonzero(u)
            aside[r] = lifted.foreign[np.searchsorted(seq.frame, assigned.frame[r]), assigned.camera[r]]
        has = np.all(np.isfinite(lifted.xyz), axis=-1).any(axis=1)
        parts.append(Poses3D(seq.frame[has], seq.track_id[has], lifted.xyz[has], lifted.score[has], lifted.n_views[has],
                             lifted.reproj_px[has], lifted.how[has], assigned.skeleton))
    if all_tracks and no_pose:
        warnings.warn(f"{no_pose} of {len(seqs)} tracks have no 2D pose assigned and get no 3D skeleton "
                      "(the keypoints cover only some tracks)", GymtrackWarning, stacklevel=2)
    p3 = Poses3D.concat(parts).sorted() if parts else Poses3D.empty(poses.skeleton)
    check = skeleton_consistency(p3)
    if check["suspect"]:
        warnings.warn(f"the 3D skeleton does not look like a body: bone lengths vary by {check['bone_cv']:.0%} over "
                      f"frames (a body's: under {BONE_CV_MAX:.0%}), left and right limbs differ by "
                      f"{check['asymmetry']:.0%} (a body's: under {ASYMMETRY_MAX:.0%}); the 2D poses are probably read "
                      f"in the wrong joint order ({poses.skeleton.name}): check --skeleton", GymtrackWarning, stacklevel=2)
    counts = {"read": len(poses), **{k: v for k, v in a.counts.items() if k != "total"},
              "unknown_track": int(unknown.sum()), "same_body": int(same.sum()),
              "foreign_moved": int((foreign & (tid >= 0)).sum()), "foreign_dropped": int((foreign & (tid < 0)).sum()),
              "used": int((used & ~aside).sum()), "foreign_torso": int(aside.sum()), "duplicate": int((dup & ~used).sum()),
              "not_lifted": int((~used & ~dup).sum()), "scores_clipped": clipped,
              "tracks_without_pose": no_pose if all_tracks else 0,
              "bone_length_cv": round(check["bone_cv"], 3), "left_right_asymmetry": round(check["asymmetry"], 3)}
    flagged = np.zeros(len(poses), bool)
    flagged[mine] = aside
    return PoseStageResult(p3, a, counts, time.perf_counter() - t0, flagged)


def pose_model_boxes(result: TrackResult, all_tracks: bool = False) -> Detections:
    """The crops a top-down pose model runs on: the target's b_buf boxes; with ``all_tracks`` also
    every track's per-view box where there is no b_buf of that track (same frame and view)."""
    tb = result.target_boxes
    if not all_tracks:
        return tb
    b = result.boxes
    n = max(len(b.camera_names), 1)

    def key(d: Detections) -> np.ndarray:
        return (d.frame * n + d.camera.astype(np.int64)) * (1 << 24) + d.track_id

    return Detections.concat([tb, b.select(~np.isin(key(b), key(tb)))]).sorted()


def _frame_range(result: TrackResult) -> tuple[int, int] | None:
    f = np.concatenate([result.tracks.frame, result.target.frame, result.boxes.frame, result.target_boxes.frame])
    return (int(f.min()), int(f.max())) if f.size else None


def _rig_boxes(boxes: Detections, rig: Rig) -> Detections:
    if tuple(boxes.camera_names) == tuple(rig.names):
        return boxes
    remap = np.array([rig.names.index(n) for n in boxes.camera_names], np.int64)
    return Detections.from_arrays(boxes.frame, remap[boxes.camera.astype(np.int64)], boxes.box, rig.names,
                                  score=boxes.score, track_id=boxes.track_id)


def read_track_result(out: str | Path, camera_names: Sequence[str]) -> TrackResult:
    """The outputs of ``gymtrack track`` read back from ``out`` (tracks, boxes, target, b_buf).

    Reads with :func:`gymtrack.formats.outputs.read_outputs`; raises InputError when ``out`` or
    one of its files is missing or malformed (naming it).
    """
    from ..formats.outputs import read_outputs
    from ..tracking.types import SOURCE_NAMES

    out = Path(out)
    if not out.is_dir():
        raise InputError("track output folder not found: run `gymtrack track <routine> --out <out>` first", source=out)
    f = read_outputs(out, camera_names)
    code = {n: k for k, n in enumerate(SOURCE_NAMES)}

    def src(col: np.ndarray, name: str) -> np.ndarray:
        bad = [s for s in col if s not in code]
        if bad:
            raise InputError(f"unknown source {bad[0]!r}", source=out / name, field="source")
        return np.array([code[s] for s in col], np.int8)

    t, g = f.tracks, f.target
    tracks = Tracks3D(t.frame, t.track_id, t.xyz, t.top_z, t.bottom_z, src(t.source, "tracks_3d.csv"),
                      t.n_views.astype(np.int8))
    target = Target(g.frame, g.track_id, g.xyz, src(g.source, "target_3d.csv"))
    return TrackResult(tracks, f.boxes, target, f.target_boxes, f.camera_names, mode="read")
