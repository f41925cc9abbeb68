"""MVOR: real multi-view upper-body poses with real 2D detector output.

The paper (Yang et al., Section III-D) triangulates the joints a pose model finds in several
calibrated views; MVOR lets the pose stage measure that on data nobody here made:

    V. Srivastav, T. Issenhuth, A. Kadkhodamohammadi, M. de Mathelin, A. Gangi, N. Padoy,
    "MVOR: A Multi-view RGB-D Operating Room Dataset for 2D and 3D Human Pose Estimation",
    MICCAI-LABELS 2018, arXiv:1808.08180. CAMMA, University of Strasbourg. Licence CC BY-NC-SA 4.0
    (non-commercial, share alike; cite the paper wherever results on it are reported).

The files are those of ``shared/data/mvor`` (its README lists every convention used here):
``camma_mvor_2018.json`` (calibration, 732 multi-view frames, GT 2D and 3D), ``openpose_kps.json``
and ``rtpose_kps.json`` (the detectors' COCO-17 output, no identity).

Conventions of what :func:`read_mvor` returns:

* **World** = camera 1's frame converted to metres: x right, y *down*, z forward (along cam1's
  optical axis). Not z-up like the gym scenes; nothing in the pose stage needs z up except the
  apparatus plane, which MVOR has none of.
* **Rig**: ``cam1``, ``cam2``, ``cam3``, pinhole, 640x480, no distortion (the README shows the
  listed coefficients make the fit worse). ``extrinsics[c]`` maps camera c to camera 1, so
  ``R = Rc.T``, ``t = -Rc.T @ tc / 1000``.
* **Frames**: F = 732 multi-view snapshots in file order (index ``f``, not video: usually 75 s
  apart, no identity across frames). **Persons**: per frame, P slots holding the frame's
  ``person_id`` values in increasing order (a person is (frame, slot); -1 pads).
* **GT joints**: the 10 of ``MVOR_SKELETON`` (head, neck, shoulders, hips, elbows, wrists). 3D
  points 11-12 (unnamed, often ``wrist + 50 mm`` placeholders) and (0, 0, 0) points (and one
  (50, 50, 50) mm, the placeholder of a missing point) are dropped and counted. Duplicate
  (frame, person_id) entries keep the first and are counted.
* **Detections**: ``coco_keypoints`` are COCO-17 (checked: OpenPose's own ``keypoints`` field is
  exactly :func:`coco17_to_mvor` of them, and left joints lie on GT left joints). Each is linked to
  a GT person of its image by its mean distance to that person's GT 2D joints over joints both
  have (the README's rule), one-to-one per image (Hungarian), within ``max_match_px``; the rest
  keep ``track_id = -1`` and are counted.

Arrays: F frames, V = 3 views, P person slots, J = 10 joints.
"""

from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..errors import InputError
from ..geometry.camera import Camera, Rig
from ..poses import Poses2D
from ..skeletons import COCO17, Skeleton, custom_skeleton
from .keypoints import load_json

MVOR_JOINTS = ("head", "neck", "left_shoulder", "right_shoulder", "left_hip", "right_hip",
               "left_elbow", "right_elbow", "left_wrist", "right_wrist")
MVOR_SKELETON: Skeleton = custom_skeleton(MVOR_JOINTS)
CAMERA_NAMES = ("cam1", "cam2", "cam3")
DETECTORS = {"openpose": "openpose_kps.json", "rtpose": "rtpose_kps.json"}


def default_folder() -> Path | None:
    """``$GYMTRACK_MVOR``, else the first ``shared/data/mvor`` beside a folder above this package."""
    env = os.environ.get("GYMTRACK_MVOR")
    if env:
        return Path(env)
    for parent in Path(__file__).resolve().parents[1:]:
        if (parent / "shared" / "data" / "mvor" / "camma_mvor_2018.json").is_file():
            return parent / "shared" / "data" / "mvor"
    return None


