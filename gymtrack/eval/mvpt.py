"""A frame-by-frame baseline in the spirit of MvPT (Dong et al. 2021) as the paper ran it.

Paper: Section IV, "Baseline trackers" and Table 3: MvPT associates single-frame observations
across views and links them over time; the paper ran it on box centres only ("we require all
methods to rely solely on a weak geometric cue: the central points of bounding boxes").

What it is, per frame:

1. cross-view association of single boxes: the Eq. 1 epipolar distance of every pair of box
   centres from different views (:func:`gymtrack.geometry.epipolar.epipolar_distance`, inf for
   two boxes of one view), clustered with the tracker's Algorithm 1
   (:func:`gymtrack.tracking.clustering.complete_linkage`, same threshold ``cluster_2d`` = 0.3);
2. triangulation (Eq. 3) of every cluster of >= 2 views: the box centre, top-centre and
   bottom-centre (for the target rule); clusters of one box, and points outside the tracking
   space (the spatial part of Eq. 4), are dropped;
3. frame-to-frame 3D linking: a linear assignment (``scipy``'s ``linear_sum_assignment``)
   between the tracks seen in the last ``max_age`` frames and the frame's points, gated at
   ``link_gate`` metres (0.6, the paper's cross-window gate); unmatched points start new ids;
4. the tracker's own target stage (:class:`gymtrack.tracking.target.TargetStage`), fed online
   (in runs of frames between track ends; a track ends ``max_age`` frames after its last point):
   Eq. 13 identification, the tracker's back-fill, gap filling and smoothing and the Eq. 14
   expanded boxes.

What it is not: no keypoints (MvPT matches full-body keypoints), no appearance / Re-ID, no 2D
tracklets or temporal windows (every frame is associated on its own), no plane fallback. It
produces the tracker's :class:`~gymtrack.tracking.types.TrackResult` (mode ``"mvpt"``), so the
metrics run unchanged.
"""

from __future__ import annotations

import time

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..detections import Detections
from ..scene import Scene
from ..geometry.camera import Rig
from ..geometry.epipolar import epipolar_distance, fundamental_matrices
from ..geometry.triangulation import triangulate
from ..tracking.clustering import complete_linkage
from ..tracking.target import TargetStage
from ..tracking.types import TRIANGULATION, Target, Tracks3D, TrackResult

__all__ = ["undistort_boxes", "associate_frame", "associate", "link_frames", "select_target", "track_mvpt"]


def undistort_boxes(rig: Rig, camera: np.ndarray, box: np.ndarray) -> np.ndarray:
    """(N,) camera indices, (N, 4) raw centre-form boxes -> (N, 4) boxes in undistorted pixels
    (corners undistorted and the box rebuilt from them, as the tracker does)."""
    out = np.asarray(box, dtype=np.float64).copy()
    for c, cam in enumerate(rig):
        rows = camera == c
        if not cam.has_distortion or not rows.any():
            continue
        b = out[rows]
        tl = cam.undistort(b[:, :2] - b[:, 2:] / 2)
        br = cam.undistort(b[:, :2] + b[:, 2:] / 2)
        out[rows] = np.column_stack([(tl + br) / 2, br - tl])
    return out


def associate_frame(camera: np.ndarray, ubox: np.ndarray, F: np.ndarray, threshold: float) -> np.ndarray:
    """Cross-view clusters of one frame's boxes.

    camera: (n,) view index; ubox: (n, 4) undistorted centre-form boxes; F: (C, C, 3, 3) from
    :func:`fundamental_matrices`; threshold: lambda of Algorithm 1.
    Returns (n,) cluster labels (at most one box per view in a cluster).
    """
    n = len(camera)
    if n < 2:
        return np.zeros(n, np.int64)
    Fp = F[camera[:, None], camera[None, :]]  # (n, n, 3, 3), F[i, j] maps view i to view j
    D = epipolar_distance(ubox[:, None, :], ubox[None, :, :], Fp)
    D[camera[:, None] == camera[None, :]] = np.inf
    return complete_linkage(D, threshold)


