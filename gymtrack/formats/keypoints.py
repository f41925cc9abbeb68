"""2D pose files: what a pose model found in each view (``shared/formats.md``, keypoints/<camera>.json).

The paper (Yang et al., Section III-D, "Identify Target Gymnast for Pose Estimation") runs a
top-down pose model (HRNet) in the target's expanded boxes ``b_buf`` (Eq. 14) and triangulates
the joints; these readers bring such 2D poses in from files, as the tools wrote them:

* **native** JSON ``{"skeleton": name, "poses": [...]}`` (or ``"joints": [name, ...]`` instead of
  ``skeleton``), each pose ``{"frame", "keypoints": [[x, y, score] * J], "bbox"?: [left, top, w,
  h], "track_id"?}``. An ``x`` or ``y`` of ``null``/NaN is a joint not found (score read as 0);
* **COCO keypoint results** (mmpose's and AlphaPose's ``results.json``, COCO evaluation): a JSON
  list of ``{"image_id", "keypoints": [x1, y1, s1, ...], "score", "bbox"}``. ``image_id`` is the
  frame: an integer, a numeric string (``"51"``) or a name whose last number is the frame
  (``"000051.jpg"``); ``category_id``, ``idx`` (AlphaPose's pose index) and ``score`` are not used;
* **MMPose** ``--save-predictions`` JSON (:mod:`.keypoints_tools`);
* **OpenPose** folders, one JSON file a frame with ``people[].pose_keypoints_2d`` (OpenPose itself,
  Pose2Sim, rtmlib through Pose2Sim/Sports2D), frame = the last number in the file name
  (:mod:`.keypoints_tools`).

Which skeleton the numbers are is given (``skeleton`` argument / ``--skeleton``, the native
``skeleton`` key, MMPose's joint names) or recognised from the joint count and the joints' layout
(:mod:`.skeleton_fit`); a 25-joint file is BODY_25 or BODY_25B by its layout, or an error asks the
user to say which. A COCO-WholeBody file (133 joints) is read into its 23 body joints.

Poses whose joints are all missing are **kept** (all scores 0). Scores must be finite and >= 0;
scores above 1 (OpenPose's heatmap peaks reach 1.04) are read as they are and counted
(:class:`KeypointsReport`); the pose stage clips them for weighting. Any problem raises
:class:`gymtrack.errors.InputError` naming the file, the pose (``poses[3]``, ``[3]``,
``people[3]``) and the field.

Arrays: keypoints (N, J, 3) ``[x, y, score]`` raw pixels; bbox (N, 4) ``[left, top, w, h]``.
"""
from __future__ import annotations

import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..errors import GymtrackWarning, InputError
from ..poses import Poses2D
from ..skeletons import COCO17, FILE_JOINTS, SKELETONS, Skeleton, custom_skeleton, get_skeleton
from .camera_match import match_cameras, strip_suffix
from .keypoints_parse import PoseRows, frame_from_name, image_frame, load_json, read_coco, read_native
from .keypoints_tools import is_mmpose, read_mmpose, read_openpose_folder
from .skeleton_fit import LayoutFit, candidates_for, clearly_better, rank_layouts

__all__ = ["KeypointsReport", "read_keypoints", "read_keypoints_file", "write_keypoints", "load_json",
           "frame_from_name", "image_frame", "keypoint_sources"]