@dataclass(eq=False)
class MVORDetections:
    """One detector's 2D poses on MVOR.

    poses: COCO-17 :class:`Poses2D`; ``frame`` = the frame index f, ``camera`` = the view,
        ``track_id`` = the linked person slot p of that frame (-1 = not linked).
    mapped: the same rows mapped to the 10 GT joints (:func:`coco17_to_mvor`).
    score: (D,) the detector's per-person score (OpenPose 0..1, RTPose unnormalised).
    match_px: (D,) mean distance to the linked person's GT 2D joints (NaN if not linked).
    repeated: (D,) bool, the keypoints repeat an earlier entry of the same image (a file defect).
    in_bbox_only: (D,) bool, not linked, but most of its joints lie in the GT box of a person
        annotated with a box only (no keypoints, no 3D): a real person, just not one to measure.
    counts: entries, linked, unlinked (of which in_bbox_only), repeated, unknown_image.
    """

    name: str
    poses: Poses2D
    mapped: Poses2D
    score: np.ndarray
    match_px: np.ndarray
    repeated: np.ndarray
    in_bbox_only: np.ndarray
    counts: dict[str, int] = field(default_factory=dict)


@dataclass(eq=False)
class MVOR:
    """The MVOR data set as dense arrays.

    rig: the 3 cameras (world = camera-1 frame, metres, y down).
    frame_ids: (F,) the multi-view ids ``"<id1>_<id2>_<id3>"``.
    image_ids: (F, V) int64 image ids; day: (F,) int64 day 1..4.
    person_id: (F, P) int64 the file's person_id per slot, -1 = empty slot.
    joints3d: (F, P, J, 3) float64 GT 3D joints, metres, NaN = none.
    keypoints2d: (F, V, P, J, 3) float64 GT 2D ``[x, y, v]``; v 2 visible, 1 occluded (guessed),
        0 not labelled (x, y NaN).
    boxes2d: (F, V, P, 4) float64 GT boxes ``[left, top, w, h]`` of the annotated persons, NaN = none.
    bbox_only: (K, 6) float64 rows ``[f, view, left, top, w, h]`` of the box-only annotations
        (person_id -1: no keypoints, no link to 3D), kept apart.
    detections: detector name -> :class:`MVORDetections`.
    counts: what was dropped or is odd, by reason.
    room: (4, 4) ``firstCamToRoomRef`` in metres: world (camera 1) -> the room frame, z up, z = 0
        about hip height; NaN where the file has none. :attr:`up` is the room's up in the world.
    """

    rig: Rig
    frame_ids: tuple[str, ...]
    image_ids: np.ndarray
    day: np.ndarray
    person_id: np.ndarray
    joints3d: np.ndarray
    keypoints2d: np.ndarray
    boxes2d: np.ndarray
    bbox_only: np.ndarray
    detections: dict[str, MVORDetections]
    counts: dict[str, int]
    skeleton: Skeleton = MVOR_SKELETON
    room: np.ndarray = field(default_factory=lambda: np.full((4, 4), np.nan))

    @property
    def up(self) -> np.ndarray:
        """(3,) unit vector: the room's up direction in world (camera-1) coordinates; NaN without a room frame."""
        z = self.room[2, :3]
        return z / np.linalg.norm(z)

    @property
    def has3d(self) -> np.ndarray:
        """(F, P) bool: the person has at least one GT 3D joint."""
        return np.isfinite(self.joints3d[..., 0]).any(-1)

    def views_annotated(self) -> np.ndarray:
        """(F, P) int64: in how many views the person has a GT 2D annotation."""
        return np.isfinite(self.boxes2d[..., 0]).sum(1)

    def detected_keypoints(self, detector: str = "openpose") -> np.ndarray:
        """(F, V, P, J, 3) the linked detections of ``detector`` mapped to the 10 GT joints, laid out
        like ``keypoints2d`` (``[x, y, s]``; NaN x, y and s 0 where no detection is linked), ready
        for lifting person by person: ``detected_keypoints()[f, :, p][None]`` is (T=1, C, J, 3)."""
        F, V, P = self.boxes2d.shape[:3]
        out = np.zeros((F, V, P, len(MVOR_JOINTS), 3))
        out[..., :2] = np.nan
        m = self.detections[detector].mapped
        linked = m.track_id >= 0
        kp = m.keypoints[linked].copy()
        kp[kp[..., 2] <= 0] = [np.nan, np.nan, 0.0]
        out[m.frame[linked], m.camera[linked], m.track_id[linked]] = kp
        return out


