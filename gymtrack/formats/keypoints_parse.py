"""The pieces every 2D pose reader shares: checked numbers, rows, and the native and COCO layouts.

Rule (``shared/formats.md``, keypoints): what the readers of :mod:`.keypoints` and
:mod:`.keypoints_tools` accept, each problem an :class:`~gymtrack.errors.InputError` naming the
file, the pose and the field. Arrays: keypoints (J, 3) ``[x, y, score]`` per pose, raw pixels.
"""

from __future__ import annotations

import json
import math
import re
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..errors import InputError
from ..poses import Poses2D
from ..skeletons import SKELETONS, Skeleton, custom_skeleton, get_skeleton
from .textfile import read_text, what_is

_NUMBER = re.compile(r"\d+")
_PLAIN = {float, int}


class PoseRows:
    """Columns of the poses of one camera, built pose by pose (the checks need Python anyway).

    ``J``: joints per pose in the file; ``skeleton``: the one the file declares (None: not said);
    ``source``/``joint_field``: where the first pose's joints are (for messages)."""

    def __init__(self, source: Path, skeleton: Skeleton | None = None) -> None:
        self.source, self.skeleton = source, skeleton
        self.J: int | None = None
        self.joint_field: str | None = None
        self.joint_source: Path = source
        self.frame: list[int] = []
        self.track_id: list[int] = []
        self.keypoints: list[np.ndarray] = []
        self.bbox: list[np.ndarray] = []

    def joints(self, J: int, field: str) -> None:
        """Every pose of a file has the same joint count."""
        if self.J is None:
            self.J, self.joint_field, self.joint_source = J, field, self.source
        elif J != self.J:
            raise InputError(f"{J} joints, but {self.joint_field} has {self.J}; every pose needs the same joints",
                             source=self.source, field=field)

    def add(self, frame: int, keypoints: np.ndarray, bbox: np.ndarray, track_id: int = -1) -> None:
        self.frame.append(frame)
        self.keypoints.append(keypoints)
        self.bbox.append(bbox)
        self.track_id.append(track_id)

    def array(self) -> np.ndarray:
        return np.stack(self.keypoints) if self.frame else np.zeros((0, self.J or 0, 3))

    def poses(self, skeleton: Skeleton, camera_index: int, camera_names: Sequence[str]) -> Poses2D:
        n, J = len(self.frame), len(skeleton.joints)
        return Poses2D(np.array(self.frame, np.int64), np.full(n, camera_index, np.int64),
                       np.array(self.track_id, np.int64),
                       self.array()[:, :J] if n else np.zeros((0, J, 3)),
                       np.stack(self.bbox) if n else np.zeros((0, 4)), skeleton, tuple(camera_names))


def frame_from_name(name: str) -> int | None:
    """The frame a name carries: its last number (``cam01.0031.json`` -> 31,
    ``run_000000000012_keypoints.json`` -> 12, ``"000051.jpg"`` -> 51); None without a number."""
    found = _NUMBER.findall(name)
    return int(found[-1]) if found else None


def is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def integer(v: Any, what: str, src: Path, field: str, minimum: int) -> int:
    if isinstance(v, float) and math.isfinite(v) and v == int(v):
        v = int(v)  # 12.0 is frame 12; 12.5 is not a frame
    if not isinstance(v, int) or isinstance(v, bool):
        raise InputError(f"{what} must be an integer, got {v!r}", source=src, field=field)
    if not minimum <= v < 2**62:
        raise InputError(f"{what} must be in [{minimum}, 2^62), got {v}", source=src, field=field)
    return v


def triples(flat: list, J: int, src: Path, field: str) -> np.ndarray:
    """(J, 3) ``[x, y, score]`` from a flat list of 3*J values; None/NaN x or y = not found."""
    if set(map(type, flat)) <= _PLAIN:  # the usual file: plain numbers, one numpy call
        out = np.array(flat, dtype=np.float64)
    else:
        out = np.empty(3 * J)
        for i, v in enumerate(flat):
            if v is None and i % 3 < 2:
                out[i] = np.nan
                continue
            if not is_number(v):
                raise InputError(f"joint {i // 3} {'xys'[i % 3]} must be a number, got {v!r}", source=src, field=field)
            out[i] = v
    kp = out.reshape(J, 3)
    if np.isinf(kp[:, :2]).any():
        raise InputError(f"joint {int(np.isinf(kp[:, :2]).any(1).argmax())} has an infinite coordinate",
                         source=src, field=field)
    bad = ~np.isfinite(kp[:, 2]) | (kp[:, 2] < 0)
    if bad.any():
        j = int(bad.argmax())
        raise InputError(f"joint {j} score must be a finite number >= 0, got {kp[j, 2]!r}", source=src, field=field)
    kp[np.isnan(kp[:, :2]).any(1), 2] = 0.0
    return kp