def associate(rig: Rig, det: Detections, threshold: float = 0.3) -> tuple[np.ndarray, np.ndarray]:
    """Per-frame association of all boxes. ``det`` sorted by frame.

    Returns (cluster (N,) int64, a label unique over the routine; ubox (N, 4) undistorted boxes).
    """
    cam = det.camera.astype(np.int64)
    ubox = undistort_boxes(rig, cam, det.box)
    F = fundamental_matrices(rig)
    label = np.zeros(len(det), np.int64)
    _, first = np.unique(det.frame, return_index=True)
    bounds = np.r_[first, len(det)]
    offset = 0
    for a, b in zip(bounds[:-1], bounds[1:]):
        lab = associate_frame(cam[a:b], ubox[a:b], F, threshold)
        label[a:b] = lab + offset
        offset += int(lab.max()) + 1 if b > a else 0
    return label, ubox


def link_frames(frame: np.ndarray, xyz: np.ndarray, gate: float = 0.6, max_age: int = 2) -> np.ndarray:
    """Frame-to-frame 3D linking by linear assignment.

    frame: (K,) frames, non-decreasing; xyz: (K, 3) points.
    A point continues the track whose last point (at most ``max_age`` frames before) is nearest
    in the optimal one-to-one assignment, if within ``gate`` metres; otherwise it starts a new
    track. Returns (K,) track ids 0, 1, ...
    """
    K = len(frame)
    ids = np.full(K, -1, np.int64)
    if K == 0:
        return ids
    tr_id = np.zeros(0, np.int64)
    tr_xyz = np.zeros((0, 3))
    tr_last = np.zeros(0, np.int64)
    next_id = 0
    uniq, first = np.unique(frame, return_index=True)
    bounds = np.r_[first, K]
    for f, a, b in zip(uniq.tolist(), bounds[:-1], bounds[1:]):
        live = tr_last >= f - max_age
        tr_id, tr_xyz, tr_last = tr_id[live], tr_xyz[live], tr_last[live]
        pts = xyz[a:b]
        got = np.full(b - a, -1, np.int64)
        if len(tr_id):
            d = np.linalg.norm(tr_xyz[:, None] - pts[None], axis=-1)
            ok = d <= gate
            if ok.any():
                cost = np.where(ok, d, 1e6)
                r, c = linear_sum_assignment(cost)
                keep = ok[r, c]
                r, c = r[keep], c[keep]
                got[c] = tr_id[r]
                tr_xyz[r] = pts[c]
                tr_last[r] = f
        new = got < 0
        got[new] = next_id + np.arange(int(new.sum()))
        next_id += int(new.sum())
        tr_id = np.r_[tr_id, got[new]]
        tr_xyz = np.r_[tr_xyz, pts[new]]
        tr_last = np.r_[tr_last, np.full(int(new.sum()), f)]
        ids[a:b] = got
    return ids


def select_target(rig: Rig, scene: Scene, tracks: Tracks3D, boxes: Detections, max_age: int = 2) -> tuple[Target, Detections, int]:
    """The tracker's target stage (Eq. 13, the back-fill, gap filling, smoothing, Eq. 14) on finished tracks.

    tracks: sorted by (frame, track_id); boxes: the tracks' raw boxes (``track_id`` = 3D id).
    A track counts as ended ``max_age`` frames after its last point (as it would online).
    Returns (target, its expanded boxes ``b_buf``, the number of target switches).
    """
    if len(tracks) == 0:
        return Target.empty(), Detections.empty(rig.names), 0
    stage = TargetStage(rig, scene)
    ids, last_idx = np.unique(tracks.track_id[::-1], return_index=True)
    last = tracks.frame[::-1][last_idx]  # last frame of each track
    end_order = np.argsort(last + max_age, kind="stable")
    ends, end_ids = (last + max_age)[end_order], ids[end_order]
    f0, f1 = int(tracks.frame.min()), int(tracks.frame.max())
    # online, in runs of frames between two track ends (the selector decides a run frame by frame)
    starts = np.unique(np.r_[f0, np.clip(ends + 1, f0, f1 + 1)])
    starts = starts[starts <= f1]
    stops = np.r_[starts[1:], f1 + 1]  # exclusive
    bounds, box_bounds = np.searchsorted(tracks.frame, starts), np.searchsorted(boxes.frame, starts)
    bounds, box_bounds = np.r_[bounds, len(tracks)], np.r_[box_bounds, len(boxes)]
    ended: dict[int, int] = {}
    out = []
    k = 0
    for i, (a, b) in enumerate(zip(starts.tolist(), stops.tolist())):
        while k < len(ends) and ends[k] < a:
            ended[int(end_ids[k])] = int(ends[k] - max_age)
            k += 1
        out.append(stage.update(a, b - 1, tracks.select(slice(bounds[i], bounds[i + 1])),
                                boxes.select(slice(box_bounds[i], box_bounds[i + 1])), ended))
    out.append(stage.finish())
    target, boxes_buf = Target.concat([t for t, _ in out]), Detections.concat([b for _, b in out])
    return target, boxes_buf, stage.switches