def mvor_rig(cam_params: dict, source: str | Path = "camma_mvor_2018.json") -> Rig:
    """The 3 cameras from ``cameras_info.camParams`` (pinhole, no distortion, world = cam1 in metres)."""
    cams = []
    try:
        for c, name in enumerate(CAMERA_NAMES):
            intr = cam_params["intrinsics"][c]
            E = np.asarray(cam_params["extrinsics"][c], dtype=np.float64).reshape(4, 4)
            (fx, fy), (cx, cy) = intr["focallength"], intr["principalpoint"]
            K = np.array([[fx, intr.get("skew_value", 0.0), cx], [0, fy, cy], [0, 0, 1.0]])
            R = E[:3, :3].T  # extrinsics: camera c -> camera 1; the rig wants world (cam1) -> camera c
            cams.append(Camera(name, tuple(intr.get("imagesize", (640, 480))), K, R, -R @ E[:3, 3] / 1000.0,
                               np.zeros(5)))
    except (KeyError, IndexError, TypeError, ValueError) as e:
        raise InputError(f"cannot read the calibration: {e!r}", source=source, field="cameras_info.camParams") from None
    return Rig(cams)


def coco17_to_mvor(keypoints: np.ndarray) -> np.ndarray:
    """(..., 17, 3) COCO-17 ``[x, y, s]`` -> (..., 10, 3) MVOR joints by MVOR's own rule.

    Head: midpoint of the eyes if both are present, else of the ears, else the nose, else any
    single eye or ear. Neck: midpoint of the shoulders, or the one present. A midpoint's s is the
    mean of its two. The other 8 joints are copied. Absent (s <= 0) -> ``[0, 0, 0]``.
    """
    k = np.asarray(keypoints, dtype=np.float64)
    c = {n: k[..., i, :] for i, n in enumerate(COCO17.joints)}
    ok = {n: (v[..., 2] > 0)[..., None] for n, v in c.items()}

    def pair(a: str, b: str) -> tuple[np.ndarray, np.ndarray]:
        return (c[a] + c[b]) / 2, ok[a] & ok[b]

    zero = np.zeros_like(c["nose"])
    # candidates in order of preference; the first present wins
    head_candidates = [pair("left_eye", "right_eye"), pair("left_ear", "right_ear"), (c["nose"], ok["nose"])] + \
        [(c[n], ok[n]) for n in ("left_eye", "right_eye", "left_ear", "right_ear")]
    neck_candidates = [pair("left_shoulder", "right_shoulder"), (c["left_shoulder"], ok["left_shoulder"]),
                       (c["right_shoulder"], ok["right_shoulder"])]

    def first(cands):
        out = zero
        for v, m in reversed(cands):
            out = np.where(m, v, out)
        return out

    rest = [c[n] * ok[n] for n in MVOR_JOINTS[2:]]
    return np.stack([first(head_candidates), first(neck_candidates), *rest], axis=-2)


