"""Overlays: what the tracker did, drawn on the videos -- one view, or a grid of all views.

Paper: Section III (the tracker's per-view output): the boxes of every 3D track in every view
(``tracks_2d``, labelled with the 3D track id), the target's expanded box ``b_buf`` (Sec. III-D,
``target_2d``) and the 2D skeletons the pose stage used (``keypoints/``), over the raw
detections. Where a camera has no video the view is drawn on a neutral canvas. Where ``gymtrack
pose`` ran, the 3D skeleton of ``poses_3d.csv`` projected into each view (red, over the 2D poses:
where they part, the 3D pose disagrees with that view); where ``gymtrack analyse`` ran, captions of
the elements going on (a flight's saltos, twists and shape, the hold timer, a landing's steps) at
the bottom left of each view (:mod:`gymtrack.eval.element_marks`).

Shapes: images (h, w, 3) uint8 BGR; boxes (N, 4) centre form in raw camera pixels, drawn at a
view's scale ``s`` (tile width / camera width).
"""

from __future__ import annotations

import os
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Iterator, Sequence

import cv2
import numpy as np

from ..detections import Detections
from ..errors import InputError
from ..formats.outputs import OutputFolder, read_outputs
from ..formats.routine import Routine, load_routine
from ..poses import Poses2D, Poses3D
from .element_marks import ElementMarks, kind_bgr, read_analysis_elements

CANVAS = (64, 64, 64)  # a view without video
DETECTION = (170, 170, 170)
B_BUF = (0, 230, 255)  # yellow: the target's expanded box
BONE = (255, 255, 255)
SKELETON_3D = (30, 30, 230)  # red: the 3D pose projected into the view
CAPTION_FONT = cv2.FONT_HERSHEY_SIMPLEX
_SHIFT = 2