@dataclass
class KeypointsReport:
    """What reading the 2D poses did, for the summary: where each camera's poses came from, which
    skeleton and why, scores above 1, joints read but not used."""

    sources: dict[str, Path] = field(default_factory=dict)
    matched_by: dict[str, str] = field(default_factory=dict)
    skeleton: str = ""
    skeleton_how: str = ""
    fits: list[LayoutFit] = field(default_factory=list)
    poses: int = 0
    scores_above_1: int = 0
    max_score: float = 0.0
    unused_joints: int = 0
    ignored: list[Path] = field(default_factory=list)

    def lines(self) -> list[str]:
        out = [f"camera {c} <- {p} (by {self.matched_by.get(c, 'name')})" for c, p in self.sources.items()]
        out.append(f"{self.poses} poses, skeleton {self.skeleton} ({self.skeleton_how})")
        out += [f"  layout {f.describe()}" for f in self.fits]
        if self.scores_above_1:
            out.append(f"{self.scores_above_1} joint scores above 1 (up to {self.max_score:.4g}): read, clipped to 1 "
                       "for weighting")
        if self.ignored:
            out.append(f"not read (beside the *_json folders): {', '.join(p.name for p in self.ignored)}")
        if self.unused_joints:
            out.append(f"{self.unused_joints} joints per pose not used (COCO-WholeBody's face and hands)")
        return out


def skeleton_arg(text: str) -> Skeleton:
    """``--skeleton``: a known name (``body25b``, ``HALPE_26``...) or the joint names in file order,
    comma-separated (``nose,neck,left_wrist,...``): any named joint list."""
    if "," in text:
        names = [n.strip() for n in text.split(",")]
        sk = custom_skeleton(names)
        return next((s for s in SKELETONS.values() if s.joints == sk.joints), sk)
    return get_skeleton(text)


def _read_rows(path: Path) -> PoseRows:
    if path.is_dir():
        return read_openpose_folder(path)
    doc = load_json(path)
    if is_mmpose(doc):
        return read_mmpose(doc, path)
    if isinstance(doc, list):
        return read_coco(doc, path)
    if isinstance(doc, dict):
        if "people" in doc:
            raise InputError("an OpenPose file of one frame: give the folder of the camera's frame files", source=path)
        return read_native(doc, path)
    raise InputError("must be a native keypoints object, a COCO results list or MMPose predictions", source=path)


def _ask(J: int, fits: list[LayoutFit], src: PoseRows) -> InputError:
    names = " | ".join(f.skeleton.name for f in fits)
    nums = "; ".join(f.describe() for f in fits)
    return InputError(f"{J} joints per pose fit several skeletons and the layout does not tell which ({nums}): "
                      f"say which with --skeleton {names}", source=src.joint_source, field=src.joint_field)