def ltwh_box(v: Any, src: Path, field: str) -> np.ndarray:
    if v is None:
        return np.full(4, np.nan)
    if not isinstance(v, list) or len(v) != 4 or not all(is_number(x) for x in v):
        raise InputError(f"must be [left, top, width, height] (4 numbers) or null, got {v!r}", source=src, field=field)
    b = np.array(v, dtype=np.float64)
    if not np.isfinite(b).all() or b[2] < 0 or b[3] < 0:
        raise InputError(f"must be finite with width, height >= 0, got {v!r}", source=src, field=field)
    return b


def load_json(path: Path) -> Any:
    """The parsed JSON of ``path``; unreadable or invalid JSON raises InputError naming file and line."""
    text = read_text(path)
    try:
        return json.loads(text)
    except json.JSONDecodeError as e:
        raise InputError(f"not valid JSON: {e.msg} (column {e.colno})", source=path, line=e.lineno) from None
    except RecursionError:
        raise InputError("not valid JSON: nested too deeply", source=path) from None


# ------------------------------------------------------------------------------------------ native
def _native_skeleton(doc: dict, path: Path) -> Skeleton:
    name, joints = doc.get("skeleton"), doc.get("joints")
    if joints is not None:
        try:
            sk = custom_skeleton(joints)
        except InputError as e:
            raise e.located(source=path) from None
        named = SKELETONS.get(name) if isinstance(name, str) else None
        if name is not None and (named is None or named.joints != sk.joints):
            raise InputError(f"skeleton {name!r} does not match the given 'joints'", source=path, field="skeleton")
        # a known joint list is that skeleton, so files of the same model agree
        return next((s for s in SKELETONS.values() if s.joints == sk.joints), sk)
    if name is None:
        raise InputError("missing: give 'skeleton' (coco17, body25, halpe26) or 'joints'",
                         source=path, field="skeleton")
    try:
        return get_skeleton(name)
    except InputError as e:
        raise e.located(source=path) from None


def read_native(doc: dict, path: Path) -> PoseRows:
    sk = _native_skeleton(doc, path)
    J = len(sk.joints)
    poses = doc.get("poses")
    if not isinstance(poses, list):
        raise InputError(f"must be a list of poses, got {what_is(poses)}", source=path, field="poses")
    rows = PoseRows(path, sk)
    rows.J, rows.joint_field = J, "skeleton"
    for i, p in enumerate(poses):
        f = f"poses[{i}]"
        if not isinstance(p, dict):
            raise InputError(f"must be an object, got {p!r}", source=path, field=f)
        if "frame" not in p:
            raise InputError("missing", source=path, field=f"{f}.frame")
        frame = integer(p["frame"], "frame", path, f"{f}.frame", 0)
        kps = p.get("keypoints")
        if not isinstance(kps, list) or len(kps) != J:
            got = f"{len(kps)} joints" if isinstance(kps, list) else repr(kps)
            raise InputError(f"must hold {J} joints [x, y, score] ({sk.name}), got {got}", source=path,
                             field=f"{f}.keypoints")
        flat = []
        for j, k in enumerate(kps):
            if not isinstance(k, list) or len(k) != 3:
                raise InputError(f"must be [x, y, score], got {k!r}", source=path, field=f"{f}.keypoints[{j}]")
            flat.extend(k)
        kp = triples(flat, J, path, f"{f}.keypoints")
        track = p.get("track_id", -1)
        track = -1 if track is None else integer(track, "track_id", path, f"{f}.track_id", -1)
        rows.add(frame, kp, ltwh_box(p.get("bbox"), path, f"{f}.bbox"), track)
    return rows


# -------------------------------------------------------------------------------------------- COCO
def image_frame(v: Any, src: Path, field: str) -> int:
    """A COCO ``image_id`` as a frame: an integer, a numeric string, or a name's last number."""
    if isinstance(v, str):
        f = frame_from_name(v)
        if f is None:
            raise InputError(f"image_id {v!r} holds no frame number: name the images by frame (000051.jpg) "
                             "or write the frame as image_id", source=src, field=field)
        v = f
    return integer(v, "image_id (the frame)", src, field, 0)


def read_coco(doc: list, path: Path) -> PoseRows:
    rows = PoseRows(path)
    for i, p in enumerate(doc):
        f = f"[{i}]"
        if not isinstance(p, dict):
            raise InputError(f"must be an object, got {p!r}", source=path, field=f)
        if "image_id" not in p:
            raise InputError("missing (the frame number)", source=path, field=f"{f}.image_id")
        frame = image_frame(p["image_id"], path, f"{f}.image_id")
        flat = p.get("keypoints")
        if not isinstance(flat, list) or len(flat) % 3 or not flat:
            got = f"{len(flat)} values" if isinstance(flat, list) else repr(flat)
            raise InputError(f"must be a flat list [x1, y1, s1, ...], got {got}", source=path, field=f"{f}.keypoints")
        rows.joints(len(flat) // 3, f"{f}.keypoints")
        rows.add(frame, triples(flat, len(flat) // 3, path, f"{f}.keypoints"), ltwh_box(p.get("bbox"), path, f"{f}.bbox"))
    return rows