@contextmanager
def replace_when_done(path: Path) -> Iterator[Path]:
    """A temporary path beside ``path`` (same suffix, so the container is the same) that takes
    ``path``'s place when the block ends without error; removed otherwise: a failed or
    interrupted run leaves no half-written file."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_name(f".{path.stem}.tmp-{os.getpid()}{path.suffix}")
    try:
        yield tmp
        os.replace(tmp, path)
    finally:
        tmp.unlink(missing_ok=True)


def id_colours(ids: np.ndarray) -> np.ndarray:
    """(N,) track ids -> (N, 3) uint8 BGR, far apart for neighbouring ids (golden-angle hues)."""
    ids = np.asarray(ids, dtype=np.int64).reshape(-1)
    if not ids.size:
        return np.zeros((0, 3), np.uint8)
    hue = ((ids * 0.618033988749895) % 1.0 * 180).astype(np.uint8)
    hsv = np.stack([hue, np.full_like(hue, 200), np.full_like(hue, 255)], -1)[None]
    return cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0]


@dataclass(frozen=True, eq=False)
class OverlayInputs:
    """A routine, the outputs of ``gymtrack track`` (and ``pose``) on it, and its videos."""

    routine: Routine
    outputs: OutputFolder
    poses: Poses2D | None
    videos: dict[str, Path]
    poses3d: Poses3D | None = None
    marks: ElementMarks | None = None

    @property
    def frames(self) -> np.ndarray:
        """(F,) every frame with a detection or an output box, increasing."""
        parts = [self.routine.detections.frame, self.outputs.boxes.frame, self.outputs.target_boxes.frame]
        return np.unique(np.concatenate(parts))


def load_overlay_inputs(routine: str | Path, out: str | Path) -> OverlayInputs:
    """Read ``routine`` (with its ``videos/``) and the output folder ``out`` (``keypoints/``,
    ``poses_3d.csv`` and ``analysis/elements.json`` optional)."""
    from ..formats.keypoints import read_keypoints
    from ..formats.poses3d import read_poses_3d
    from ..formats.video import find_videos

    r = load_routine(routine)
    outputs = read_outputs(out, r.camera_names)
    kp = Path(out) / "keypoints"
    poses = read_keypoints(kp, r.camera_names) if kp.is_dir() else None
    p3 = Path(out) / "poses_3d.csv"
    poses3d = read_poses_3d(p3) if p3.is_file() else None
    doc = read_analysis_elements(out)
    marks = ElementMarks.from_doc(doc) if doc is not None else None
    return OverlayInputs(r, outputs, poses, find_videos(r.path, r.camera_names), poses3d, marks)


def _tl_br(box: np.ndarray, s: float) -> tuple[np.ndarray, np.ndarray]:
    """Integer (shifted) corners of centre-form boxes (N, 4) at scale ``s``."""
    k = s * (1 << _SHIFT)
    tl = np.round((box[:, :2] - box[:, 2:] / 2) * k).astype(np.int64)
    br = np.round((box[:, :2] + box[:, 2:] / 2) * k).astype(np.int64)
    return np.clip(tl, -2**28, 2**28), np.clip(br, -2**28, 2**28)


def _boxes(img: np.ndarray, boxes: Detections, rows: np.ndarray, s: float, colour, thickness: int,
           labels: bool = False) -> None:
    if not rows.size:
        return
    tl, br = _tl_br(boxes.box[rows], s)
    cols = id_colours(boxes.track_id[rows]).tolist() if colour is None else [colour] * rows.size
    for a, b, c, tid in zip(tl.tolist(), br.tolist(), cols, boxes.track_id[rows].tolist()):
        cv2.rectangle(img, a, b, c, thickness, cv2.LINE_8, _SHIFT)
        if labels:
            org = (a[0] >> _SHIFT, (a[1] >> _SHIFT) - 4)
            cv2.putText(img, str(tid), org, cv2.FONT_HERSHEY_SIMPLEX, 0.5, c, 1, cv2.LINE_AA)


def _skeletons(img: np.ndarray, poses: Poses2D, rows: np.ndarray, s: float) -> None:
    bones = poses.skeleton.bones
    k = s * (1 << _SHIFT)
    for i in rows.tolist():
        kp = poses.keypoints[i]
        ok = (kp[:, 2] > 0) & np.all(np.isfinite(kp[:, :2]), -1)
        xy = np.round(np.nan_to_num(kp[:, :2]) * k).astype(np.int64).tolist()
        col = id_colours(poses.track_id[i:i + 1])[0].tolist()
        for a, b in bones.tolist():
            if ok[a] and ok[b]:
                cv2.line(img, xy[a], xy[b], BONE, 2, cv2.LINE_AA, _SHIFT)
        for j in np.flatnonzero(ok).tolist():
            cv2.circle(img, xy[j], 3 << _SHIFT, col, -1, cv2.LINE_AA, _SHIFT)


def _skeletons_3d(img: np.ndarray, uv: np.ndarray, bones: np.ndarray, s: float) -> None:
    """Bones of projected 3D poses ``uv`` (n, J, 2) raw camera pixels (NaN: not estimated or behind)."""
    k = s * (1 << _SHIFT)
    ok = np.all(np.isfinite(uv), -1)
    xy = np.round(np.nan_to_num(uv) * k).clip(-2**28, 2**28).astype(np.int64)
    a, b = bones[:, 0], bones[:, 1]
    for row, bone in zip(*np.nonzero(ok[:, a] & ok[:, b])):
        cv2.line(img, xy[row, a[bone]].tolist(), xy[row, b[bone]].tolist(), SKELETON_3D, 2, cv2.LINE_AA, _SHIFT)


def _ascii(text: str) -> str:
    """OpenCV's Hershey fonts draw ASCII only."""
    return text.replace(" · ", " | ").replace("°", "").replace(" ± ", "+-").encode("ascii", "replace").decode()