def _resolve(parts: list[PoseRows], skeleton: Skeleton | str | None, report: KeypointsReport) -> Skeleton:
    """The skeleton of all cameras' rows (module docstring); checks every camera against it."""
    given = skeleton_arg(skeleton) if isinstance(skeleton, str) else skeleton
    withdata = [p for p in parts if p.frame]
    declared = [p for p in parts if p.skeleton is not None]
    for p in declared[1:]:
        if p.skeleton != declared[0].skeleton:
            a, b = p.skeleton, declared[0].skeleton
            raise InputError(f"skeleton {a.name} ({len(a.joints)} joints) differs from {b.name} ({len(b.joints)} "
                             f"joints) of {declared[0].source}; all cameras must agree", source=p.source)
    counts = {p.J for p in withdata}
    if len(counts) > 1:
        a, b = withdata[0], next(p for p in withdata if p.J != withdata[0].J)
        raise InputError(f"{b.J} joints per pose, but {a.joint_source} has {a.J}; all cameras must use one skeleton",
                         source=b.joint_source, field=b.joint_field)
    data = np.concatenate([p.array() for p in withdata]) if withdata else None
    J = counts.pop() if counts else None
    if given is not None:
        sk, how = given, "given"
    elif declared:
        sk, how = declared[0].skeleton, f"named in {declared[0].source.name}"
    elif J is None:
        return COCO17  # no poses at all: nothing to name; the pose stage says so
    else:
        cands = candidates_for(J)
        if not cands:
            raise InputError(f"{J} joints per pose: no known skeleton has that many ({', '.join(SKELETONS)}): "
                             "give --skeleton NAME, or write a native file with its 'joints'",
                             source=withdata[0].joint_source, field=withdata[0].joint_field)
        ranked = rank_layouts(data, cands)
        report.fits = ranked
        if len(cands) > 1 and not clearly_better(ranked[0], ranked[1]):
            raise _ask(J, ranked, withdata[0])
        sk = ranked[0].skeleton
        how = "recognised from the joint count and layout" if len(cands) > 1 else "from the joint count, layout checked"
    for p in withdata:
        if p.J != FILE_JOINTS.get(sk.name, len(sk.joints)) and p.J != len(sk.joints):
            raise InputError(f"{p.J} joints, expected {len(sk.joints)} ({sk.name})", source=p.joint_source,
                             field=p.joint_field)
    if data is not None and not report.fits:
        report.fits = rank_layouts(data[:, :len(sk.joints)] if data.shape[1] >= len(sk.joints) else data,
                                   [sk] + [c for c in candidates_for(data.shape[1]) if c != sk])
    mine = next((f for f in report.fits if f.skeleton == sk), None)
    better = [f for f in report.fits if f.skeleton != sk and mine is not None and clearly_better(f, mine)]
    if mine is not None and mine.measurable and not mine.fits:
        msg = (f"the joints do not lie like {sk.name}'s ({mine.describe()})"
               + (f"; they fit {better[0].skeleton.name} ({better[0].describe()})" if better else ""))
        if better and how.startswith("named in"):
            raise InputError(msg + f": fix the file's 'skeleton' or give --skeleton {better[0].skeleton.name}",
                             source=declared[0].source, field="skeleton")
        warnings.warn(f"2D poses: {msg}; check the skeleton (--skeleton)", GymtrackWarning, stacklevel=3)
    report.skeleton, report.skeleton_how = sk.name, how
    if data is not None and data.shape[1] > len(sk.joints):
        report.unused_joints = int(data.shape[1] - len(sk.joints))
    return sk


def _finish(parts: list[PoseRows], camera_names: Sequence[str], indices: Sequence[int],
            skeleton: Skeleton | str | None, report: KeypointsReport) -> Poses2D:
    sk = _resolve(parts, skeleton, report)
    out = [p.poses(sk, c, camera_names) if p.frame else Poses2D.empty(sk, camera_names) for p, c in zip(parts, indices)]
    poses = Poses2D.concat(out)
    s = np.concatenate([p.array()[..., 2].ravel() for p in parts if p.frame]) if any(p.frame for p in parts) else np.zeros(0)
    report.poses = len(poses)
    report.scores_above_1 = int((s > 1).sum())
    report.max_score = float(s.max()) if s.size else 0.0
    return poses


def read_keypoints_file(path: str | Path, camera_index: int, camera_names: Sequence[str],
                        skeleton: Skeleton | str | None = None, report: KeypointsReport | None = None) -> Poses2D:
    """The poses of one camera: a native, COCO-results or MMPose JSON file, or an OpenPose folder.

    ``skeleton``: the joint order (a name such as ``"body25b"`` or a Skeleton); default: the
    file's own, else recognised (module docstring). Every row gets ``camera = camera_index``.
    ``report`` (optional) is filled in.
    """
    rows = _read_rows(Path(path))
    return _finish([rows], camera_names, [camera_index], skeleton, report or KeypointsReport())


