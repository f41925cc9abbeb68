"""Person detectors on ONNX Runtime: YOLOX (raw grid or NMS inside) and YOLOv8/YOLO11 exports.

Paper: Section III-A -- a person detector (YOLOX-S, frames rescaled to 608 x 608) gives the boxes
``b_{t,c,i}`` of every view. Adapters (the output layouts of ``docs/models.md``):

* ``yolox``: output (B, N, 5 + C), N = sum over strides 8/16/32 of (H/s)(W/s); rows
  ``[x, y, w, h, obj, cls_0..]`` (sigmoid-ed); ``cx = (x + gx) s``, ``w = exp(w) s``; score = obj * cls.
  Input BGR 0..255, letterbox top-left.
* ``yolox_nms``: NMS in the graph: ``dets`` (B, N, 5) ``[x1, y1, x2, y2, score]`` + ``labels`` (B, N),
  or one (B, N, 6) ``[x1, y1, x2, y2, score, class]``; input as ``yolox``.
* ``yolov8``: output (B, 4 + C, N) ``[cx, cy, w, h, cls_0..]`` (no objectness); input RGB / 255,
  letterbox centred.

Every adapter keeps the person class, applies the score threshold and NMS (cv2.dnn.NMSBoxes),
maps boxes back through the letterbox to raw pixels and clips them to the frame. The cameras of
one frame go through the model as one batch when its batch dimension is dynamic.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import cv2
import numpy as np

from ..errors import InputError
from .image import Letterbox, letterbox_batch, to_blob
from .runtime import Session, Signature, open_session

__all__ = ["DETECTOR_KINDS", "DetectorOptions", "Detector", "grid_points", "decode_yolox", "decode_yolov8",
           "decode_nms_output", "nms", "fit_detector"]

DETECTOR_KINDS = ("yolox", "yolox_nms", "yolov8")
STRIDES = (8, 16, 32)


@dataclass
class DetectorOptions:
    """Adapter options (``models.yaml`` ``detector:`` keys); None = the kind's default."""

    kind: str | None = None                # yolox | yolox_nms | yolov8; None: from the signature
    input_size: tuple[int, int] | None = None  # (H, W) when the model's input is dynamic
    letterbox: str | None = None           # topleft | centre
    rgb: bool | None = None                # feed RGB (True) or BGR as decoded (False)
    scale: float | None = None             # pixel values times this (1/255 for ultralytics)
    score_threshold: float = 0.3
    nms_threshold: float = 0.45
    person_class: int = 0
    strides: tuple[int, ...] = STRIDES
    extra: dict = field(default_factory=dict)

    def resolved(self, kind: str) -> "DetectorOptions":
        v8 = kind == "yolov8"
        return DetectorOptions(kind, self.input_size, self.letterbox or ("centre" if v8 else "topleft"),
                               v8 if self.rgb is None else self.rgb, self.scale or (1 / 255 if v8 else 1.0),
                               self.score_threshold, self.nms_threshold, self.person_class, tuple(self.strides))


