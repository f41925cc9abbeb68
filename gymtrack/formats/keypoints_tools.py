"""2D pose outputs of real tools, as they write them: OpenPose folders and MMPose's predictions.

Rule (``shared/formats.md``, keypoints, "Also read"):

* **OpenPose folders** (OpenPose ``--write_json``; Pose2Sim's ``pose/<camera>_json/``; rtmlib's
  poses as Pose2Sim and Sports2D save them): one JSON file a frame, ``{"people": [{"person_id",
  "pose_keypoints_2d": [x1, y1, c1, ...]}, ...]}``. The frame is the last number in the file name,
  whatever the naming (``<video>_000000000012_keypoints.json``, ``cam01.0031.json``,
  ``Static_cam_01.00001.json``); files are taken in frame order; two files of one frame are an
  error. Any joint count (BODY_25, BODY_25B, COCO-18, HALPE_26, COCO-WholeBody...): which
  skeleton it is, is decided by :mod:`.keypoints`. OpenPose files carry no box.
* **MMPose** ``--save-predictions`` (``demo/topdown_demo_with_mmdet.py``, ``demo/inferencer_demo.py``):
  ``{"meta_info": {..., "keypoint_id2name": {"0": "nose", ...}}, "instance_info": [{"frame_id",
  "instances": [{"keypoints": [[x, y], ...], "keypoint_scores": [...], "bbox": [[x1, y1, x2, y2]],
  "bbox_score"}]}]}``, or the inferencer's list of ``{"frame_id", "instances"}``; ``frame_id`` is the
  frame (MMPose's demos count video frames from 1). For one image (``instance_info`` a list of
  instances) the frame is the last number in the file name. ``keypoint_id2name`` names the joints.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from ..errors import InputError
from ..skeletons import SKELETONS, WHOLEBODY_BODY_JOINTS, WHOLEBODY_JOINT_COUNT, Skeleton, custom_skeleton
from .keypoints_parse import PoseRows, frame_from_name, integer, is_number, load_json, triples
from .textfile import what_is

__all__ = ["read_openpose_folder", "is_mmpose", "read_mmpose"]


def read_openpose_folder(folder: Path) -> PoseRows:
    """The poses of an OpenPose-style folder (module docstring), frames in order."""
    files: dict[int, Path] = {}
    for path in sorted(folder.iterdir()):
        if path.name.startswith("."):
            continue  # hidden files (.DS_Store) are not pose output
        if not path.is_file() or path.suffix.lower() != ".json":
            raise InputError("not a JSON file: an OpenPose folder holds only its per-frame JSON files; move it out",
                             source=path)
        frame = frame_from_name(path.stem)
        if frame is None:
            raise InputError("no frame number in the file name (the frame is the name's last number, as in "
                             "cam01.0031.json or video_000000000031_keypoints.json): rename it", source=path)
        if frame in files:
            raise InputError(f"frame {frame} again (also {files[frame].name}): one file a frame", source=path)
        files[frame] = path
    rows = PoseRows(folder)
    for frame in sorted(files):
        path = files[frame]
        doc = load_json(path)
        people = doc.get("people") if isinstance(doc, dict) else None
        if not isinstance(people, list):
            raise InputError("must be an object with a list 'people' (OpenPose --write_json)", source=path,
                             field="people")
        for i, p in enumerate(people):
            f = f"people[{i}].pose_keypoints_2d"
            flat = p.get("pose_keypoints_2d") if isinstance(p, dict) else None
            if not isinstance(flat, list) or not flat or len(flat) % 3:
                got = f"{len(flat)} values" if isinstance(flat, list) else what_is(flat)
                raise InputError(f"must hold x, y, score per joint (a multiple of 3 values), got {got}", source=path,
                                 field=f)
            rows.source = path
            rows.joints(len(flat) // 3, f)
            rows.add(frame, triples(flat, len(flat) // 3, path, f), np.full(4, np.nan))
    rows.source = folder
    return rows


def is_mmpose(doc: Any) -> bool:
    """``doc`` is MMPose's predictions (a dict with ``instance_info``, or a list of ``{frame_id, instances}``)."""
    if isinstance(doc, dict):
        return "instance_info" in doc
    return isinstance(doc, list) and bool(doc) and isinstance(doc[0], dict) and "instances" in doc[0]