def track_mvpt(
    rig: Rig,
    scene: Scene,
    detections: Detections,
    threshold: float | None = None,
    link_gate: float | None = None,
    max_age: int | None = None,
) -> TrackResult:
    """Run the MvPT-like baseline on a routine's detections (see the module docstring).

    threshold: Algorithm 1 cut (default ``scene.params.cluster_2d``); link_gate: metres per
    frame (default ``scene.params.link_3d``); max_age: frames a 3D track may miss (default
    ``scene.params.max_age``). Returns a TrackResult with mode ``"mvpt"``.
    """
    p = scene.params
    threshold = p.cluster_2d if threshold is None else threshold
    link_gate = p.link_3d if link_gate is None else link_gate
    max_age = p.max_age if max_age is None else max_age
    clock = time.perf_counter
    t0 = clock()
    det = detections.sorted()
    C = len(rig)
    label, ubox = associate(rig, det, threshold)
    t1 = clock()

    # clusters of >= 2 views: gather per-view points (K, C, 2) and triangulate in one batch
    uniq, inv = np.unique(label, return_inverse=True)
    K = len(uniq)
    cam = det.camera.astype(np.int64)
    nview = np.bincount(inv, minlength=K)
    keep_box = nview[inv] >= 2
    members = np.full((K, C), -1, np.int64)
    members[inv[keep_box], cam[keep_box]] = np.flatnonzero(keep_box)
    multi = nview >= 2
    members = members[multi]
    cl_frame = np.zeros(K, np.int64)
    cl_frame[inv] = det.frame
    cl_frame = cl_frame[multi]
    mask = members >= 0
    idx = np.where(mask, members, 0)
    P = rig.projections
    b = ubox[idx]  # (K, C, 4)
    centre, _ = triangulate(P, b[..., :2], mask)
    top, _ = triangulate(P, np.stack([b[..., 0], b[..., 1] - b[..., 3] / 2], -1), mask)
    bot, _ = triangulate(P, np.stack([b[..., 0], b[..., 1] + b[..., 3] / 2], -1), mask)
    space = np.asarray(scene.tracking_space, dtype=np.float64)
    good = np.all(np.isfinite(centre), axis=1) & np.all((centre >= space[:3]) & (centre <= space[3:]), axis=1)
    centre, top, bot, members, cl_frame, mask = centre[good], top[good], bot[good], members[good], cl_frame[good], mask[good]
    t2 = clock()

    tid = link_frames(cl_frame, centre, link_gate, max_age)
    order = np.lexsort((tid, cl_frame))
    tracks = Tracks3D(
        cl_frame[order], tid[order], centre[order], top[order, 2], bot[order, 2],
        np.full(len(order), TRIANGULATION, np.int8), mask[order].sum(axis=1).astype(np.int8),
    )
    m, c = np.nonzero(mask)
    rows = members[m, c]
    boxes = Detections.from_arrays(det.frame[rows], c, det.box[rows], rig.names, score=det.score[rows], track_id=tid[m])
    boxes = boxes.select(np.lexsort((boxes.track_id, boxes.camera, boxes.frame)))
    t3 = clock()

    target, target_boxes, switches = select_target(rig, scene, tracks, boxes, max_age)
    t4 = clock()
    frames = int(det.frame.max() - det.frame.min() + 1) if len(det) else 0
    total = t4 - t0
    summary = {
        "mode": "mvpt",
        "association": "epipolar per frame",
        "frames": frames,
        "tracks": int(np.unique(tid).size),
        "clusters_triangulated": int(len(centre)),
        "clusters_single_view": int((~multi).sum()),
        "clusters_outside_space": int((~good).sum()),
        "target_frames": int(len(target)),
        "target_switches": int(switches),
        "seconds": {"association": t1 - t0, "triangulation": t2 - t1, "linking": t3 - t2, "target": t4 - t3},
        "seconds_total": total,
        "fps": round(frames / total, 1) if total > 0 else None,
    }
    return TrackResult(tracks, boxes, target, target_boxes, rig.names, "mvpt", summary)