def keypoint_sources(root: str | Path, camera_names: Sequence[str],
                     ignored: list[Path] | None = None) -> tuple[dict[str, Path], dict[str, str]]:
    """camera -> its poses' file or folder in ``root``, and how each was matched (by name, a similar
    name -- ``cam01_json`` for ``cam_01`` -- or sorted order). Entries: ``<camera>.json`` files and
    ``<camera>/`` or ``<camera>_json/`` folders; hidden entries are ignored. Where ``*_json/``
    folders exist (Pose2Sim's ``pose/``), only they are read: the pose videos and image folders
    Pose2Sim writes beside them are appended to ``ignored`` (reported, not read). An entry that
    names no camera, a camera without one, or a camera with two, is an error naming the folder."""
    root = Path(root)
    entries: dict[str, list[Path]] = {}
    listing = [e for e in sorted(root.iterdir()) if not e.name.startswith(".")]
    if any(e.is_dir() and e.name.lower().endswith("_json") for e in listing):
        others = [e for e in listing if not (e.is_dir() and e.name.lower().endswith("_json"))]
        listing = [e for e in listing if e not in others]
        if ignored is not None:
            ignored.extend(others)
    for e in listing:
        if e.is_file() and e.suffix.lower() != ".json":
            raise InputError("not a keypoints file (<camera>.json) or folder (<camera>/, <camera>_json/): move it out",
                             source=e)
        stem = e.stem if e.is_file() else strip_suffix(e.name)
        entries.setdefault(stem, []).append(e)
    for stem, es in entries.items():
        if len(es) > 1:
            raise InputError(f"camera {stem!r} has both {es[0].name} and {es[1].name}; keep one", source=root)
    m = match_cameras(list(entries), camera_names)
    if m.unmatched_entries and m.unmatched_cameras:
        names = [entries[e][0].name for e in m.unmatched_entries]
        raise InputError(f"{', '.join(names)} cannot be matched to the cameras {', '.join(m.unmatched_cameras)}: the "
                         f"names differ and there are {len(names)} for {len(m.unmatched_cameras)} cameras (sorted order "
                         "needs as many); name them after the calibration's cameras", source=root)
    if m.unmatched_entries:
        extra = [entries[e][0] for e in m.unmatched_entries]
        raise InputError(f"names no camera of {list(camera_names)} (expected <camera>.json, <camera>/ or "
                         f"<camera>_json/)" + (f"; nor do {', '.join(e.name for e in extra[1:])}" if extra[1:] else ""),
                         source=extra[0])
    if m.unmatched_cameras:
        c = m.unmatched_cameras[0]
        raise InputError(f"no keypoints for camera {c!r}: expected {c}.json or a folder {c}/ or {c}_json/", source=root)
    return {c: entries[e][0] for c, e in m.entries.items()}, m.how


def read_keypoints(path_or_folder: str | Path, camera_names: Sequence[str], skeleton: Skeleton | str | None = None,
                   report: KeypointsReport | None = None) -> Poses2D:
    """All cameras' poses from a ``keypoints/`` (or Pose2Sim ``pose/``) folder, sorted by (frame, camera).

    Cameras are matched to the folder's entries by :func:`keypoint_sources`; the mapping is in
    ``report`` (and a warning when made by sorted order). A single file is read as the camera its
    name gives. All cameras must use the same skeleton.
    """
    root = Path(path_or_folder)
    camera_names = tuple(camera_names)
    report = report if report is not None else KeypointsReport()
    if not camera_names:
        raise InputError("no camera names given", source=root)
    if not root.exists():
        raise InputError("keypoints folder not found", source=root)
    if root.is_file():
        if root.stem not in camera_names:
            raise InputError(f"file name must be <camera>.json with a camera of {list(camera_names)}", source=root)
        report.sources = {root.stem: root}
        return read_keypoints_file(root, camera_names.index(root.stem), camera_names, skeleton, report).sorted()
    sources, how = keypoint_sources(root, camera_names, report.ignored)
    report.sources, report.matched_by = sources, how
    if "sorted order" in how.values():
        pairs = ", ".join(f"{c} <- {sources[c].name}" for c in sources if how[c] == "sorted order")
        warnings.warn(f"2D poses matched to cameras by sorted order, the names differing: {pairs}; rename the "
                      "folders after the calibration's cameras if this is wrong", GymtrackWarning, stacklevel=2)
    parts = [_read_rows(sources[c]) for c in camera_names]
    return _finish(parts, camera_names, range(len(camera_names)), skeleton, report).sorted()


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