def _declared(meta: Any, path: Path, J: int | None) -> Skeleton | None:
    """The skeleton MMPose's ``meta_info.keypoint_id2name`` names (None when absent)."""
    if not isinstance(meta, dict) or not isinstance(meta.get("keypoint_id2name"), dict):
        return None
    id2name = meta["keypoint_id2name"]
    try:
        names = [str(id2name[k]) for k in sorted(id2name, key=lambda k: int(k))]
    except (TypeError, ValueError):
        raise InputError("keys must be joint numbers", source=path, field="meta_info.keypoint_id2name") from None
    if len(names) == WHOLEBODY_JOINT_COUNT and tuple(names[:len(WHOLEBODY_BODY_JOINTS)]) == WHOLEBODY_BODY_JOINTS:
        return SKELETONS["coco_wholebody"]
    known = next((s for s in SKELETONS.values() if s.joints == tuple(names)), None)
    if known is not None:
        return known
    try:
        return custom_skeleton(names)
    except InputError as e:
        raise e.located(source=path, field_prefix="meta_info.keypoint_id2name") from None


def _instance(rows: PoseRows, frame: int, inst: Any, path: Path, f: str) -> None:
    if not isinstance(inst, dict):
        raise InputError(f"must be an object, got {what_is(inst)}", source=path, field=f)
    kps, sc = inst.get("keypoints"), inst.get("keypoint_scores")
    if not isinstance(kps, list) or not kps or not all(isinstance(k, list) and len(k) >= 2 for k in kps):
        raise InputError(f"must be a list of [x, y] per joint, got {what_is(kps)}", source=path, field=f"{f}.keypoints")
    if not isinstance(sc, list) or len(sc) != len(kps):
        raise InputError(f"must hold one score per joint ({len(kps)}), got {what_is(sc)}", source=path,
                         field=f"{f}.keypoint_scores")
    flat = [v for k, s in zip(kps, sc) for v in (k[0], k[1], s)]
    rows.joints(len(kps), f"{f}.keypoints")
    kp = triples(flat, len(kps), path, f"{f}.keypoints")
    box = inst.get("bbox")
    if isinstance(box, list) and len(box) == 1 and isinstance(box[0], list):
        box = box[0]  # MMPose writes one box as [[x1, y1, x2, y2]]
    b = np.full(4, np.nan)
    if box is not None:
        if not isinstance(box, list) or len(box) != 4 or not all(is_number(v) for v in box):
            raise InputError(f"must be [x1, y1, x2, y2], got {box!r}", source=path, field=f"{f}.bbox")
        x1, y1, x2, y2 = (float(v) for v in box)
        if not np.isfinite([x1, y1, x2, y2]).all() or x2 < x1 or y2 < y1:
            raise InputError(f"must be finite corners with x2 >= x1, y2 >= y1, got {box!r}", source=path,
                             field=f"{f}.bbox")
        b = np.array([x1, y1, x2 - x1, y2 - y1])
    rows.add(frame, kp, b)


def read_mmpose(doc: Any, path: Path) -> PoseRows:
    """The poses of MMPose's predictions (module docstring)."""
    meta = doc.get("meta_info") if isinstance(doc, dict) else None
    frames = doc.get("instance_info") if isinstance(doc, dict) else doc
    base = "instance_info" if isinstance(doc, dict) else ""
    if not isinstance(frames, list):
        raise InputError(f"must be a list, got {what_is(frames)}", source=path, field=base or None)
    rows = PoseRows(path, _declared(meta, path, None))
    single = bool(frames) and isinstance(frames[0], dict) and "instances" not in frames[0]
    if single:  # one image's predictions: a list of instances
        frame = frame_from_name(path.stem)
        if frame is None:
            raise InputError("the predictions of one image: the frame is the last number in the file name, and "
                             "this name has none (rename it, e.g. cam1_000051.json)", source=path)
        for i, inst in enumerate(frames):
            _instance(rows, frame, inst, path, f"{base}[{i}]")
        return rows
    for i, fr in enumerate(frames):
        f = f"{base}[{i}]"
        if not isinstance(fr, dict) or "frame_id" not in fr or not isinstance(fr.get("instances"), list):
            raise InputError("must be {\"frame_id\": n, \"instances\": [...]}", source=path, field=f)
        frame = integer(fr["frame_id"], "frame_id", path, f"{f}.frame_id", 0)
        for k, inst in enumerate(fr["instances"]):
            _instance(rows, frame, inst, path, f"{f}.instances[{k}]")
    return rows
