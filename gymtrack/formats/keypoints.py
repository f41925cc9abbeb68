"""2D pose files: what a pose model found in each view (``shared/formats.md``, keypoints/<camera>.json).

The paper (Yang et al., Section III-D, "Identify Target Gymnast for Pose Estimation") runs a
top-down pose model (HRNet) in the target's expanded boxes ``b_buf`` (Eq. 14) and triangulates
the joints; these readers bring such 2D poses in from files. Three layouts are read:

* **native** JSON ``{"skeleton": "coco17" | "body25" | "halpe26", "poses": [...]}`` (or
  ``"joints": [name, ...]`` instead of ``skeleton``), each pose ``{"frame", "keypoints": [[x, y,
  score] * J], "bbox"?: [left, top, w, h], "track_id"?}``. An ``x`` or ``y`` of ``null``/NaN is a
  joint not found (its score is read as 0);
* **COCO keypoint results** (mmpose, COCO evaluation): a JSON list of ``{"image_id": frame,
  "keypoints": [x1, y1, s1, ...], "score", "bbox"}``; the skeleton is an argument or inferred
  from the number of joints (17 coco17, 25 body25, 26 halpe26). The per-pose ``score`` is not kept;
* **OpenPose** folders ``<camera>/*_<12-digit frame>_keypoints.json`` with
  ``people[].pose_keypoints_2d`` (BODY_25, 75 numbers), the layout Pose2Sim reads. No box.

Poses whose joints are all missing are **kept** (all scores 0), never dropped, so whoever uses the
poses can count them (``(~poses.found()).all(axis=1).sum()``). Any problem raises
:class:`gymtrack.errors.InputError` naming the file, the pose (``poses[3]``, ``[3]`` or
``people[3]`` in an OpenPose file) and the field. Scores must be finite and >= 0 (values above 1
are accepted: OpenPose's reach 1.02). Frames are integers >= 0.

Arrays: keypoints (N, J, 3) ``[x, y, score]`` raw pixels; bbox (N, 4) ``[left, top, w, h]``.
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
from ..skeletons import BODY25, SKELETONS, Skeleton, custom_skeleton, get_skeleton
from .textfile import read_text, what_is

OPENPOSE_NAME = re.compile(r"_(\d{12})_keypoints\.json$")
_BY_COUNT = {len(s.joints): s for s in SKELETONS.values()}


class _Rows:
    """Columns of the poses of one file, built pose by pose (the checks need Python anyway)."""

    def __init__(self) -> None:
        self.frame: list[int] = []
        self.track_id: list[int] = []
        self.keypoints: list[np.ndarray] = []
        self.bbox: list[np.ndarray] = []

    def add(self, frame: int, keypoints: np.ndarray, bbox: np.ndarray, track_id: int = -1) -> None:
        self.frame.append(frame)
        self.keypoints.append(keypoints)
        self.bbox.append(bbox)
        self.track_id.append(track_id)

    def poses(self, skeleton: Skeleton, camera_index: int, camera_names: Sequence[str]) -> Poses2D:
        n, J = len(self.frame), len(skeleton.joints)
        return Poses2D(np.array(self.frame, np.int64), np.full(n, camera_index, np.int64),
                       np.array(self.track_id, np.int64),
                       np.stack(self.keypoints) if n else np.zeros((0, J, 3)),
                       np.stack(self.bbox) if n else np.zeros((0, 4)), skeleton, tuple(camera_names))


def _is_number(v: Any) -> bool:
    return isinstance(v, (int, float)) and not isinstance(v, bool)


def _integer(v: Any, what: str, src: Path, field: str, minimum: int) -> int:
    if isinstance(v, float) and math.isfinite(v) and v == int(v):
        v = int(v)  # 12.0 is frame 12; 12.5 is not a frame
    if not isinstance(v, int) or isinstance(v, bool):
        raise InputError(f"{what} must be an integer, got {v!r}", source=src, field=field)
    if not minimum <= v < 2**62:
        raise InputError(f"{what} must be in [{minimum}, 2^62), got {v}", source=src, field=field)
    return v


def _triples(flat: list, J: int, src: Path, field: str) -> np.ndarray:
    """(J, 3) ``[x, y, score]`` from a flat list of 3*J values; None/NaN x or y = not found."""
    out = np.empty(3 * J)
    for i, v in enumerate(flat):
        if v is None and i % 3 < 2:
            out[i] = np.nan
            continue
        if not _is_number(v):
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


def _bbox(v: Any, src: Path, field: str) -> np.ndarray:
    if v is None:
        return np.full(4, np.nan)
    if not isinstance(v, list) or len(v) != 4 or not all(_is_number(x) for x in v):
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


def _read_native(doc: dict, path: Path, camera_index: int, camera_names: Sequence[str]) -> Poses2D:
    sk = _native_skeleton(doc, path)
    J = len(sk.joints)
    poses = doc.get("poses")
    if not isinstance(poses, list):
        raise InputError(f"must be a list of poses, got {what_is(poses)}", source=path, field="poses")
    rows = _Rows()
    for i, p in enumerate(poses):
        f = f"poses[{i}]"
        if not isinstance(p, dict):
            raise InputError(f"must be an object, got {p!r}", source=path, field=f)
        if "frame" not in p:
            raise InputError("missing", source=path, field=f"{f}.frame")
        frame = _integer(p["frame"], "frame", path, f"{f}.frame", 0)
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
        kp = _triples(flat, J, path, f"{f}.keypoints")
        track = p.get("track_id", -1)
        track = -1 if track is None else _integer(track, "track_id", path, f"{f}.track_id", -1)
        rows.add(frame, kp, _bbox(p.get("bbox"), path, f"{f}.bbox"), track)
    return rows.poses(sk, camera_index, camera_names)


# -------------------------------------------------------------------------------------------- COCO
def _read_coco(doc: list, path: Path, camera_index: int, camera_names: Sequence[str],
               skeleton: Skeleton | None) -> tuple[Poses2D, bool]:
    """The poses and whether the skeleton was determined (given, or inferred from a pose)."""
    rows, sk = _Rows(), skeleton
    for i, p in enumerate(doc):
        f = f"[{i}]"
        if not isinstance(p, dict):
            raise InputError(f"must be an object, got {p!r}", source=path, field=f)
        if "image_id" not in p:
            raise InputError("missing (the frame number)", source=path, field=f"{f}.image_id")
        frame = _integer(p["image_id"], "image_id (the frame)", path, f"{f}.image_id", 0)
        flat = p.get("keypoints")
        if not isinstance(flat, list) or len(flat) % 3 or not flat:
            got = f"{len(flat)} values" if isinstance(flat, list) else repr(flat)
            raise InputError(f"must be a flat list [x1, y1, s1, ...], got {got}", source=path, field=f"{f}.keypoints")
        J = len(flat) // 3
        if sk is None:
            if J not in _BY_COUNT:
                raise InputError(f"{J} joints: give the skeleton (17 = coco17, 25 = body25, 26 = halpe26 are inferred)",
                                 source=path, field=f"{f}.keypoints")
            sk = _BY_COUNT[J]
        if J != len(sk.joints):
            raise InputError(f"{J} joints, expected {len(sk.joints)} ({sk.name})", source=path, field=f"{f}.keypoints")
        kp = _triples(flat, J, path, f"{f}.keypoints")
        rows.add(frame, kp, _bbox(p.get("bbox"), path, f"{f}.bbox"))
    known = sk is not None
    return rows.poses(sk if known else get_skeleton("coco17"), camera_index, camera_names), known


# ---------------------------------------------------------------------------------------- OpenPose
def _read_openpose(folder: Path, camera_index: int, camera_names: Sequence[str]) -> Poses2D:
    rows, J = _Rows(), len(BODY25.joints)
    for path in sorted(folder.iterdir()):
        if path.name.startswith("."):
            continue  # hidden files (.DS_Store) are not OpenPose output
        m = OPENPOSE_NAME.search(path.name)
        if m is None or not path.is_file():
            raise InputError("not an OpenPose file '*_<12-digit frame>_keypoints.json'", source=path)
        frame = int(m.group(1))
        doc = load_json(path)
        people = doc.get("people") if isinstance(doc, dict) else None
        if not isinstance(people, list):
            raise InputError("must be an object with a list 'people'", source=path, field="people")
        for i, p in enumerate(people):
            f = f"people[{i}].pose_keypoints_2d"
            flat = p.get("pose_keypoints_2d") if isinstance(p, dict) else None
            if not isinstance(flat, list) or len(flat) != 3 * J:
                got = f"{len(flat)} values" if isinstance(flat, list) else repr(flat)
                raise InputError(f"must hold {3 * J} values (BODY_25), got {got}", source=path, field=f)
            rows.add(frame, _triples(flat, J, path, f), np.full(4, np.nan))
    return rows.poses(BODY25, camera_index, camera_names)


# ------------------------------------------------------------------------------------------- API
def _read_file(path: Path, camera_index: int, camera_names: Sequence[str],
               skeleton: Skeleton | str | None) -> tuple[Poses2D, bool]:
    sk = get_skeleton(skeleton) if isinstance(skeleton, str) else skeleton
    if path.is_dir():
        return _read_openpose(path, camera_index, camera_names), True
    doc = load_json(path)
    if isinstance(doc, list):
        return _read_coco(doc, path, camera_index, camera_names, sk)
    if isinstance(doc, dict):
        poses = _read_native(doc, path, camera_index, camera_names)
        return poses, True
    raise InputError("must be a native keypoints object or a COCO results list", source=path)


def read_keypoints_file(path: str | Path, camera_index: int, camera_names: Sequence[str],
                        skeleton: Skeleton | str | None = None) -> Poses2D:
    """The poses of one camera: a native or COCO-results JSON file, or an OpenPose folder.

    ``skeleton`` only matters for COCO results (default: inferred from the joint count; an empty
    list gives coco17). Every row gets ``camera = camera_index``.
    """
    return _read_file(Path(path), camera_index, camera_names, skeleton)[0]


def read_keypoints(path_or_folder: str | Path, camera_names: Sequence[str],
                   skeleton: Skeleton | str | None = None) -> Poses2D:
    """All cameras' poses from a routine's ``keypoints/`` folder, sorted by (frame, camera).

    Per camera the folder holds ``<camera>.json`` or an OpenPose folder ``<camera>/`` (not both).
    A camera with neither, or an entry naming no camera, is an error. A single file is read as the
    camera its name (``<camera>.json``) gives. All cameras must use the same skeleton.
    """
    root = Path(path_or_folder)
    camera_names = tuple(camera_names)
    if not camera_names:
        raise InputError("no camera names given", source=root)
    if not root.exists():
        raise InputError("keypoints folder not found", source=root)
    if root.is_file():
        if root.stem not in camera_names:
            raise InputError(f"file name must be <camera>.json with a camera of {list(camera_names)}", source=root)
        return read_keypoints_file(root, camera_names.index(root.stem), camera_names, skeleton).sorted()
    sources = []
    for c, name in enumerate(camera_names):
        file, folder = root / f"{name}.json", root / name
        if file.is_file() and folder.is_dir():
            raise InputError(f"camera {name!r} has both {file.name} and an OpenPose folder {name}/; keep one",
                             source=root)
        if not file.is_file() and not folder.is_dir():
            raise InputError(f"no keypoints for camera {name!r}: expected {name}.json or an OpenPose folder {name}/",
                             source=root)
        sources.append(file if file.is_file() else folder)
    known = set(camera_names) | {f"{n}.json" for n in camera_names}
    for entry in sorted(root.iterdir()):
        if not entry.name.startswith(".") and entry.name not in known:
            raise InputError(f"names no camera of {list(camera_names)} (expected <camera>.json or <camera>/)",
                             source=entry)
    parts = [_read_file(src, c, camera_names, skeleton) for c, src in enumerate(sources)]
    determined = [(p.skeleton, src) for (p, ok), src in zip(parts, sources) if ok]
    common = determined[0][0] if determined else parts[0][0].skeleton
    for sk, src in determined:
        if sk != common:
            raise InputError(f"skeleton {sk.name} ({len(sk.joints)} joints) differs from {common.name} "
                             f"({len(common.joints)} joints) of {determined[0][1]}; all cameras must agree", source=src)
    # an empty COCO list has no skeleton of its own: it takes the others'
    out = [p if ok else Poses2D.empty(common, camera_names) for p, ok in parts]
    return Poses2D.concat(out).sorted()


def _num(v: float, digits: int) -> float | None:
    return round(float(v), digits) if math.isfinite(v) else None


def write_keypoints(folder: str | Path, poses: Poses2D) -> list[Path]:
    """Native ``<folder>/<camera>.json`` for every camera of ``poses`` (empty ``poses`` lists for
    cameras without any); pixels to 2 decimals, scores to 4 significant digits; missing x/y as
    ``null``; ``track_id`` written when >= 0, ``bbox`` when known. Returns the paths written."""
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    sk = poses.skeleton
    head: dict[str, Any] = {"skeleton": sk.name} if sk.name in SKELETONS else {"joints": list(sk.joints)}
    p = poses.sorted()
    out = []
    for c, name in enumerate(p.camera_names):
        rows = np.flatnonzero(p.camera == c)
        items = []
        for r in rows:
            kp = p.keypoints[r]
            item: dict[str, Any] = {"frame": int(p.frame[r]), "keypoints": [
                [_num(x, 2), _num(y, 2), float(f"{s:.4g}") if math.isfinite(s) and s > 0 else 0.0] for x, y, s in kp]}
            if np.isfinite(p.bbox[r]).all():
                item["bbox"] = [round(float(v), 2) for v in p.bbox[r]]
            if p.track_id[r] >= 0:
                item["track_id"] = int(p.track_id[r])
            items.append(json.dumps(item, allow_nan=False))
        path = folder / f"{name}.json"
        body = ",\n    ".join(items)
        text = json.dumps(head)[:-1] + ', "poses": [\n    ' + body + "\n  ]}\n" if items else \
            json.dumps({**head, "poses": []}) + "\n"
        path.write_text(text, encoding="utf-8")
        out.append(path)
    return out