def draw_captions(img: np.ndarray, lines: Sequence[tuple[str, str]]) -> None:
    """Captions ``(kind, text)`` at the bottom left of ``img`` (in place), the last lowest: a dark
    backdrop, a swatch in the kind's colour, the text in white; sized to the image's width."""
    if not lines:
        return
    h, w = img.shape[:2]
    texts = [_ascii(t) for _, t in lines]
    fs = float(np.clip(w / 1200, 0.35, 0.7))
    widest = max(cv2.getTextSize(t, CAPTION_FONT, fs, 1)[0][0] for t in texts)
    fs = max(0.3, fs * min(1.0, (w - 24 - 20 * fs) / widest))  # shrink to fit the view's width
    lh = int(round(24 * fs)) + 2  # line height
    y = h - 4
    for (kind, _), txt in zip(reversed(list(lines)), reversed(texts)):
        (tw, _), _ = cv2.getTextSize(txt, CAPTION_FONT, fs, 1)
        sw = lh - 8
        cv2.rectangle(img, (2, y - lh), (min(w - 1, 14 + sw + tw), y), (0, 0, 0), -1)
        cv2.rectangle(img, (6, y - lh + 4), (6 + sw, y - 4), kind_bgr(kind), -1)
        cv2.putText(img, txt, (12 + sw, y - lh // 2 + int(8 * fs)), CAPTION_FONT, fs, (255, 255, 255), 1, cv2.LINE_AA)
        y -= lh + 2


class _Index:
    """Rows of a table by (frame, camera), found by binary search on the sorted keys."""

    def __init__(self, frame: np.ndarray, camera: np.ndarray):
        key = frame.astype(np.int64) * 4096 + camera.astype(np.int64)
        self.order = np.argsort(key, kind="stable")
        self.key = key[self.order]

    def rows(self, frame: int, camera: int) -> np.ndarray:
        k = frame * 4096 + camera
        return self.order[np.searchsorted(self.key, k):np.searchsorted(self.key, k, side="right")]


def draw_view(img: np.ndarray, s: float, frame: int, camera: int, inputs: OverlayInputs, index: dict | None = None) -> None:
    """Draw one view's overlay of ``frame`` on ``img`` (in place); ``s``: image pixels per camera pixel.

    Order (bottom to top): raw detections (thin grey), the 3D tracks' boxes (id colour, labelled),
    the 2D skeletons, the projected 3D skeleton (red), ``b_buf`` (yellow), the element captions."""
    o = inputs.outputs
    idx = index if index is not None else _indices(inputs)
    dets = inputs.routine.detections
    _boxes(img, dets, idx["det"].rows(frame, camera), s, DETECTION, 1)
    _boxes(img, o.boxes, idx["box"].rows(frame, camera), s, None, 2, labels=True)
    if inputs.poses is not None:
        _skeletons(img, inputs.poses, idx["pose"].rows(frame, camera), s)
    if inputs.poses3d is not None:
        rows = idx["pose3d"].rows(frame, 0)
        if rows.size:
            cam = inputs.routine.rig[camera]
            _skeletons_3d(img, cam.project(inputs.poses3d.xyz[rows]), inputs.poses3d.skeleton.bones, s)
    _boxes(img, o.target_boxes, idx["target"].rows(frame, camera), s, B_BUF, 3)
    if inputs.marks is not None:
        draw_captions(img, inputs.marks.at(frame))


def _indices(inputs: OverlayInputs) -> dict:
    o, d = inputs.outputs, inputs.routine.detections
    idx = {"det": _Index(d.frame, d.camera), "box": _Index(o.boxes.frame, o.boxes.camera),
           "target": _Index(o.target_boxes.frame, o.target_boxes.camera)}
    if inputs.poses is not None:
        idx["pose"] = _Index(inputs.poses.frame, inputs.poses.camera)
    if inputs.poses3d is not None:
        idx["pose3d"] = _Index(inputs.poses3d.frame, np.zeros_like(inputs.poses3d.frame))
    return idx


def overlay_frames(inputs: OverlayInputs, cameras: Sequence[int] | None = None, width: int | None = None,
                   frames: Sequence[int] | None = None) -> Iterator[tuple[int, np.ndarray]]:
    """``(frame, image)`` overlays: one view when ``cameras`` has one index, else a grid (columns =
    ceil(sqrt(n))). ``width``: the whole image's width (default: one view at its video's or
    camera's width, a grid 1920). ``frames``: default :attr:`OverlayInputs.frames`."""
    from ..formats.video import VideoReader, VideoSet

    r = inputs.routine
    cams = list(range(len(r.rig))) if cameras is None else [int(c) for c in cameras]
    cols = int(np.ceil(np.sqrt(len(cams))))
    rows_n = int(np.ceil(len(cams) / cols))
    if width is None:
        first = r.camera_names[cams[0]]
        width = 1920 if len(cams) > 1 else (_video_width(inputs.videos[first]) if first in inputs.videos else r.rig[cams[0]].size[0])
    tw = int(width) // cols // 2 * 2
    if tw < 16:
        raise InputError(f"overlay width {width} leaves tiles under 16 pixels", field="--width")
    scale = [tw / r.rig[c].size[0] for c in cams]
    th = max(int(round(r.rig[c].size[1] * s)) for c, s in zip(cams, scale))
    th += th % 2
    idx = _indices(inputs)
    first, offsets = r.scene.first_frame, r.scene.video_offsets
    readers = [VideoReader(inputs.videos[n], first, int(offsets.get(n, 0))) if n in inputs.videos else None
               for n in (r.camera_names[c] for c in cams)]
    videos = VideoSet(readers, [r.camera_names[c] for c in cams])
    todo = inputs.frames if frames is None else np.asarray(frames, dtype=np.int64)
    try:
        for fr, images in videos.iter_frames(int(f) for f in todo):
            grid = np.full((th * rows_n, tw * cols, 3), 0, np.uint8)
            for k, (c, s, im) in enumerate(zip(cams, scale, images)):
                w, h = tw, int(round(r.rig[c].size[1] * s))
                tile = np.empty((h, w, 3), np.uint8)
                if im is None:
                    tile[:] = CANVAS
                else:
                    tile[:] = cv2.resize(im, (w, h), interpolation=cv2.INTER_AREA)
                draw_view(tile, s, fr, c, inputs, idx)
                cv2.putText(tile, f"{r.camera_names[c]}  frame {fr}", (8, 22), cv2.FONT_HERSHEY_SIMPLEX, 0.6,
                            (255, 255, 255), 1, cv2.LINE_AA)
                y0, x0 = (k // cols) * th, (k % cols) * tw
                grid[y0:y0 + min(h, th), x0:x0 + w] = tile[:th]
            yield fr, grid
    finally:
        videos.close()


def _video_width(path: Path) -> int:
    from ..formats.video import VideoReader

    with VideoReader(path) as v:
        return v.size[0]


def write_overlay(routine: str | Path, out: str | Path, video: str | Path, camera: str | None = None,
                  width: int | None = None, frames: Sequence[int] | None = None) -> dict:
    """Write the overlay video ``video`` (``.mp4`` H.264, ``.mkv`` lossless) of ``routine`` and the
    outputs in ``out``: one camera (``camera``) or a grid of all. Returns counts for a summary:
    frames written, size and the cameras that had a video."""
    from ..formats.video import write_video

    inputs = load_overlay_inputs(routine, out)
    names = inputs.routine.camera_names
    if camera is not None and camera not in names:
        raise InputError(f"unknown camera {camera!r}; cameras: {', '.join(names)}", field="--camera")
    cams = None if camera is None else [names.index(camera)]
    gen = overlay_frames(inputs, cams, width, frames)
    shape: list = []

    def images():
        for _, img in gen:
            shape[:] = img.shape[:2]
            yield img

    video = Path(video)
    fast = {"crf": "20", "preset": "veryfast"} if video.suffix.lower() in (".mp4", ".mov") else None
    with replace_when_done(video) as tmp:
        n = write_video(tmp, images(), inputs.routine.scene.fps, options=fast)
    used = names if camera is None else (camera,)
    return {"frames": n, "size": (shape[1], shape[0]) if shape else None, "path": Path(video),
            "poses_3d": 0 if inputs.poses3d is None else len(inputs.poses3d),
            "elements": 0 if inputs.marks is None else len(inputs.marks.elements),
            "videos": [c for c in used if c in inputs.videos], "canvas": [c for c in used if c not in inputs.videos]}