def _mean_distance(det: np.ndarray, gt: np.ndarray) -> np.ndarray:
    """(D, Q) mean pixel distance over joints present in both; (D, 10, 3) det ``[x, y, s]``, (Q, 10, 3)
    GT ``[x, y, v]`` (NaN x = absent); inf where no joint is shared."""
    both = (det[:, None, :, 2] > 0) & np.isfinite(gt[None, :, :, 0])
    d = np.linalg.norm(det[:, None, :, :2] - gt[None, :, :, :2], axis=-1)
    n = both.sum(-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        m = np.where(both, d, 0.0).sum(-1) / n
    return np.where(n > 0, m, np.inf)


def _inside_share(det: np.ndarray, boxes: np.ndarray) -> np.ndarray:
    """(D, K) share of each detection's found joints inside each ``[left, top, w, h]`` box (+10 % margin)."""
    found = det[:, None, :, 2] > 0
    m = 0.1 * boxes[None, :, None, 2:]
    lo, hi = boxes[None, :, None, :2] - m, boxes[None, :, None, :2] + boxes[None, :, None, 2:] + m
    inside = found & ((det[:, None, :, :2] >= lo) & (det[:, None, :, :2] <= hi)).all(-1)
    return inside.sum(-1) / np.maximum(found.sum(-1), 1)


def _read_detections(name: str, path: Path, image_index: dict[int, tuple[int, int]], kp2d: np.ndarray,
                     bbox_only: np.ndarray, max_match_px: float) -> MVORDetections:
    doc = load_json(path)
    if not isinstance(doc, list):
        raise InputError("must be a list of detections", source=path)
    n = len(doc)
    fv = np.full((n, 2), -1, np.int64)
    coco = np.zeros((n, 17, 3))
    score = np.zeros(n)
    counts = {"entries": n, "unknown_image": 0}
    for i, d in enumerate(doc):
        try:
            flat = np.asarray(d["coco_keypoints"], dtype=np.float64)
            coco[i] = flat.reshape(17, 3)
            score[i] = float(d["score"])
            img = int(d["image_id"])
        except (KeyError, TypeError, ValueError) as e:
            raise InputError(f"not a detection with 17 COCO keypoints: {e!r}", source=path, field=f"[{i}]") from None
        if img in image_index:
            fv[i] = image_index[img]
        else:
            counts["unknown_image"] += 1
    keep = fv[:, 0] >= 0
    fv, coco, score = fv[keep], coco[keep], score[keep]
    coco[coco[..., 2] <= 0] = 0.0
    mapped = coco17_to_mvor(coco)
    track = np.full(len(fv), -1, np.int64)
    match_px = np.full(len(fv), np.nan)
    repeated = np.zeros(len(fv), bool)
    gt_absent = kp2d[..., 2] <= 0
    gt = np.where(gt_absent[..., None], np.nan, kp2d)  # (F, V, P, J, 3)
    order = np.lexsort((fv[:, 1], fv[:, 0]))
    keys = fv[order, 0] * 3 + fv[order, 1]
    starts = np.flatnonzero(np.r_[True, np.diff(keys) != 0])
    for s, e in zip(starts, np.r_[starts[1:], len(order)]):
        rows = order[s:e]
        f, v = fv[rows[0]]
        flat = coco[rows].reshape(len(rows), -1)
        same = (flat[:, None] == flat[None]).all(-1)
        repeated[rows] = np.triu(same, 1).any(0)
        cost = _mean_distance(mapped[rows], gt[f, v])
        cost = np.where(cost <= max_match_px, cost, np.inf)
        ok_r, ok_c = np.isfinite(cost).any(1), np.isfinite(cost).any(0)
        if not ok_r.any():
            continue
        sub = np.where(np.isfinite(cost[np.ix_(ok_r, ok_c)]), cost[np.ix_(ok_r, ok_c)], 1e9)
        r, c = linear_sum_assignment(sub)
        good = sub[r, c] < 1e9
        rr, cc = np.flatnonzero(ok_r)[r[good]], np.flatnonzero(ok_c)[c[good]]
        track[rows[rr]] = cc
        match_px[rows[rr]] = cost[rr, cc]
    in_box = np.zeros(len(fv), bool)
    for r in np.flatnonzero(track < 0):
        b = bbox_only[(bbox_only[:, 0] == fv[r, 0]) & (bbox_only[:, 1] == fv[r, 1]), 2:]
        in_box[r] = len(b) > 0 and _inside_share(mapped[r:r + 1], b).max() >= 0.8
    counts.update(linked=int((track >= 0).sum()), unlinked=int((track < 0).sum()), in_bbox_only=int(in_box.sum()),
                  repeated=int(repeated.sum()))
    cams = CAMERA_NAMES
    nan_box = np.full((len(fv), 4), np.nan)
    poses = Poses2D(fv[:, 0], fv[:, 1], track, coco, nan_box, COCO17, cams)
    mp = Poses2D(fv[:, 0], fv[:, 1], track, mapped, nan_box.copy(), MVOR_SKELETON, cams)
    return MVORDetections(name, poses, mp, score, match_px, repeated, in_box, counts)


def read_mvor(folder: str | Path | None = None, detectors: tuple[str, ...] = ("openpose", "rtpose"),
              max_match_px: float = 50.0) -> MVOR:
    """Read MVOR from ``folder`` (default :func:`default_folder`, i.e. ``../shared/data/mvor``).

    ``max_match_px``: the largest mean joint distance at which a detection is linked to a GT
    person. 50 px is the README's limit; ``np.inf`` links every detection it can one-to-one
    (wrong detections then count as the person's, as in the README's no-limit baseline).
    """
    folder = Path(folder) if folder is not None else default_folder()
    if folder is None:
        raise InputError("MVOR not found: pass its folder or set GYMTRACK_MVOR", source="shared/data/mvor")
    path = folder / "camma_mvor_2018.json"
    doc = load_json(path)
    try:
        rig = mvor_rig(doc["cameras_info"]["camParams"], path)
        mv = doc["multiview_images"]
        frame_ids = tuple(str(m["id"]) for m in mv)
        image_ids = np.array([[int(im["id"]) for im in m["images"]] for m in mv], np.int64).reshape(len(mv), 3)
        day = np.array([int(m["images"][0]["day_id"]) for m in mv], np.int64)
        ann2d, ann3d = doc["annotations"], doc["annotations3D"]
    except (KeyError, TypeError, ValueError) as e:
        raise InputError(f"not the MVOR annotation file: {e!r}", source=path) from None
    F, V, J = len(frame_ids), 3, len(MVOR_JOINTS)
    image_index = {int(i): (f, v) for (f, v), i in np.ndenumerate(image_ids)}
    frame_index = {fid: f for f, fid in enumerate(frame_ids)}
    counts = dict.fromkeys(("annotations_2d", "bbox_only", "duplicate_2d", "annotations_3d", "duplicate_3d",
                            "placeholder_points_3d", "missing_joints_3d", "unknown_frame"), 0)
    # person slots: the person_ids each frame uses, in 2D or 3D
    ids: list[set[int]] = [set() for _ in range(F)]
    for a in ann2d:
        if a.get("person_id", -1) >= 0 and a["image_id"] in image_index:
            ids[image_index[a["image_id"]][0]].add(int(a["person_id"]))
    for a in ann3d:
        if a["image_ids"] in frame_index:
            ids[frame_index[a["image_ids"]]].add(int(a["person_id"]))
    P = max((len(s) for s in ids), default=0)
    person_id = np.full((F, P), -1, np.int64)
    slot = {}
    for f, s in enumerate(ids):
        for p, pid in enumerate(sorted(s)):
            person_id[f, p] = pid
            slot[f, pid] = p
    joints3d = np.full((F, P, J, 3), np.nan)
    kp2d = np.zeros((F, V, P, J, 3))
    kp2d[..., :2] = np.nan
    boxes = np.full((F, V, P, 4), np.nan)
    bbox_only = []
    for a in ann2d:
        if a["image_id"] not in image_index:
            counts["unknown_frame"] += 1
            continue
        f, v = image_index[a["image_id"]]
        if a.get("person_id", -1) < 0:
            counts["bbox_only"] += 1
            bbox_only.append([f, v, *a["bbox"]])
            continue
        p = slot[f, int(a["person_id"])]
        if np.isfinite(boxes[f, v, p, 0]):
            counts["duplicate_2d"] += 1
            continue
        counts["annotations_2d"] += 1
        k = np.asarray(a["keypoints"], np.float64).reshape(J, 3)
        k[k[:, 2] <= 0] = [np.nan, np.nan, 0.0]
        kp2d[f, v, p], boxes[f, v, p] = k, a["bbox"]
    for a in ann3d:
        if a["image_ids"] not in frame_index:
            counts["unknown_frame"] += 1
            continue
        f = frame_index[a["image_ids"]]
        p = slot[f, int(a["person_id"])]
        if np.isfinite(joints3d[f, p]).any():
            counts["duplicate_3d"] += 1
            continue
        counts["annotations_3d"] += 1
        k = np.asarray(a["keypoints3D"], np.float64).reshape(-1, 4)
        counts["placeholder_points_3d"] += len(k) - J  # points 11-12: not named, often wrist + 50 mm
        xyz = k[:J, :3] / 1000.0
        # (0, 0, 0) is a missing joint; (50, 50, 50) is the +50 mm placeholder of one (a neck in frame
        # 20010000114_..., not in the README)
        missing = (k[:J, :3] == 0).all(1) | (k[:J, :3] == 50).all(1)
        counts["missing_joints_3d"] += int(missing.sum())
        xyz[missing] = np.nan
        joints3d[f, p] = xyz
    bbox_only = np.array(bbox_only, np.float64).reshape(-1, 6)
    for name in detectors:
        if name not in DETECTORS:
            raise InputError(f"unknown MVOR detector {name!r}; known: {', '.join(DETECTORS)}", field="detectors")
    dets = {name: _read_detections(name, folder / DETECTORS[name], image_index, kp2d, bbox_only, max_match_px)
            for name in detectors}
    room = np.full((4, 4), np.nan)
    to_room = doc["cameras_info"]["camParams"].get("firstCamToRoomRef")
    if to_room is not None:
        try:
            room = np.asarray(to_room, np.float64).reshape(4, 4)
        except ValueError:
            raise InputError("must be 16 numbers (a 4x4 matrix)", source=path, field="firstCamToRoomRef") from None
        room[:3, 3] /= 1000.0  # mm -> m
    return MVOR(rig, frame_ids, image_ids, day, person_id, joints3d, kp2d, boxes, bbox_only, dets, counts, room=room)