def grid_points(size: tuple[int, int], strides: Sequence[int] = STRIDES) -> tuple[np.ndarray, np.ndarray]:
    """Anchor points of a YOLOX head: ((N, 2) grid x, y; (N,) stride), strides in order, rows first."""
    H, W = size
    g, s = [], []
    for st in strides:
        gy, gx = np.mgrid[0:H // st, 0:W // st]
        g.append(np.column_stack([gx.ravel(), gy.ravel()]))
        s.append(np.full(gx.size, st))
    return np.concatenate(g).astype(np.float32), np.concatenate(s).astype(np.float32)


def _anchor_count(size: tuple[int, int], strides: Sequence[int] = STRIDES) -> int:
    return sum((size[0] // s) * (size[1] // s) for s in strides)


def decode_yolox(out: np.ndarray, grid: np.ndarray, stride: np.ndarray, person_class: int, threshold: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """One image's (N, 5 + C) raw rows -> (M, 4) ``[x1, y1, x2, y2]`` input pixels, (M,) scores above ``threshold``."""
    score = out[:, 4] * out[:, 5 + person_class]
    keep = np.flatnonzero(score > threshold)
    o, g, s = out[keep], grid[keep], stride[keep, None]
    c = (o[:, :2] + g) * s
    wh = np.exp(np.minimum(o[:, 2:4], 20.0)) * s
    return np.concatenate([c - wh / 2, c + wh / 2], axis=1), score[keep]


def decode_yolov8(out: np.ndarray, person_class: int, threshold: float) -> tuple[np.ndarray, np.ndarray]:
    """One image's (4 + C, N) output -> (M, 4) xyxy input pixels, (M,) scores above ``threshold``."""
    score = out[4 + person_class]
    keep = np.flatnonzero(score > threshold)
    c, wh = out[:2, keep].T, out[2:4, keep].T
    return np.concatenate([c - wh / 2, c + wh / 2], axis=1), score[keep]


def decode_nms_output(dets: np.ndarray, labels: np.ndarray | None, person_class: int, threshold: float
                      ) -> tuple[np.ndarray, np.ndarray]:
    """One image's NMS-ed rows (N, 5) + labels (N,), or (N, 6) with the class last -> xyxy, scores."""
    cls = dets[:, 5] if labels is None else labels
    keep = (np.round(cls).astype(np.int64) == person_class) & (dets[:, 4] > threshold)
    return dets[keep, :4], dets[keep, 4]


def nms(xyxy: np.ndarray, scores: np.ndarray, iou: float) -> np.ndarray:
    """Indices of the boxes non-maximum suppression keeps, by decreasing score."""
    if len(xyxy) == 0:
        return np.zeros(0, np.int64)
    tlwh = np.column_stack([xyxy[:, :2], xyxy[:, 2:] - xyxy[:, :2]]).astype(np.float32)
    keep = cv2.dnn.NMSBoxes(tlwh.tolist(), scores.astype(np.float32).tolist(), 0.0, float(iou))
    return np.asarray(keep, np.int64).reshape(-1)


def fit_detector(sig: Signature) -> tuple[str | None, str]:
    """(the detector kind ``sig`` fits or None, why) -- ``gymtrack models check``'s detector logic."""
    if len(sig.inputs) != 1:
        return None, f"a detector has one image input, this model has {len(sig.inputs)}"
    x = sig.inputs[0]
    if len(x.shape) != 4 or x.dim(1) not in (3, None):
        return None, f"input {x} is not (B, 3, H, W)"
    size = (x.dim(2), x.dim(3))
    n_anchor = _anchor_count(size) if None not in size else None  # type: ignore[arg-type]
    outs = sig.outputs
    if len(outs) == 2 and len(outs[0].shape) == 3 and outs[0].dim(2) == 5 and len(outs[1].shape) == 2:
        return "yolox_nms", f"{outs[0].name} (B, N, 5) boxes + {outs[1].name} (B, N) labels: YOLOX with NMS in the graph"
    if len(outs) != 1 or len(outs[0].shape) != 3:
        return None, ("detector outputs must be one (B, N, 5+C), one (B, 4+C, N) or dets (B, N, 5) + labels (B, N); "
                      f"got {', '.join(map(str, outs))}")
    o = outs[0]
    a, b = o.dim(1), o.dim(2)
    if n_anchor is not None:  # a fixed input size: the anchor count tells the layouts apart
        if a == n_anchor and b is not None and b >= 6:
            return "yolox", f"{o} rows [x, y, w, h, obj, {b - 5} classes] on the stride 8/16/32 grid: YOLOX raw head"
        if b == n_anchor and a is not None and a >= 5:
            return "yolov8", f"{o} = [cx, cy, w, h, {a - 4} classes] x {n_anchor} anchors: YOLOv8/YOLO11 head"
        if b == 6:
            return "yolox_nms", f"{o} rows [x1, y1, x2, y2, score, class]: NMS in the graph"
        return None, (f"output {o} matches no detector layout for a {size[0]}x{size[1]} input: YOLOX (B, {n_anchor}, 5+C), "
                      f"YOLOv8 (B, 4+C, {n_anchor}) or NMS-ed (B, N, 6)")
    # a dynamic input size: the fixed (class) dimension is the small one
    if b is not None and b >= 6 and (a is None or a > b):
        return "yolox", f"{o} rows [x, y, w, h, obj, {b - 5} classes]: YOLOX raw head (dynamic input size)"
    if a is not None and a >= 5 and (b is None or b > a):
        return "yolov8", f"{o} = [cx, cy, w, h, {a - 4} classes] x anchors: YOLOv8/YOLO11 head (dynamic input size)"
    return None, f"output {o} matches no detector layout: (B, N, 5+C), (B, 4+C, N) or (B, N, 6)"


class Detector:
    """A person detector: ``detect(images)`` -> per image (M, 4) xyxy raw pixels and (M,) scores.

    ``path``: the ONNX file; ``options``: :class:`DetectorOptions` (kind from the signature when
    not given); ``device``: cpu | cuda | tensorrt | auto (see :mod:`gymtrack.models.runtime`).
    """

    def __init__(self, path: str | Path, options: DetectorOptions | None = None, device: str = "cpu") -> None:
        options = options or DetectorOptions()
        self.session: Session = open_session(path, device)
        sig = self.session.signature
        kind, why = fit_detector(sig)
        if options.kind is not None:
            if options.kind not in DETECTOR_KINDS:
                raise InputError(f"unknown detector kind {options.kind!r}; choose one of {', '.join(DETECTOR_KINDS)}",
                                 field="detector.kind")
            kind = options.kind
        if kind is None:
            raise InputError(f"not a detector gymtrack can run: {why}", source=path)
        self.kind, self.why = kind, why
        self.options = o = options.resolved(kind)
        self.input_name, self.input_size, self.batched = sig.image_input(o.input_size, path)
        self._grid, self._stride = grid_points(self.input_size, o.strides)

    @property
    def provider(self) -> str:
        return self.session.provider

    def prepare(self, images: list[np.ndarray]) -> tuple[np.ndarray, list[Letterbox]]:
        """Frames -> ((B, 3, H, W) float32 input, letterboxes)."""
        batch, lbs = letterbox_batch(images, self.input_size, self.options.letterbox or "topleft")
        return to_blob(batch, rgb=bool(self.options.rgb), scale=float(self.options.scale or 1.0)), lbs

    def infer(self, blob: np.ndarray) -> list[np.ndarray]:
        """Run the model; one call for the batch when the batch dimension is dynamic, else one per image."""
        if self.batched or len(blob) == 1:
            return self.session.run({self.input_name: blob})
        parts = [self.session.run({self.input_name: blob[i:i + 1]}) for i in range(len(blob))]
        return [np.concatenate([p[k] for p in parts]) for k in range(len(parts[0]))]

    def decode(self, outputs: list[np.ndarray], lbs: list[Letterbox], shapes: list[tuple[int, int]]
               ) -> list[tuple[np.ndarray, np.ndarray]]:
        """Model outputs -> per image (M, 4) xyxy raw pixels (clipped to the frame ``shapes`` (h, w)), (M,) scores."""
        o = self.options
        if self.kind == "yolox" and outputs[0].shape[1] != len(self._grid):
            raise InputError(f"the model gave {outputs[0].shape[1]} rows for a {self.input_size[0]}x{self.input_size[1]} "
                             f"input, the stride {'/'.join(map(str, o.strides))} grid has {len(self._grid)}: "
                             "check input_size and strides in models.yaml", source=self.session.path)
        res = []
        for i, (lb, (h, w)) in enumerate(zip(lbs, shapes)):
            if self.kind == "yolox":
                xyxy, s = decode_yolox(outputs[0][i], self._grid, self._stride, o.person_class, o.score_threshold)
            elif self.kind == "yolov8":
                xyxy, s = decode_yolov8(outputs[0][i], o.person_class, o.score_threshold)
            else:
                labels = outputs[1][i] if len(outputs) > 1 else None
                xyxy, s = decode_nms_output(outputs[0][i], labels, o.person_class, o.score_threshold)
            if self.kind != "yolox_nms":
                k = nms(xyxy, s, o.nms_threshold)
                xyxy, s = xyxy[k], s[k]
            xyxy = lb.to_image(xyxy)
            xyxy[:, 0::2] = np.clip(xyxy[:, 0::2], 0, w)
            xyxy[:, 1::2] = np.clip(xyxy[:, 1::2], 0, h)
            ok = (xyxy[:, 2] > xyxy[:, 0]) & (xyxy[:, 3] > xyxy[:, 1])
            res.append((xyxy[ok], np.asarray(s, np.float64)[ok]))
        return res

    def detect(self, images: list[np.ndarray]) -> list[tuple[np.ndarray, np.ndarray]]:
        """Frames (h, w, 3) uint8 BGR -> per frame ((M, 4) xyxy raw pixels, (M,) scores)."""
        if not images:
            return []
        blob, lbs = self.prepare(images)
        return self.decode(self.infer(blob), lbs, [im.shape[:2] for im in images])
