"""Top-down pose models on ONNX Runtime: SimCC heads (RTMPose) and heatmap heads (HRNet, ViTPose).

Paper: Section III-D, last paragraph -- a top-down pose model (HRNet) runs on high-resolution
crops of the expanded box ``b_buf`` (Eq. 14) from the full-resolution frame; its keypoints are
triangulated. Here every box of a frame (all views, all tracks) becomes an affine crop
(:mod:`gymtrack.models.image`) and the crops go through the model as one batch when its batch
dimension is dynamic. Decoding back to raw pixels:

* ``simcc``: ``simcc_x`` (N, K, W * r), ``simcc_y`` (N, K, H * r): argmax per joint divided by the
  split ratio r (2.0); confidence = the smaller of the two maxima.
* ``heatmap``: (N, K, h, w) (64 x 48 for a 256 x 192 input): argmax, a quarter-pixel shift
  towards the higher neighbour, times the stride (input / heatmap); confidence = the maximum.

then through the inverse affine. Output: :class:`gymtrack.poses.Poses2D`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np

from ..detections import Detections
from ..errors import InputError
from ..poses import Poses2D
from ..skeletons import Skeleton, get_skeleton
from .image import affine_crops, box_to_centre_scale, crop_affines, to_blob, undo_affine
from .runtime import Session, Signature, open_session

__all__ = ["POSE_KINDS", "PoseOptions", "PoseModel", "decode_simcc", "decode_heatmaps", "fit_pose"]

POSE_KINDS = ("simcc", "heatmap")
IMAGENET_MEAN = (123.675, 116.28, 103.53)
IMAGENET_STD = (58.395, 57.12, 57.375)


@dataclass
class PoseOptions:
    """Adapter options (``models.yaml`` ``pose:`` keys)."""

    kind: str | None = None            # simcc | heatmap; None: from the signature
    input_size: tuple[int, int] | None = None  # (H, W) when the model's input is dynamic
    rgb: bool = True                   # mmpose's configs convert BGR to RGB; rtmlib feeds BGR (False)
    mean: tuple[float, float, float] = IMAGENET_MEAN
    std: tuple[float, float, float] = IMAGENET_STD
    padding: float = 1.25              # box grown by this before the crop
    split_ratio: float | None = None   # SimCC bins per pixel; None: from the output size (2.0)
    skeleton: str | None = None        # joint layout; None: coco17 for 17 joints, halpe26 for 26


def decode_simcc(simcc_x: np.ndarray, simcc_y: np.ndarray, split_ratio: float) -> tuple[np.ndarray, np.ndarray]:
    """(N, K, Wx), (N, K, Wy) -> (N, K, 2) crop pixels, (N, K) scores (min of the two maxima)."""
    ix, iy = simcc_x.argmax(-1), simcc_y.argmax(-1)
    mx = np.take_along_axis(simcc_x, ix[..., None], -1)[..., 0]
    my = np.take_along_axis(simcc_y, iy[..., None], -1)[..., 0]
    xy = np.stack([ix, iy], axis=-1).astype(np.float64) / split_ratio
    return xy, np.minimum(mx, my).astype(np.float64)


def decode_heatmaps(heatmaps: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(N, K, h, w) -> (N, K, 2) heatmap pixels with the quarter-pixel refinement, (N, K) maxima."""
    N, K, h, w = heatmaps.shape
    flat = heatmaps.reshape(N, K, h * w)
    idx = flat.argmax(-1)
    score = np.take_along_axis(flat, idx[..., None], -1)[..., 0].astype(np.float64)
    x, y = (idx % w).astype(np.int64), (idx // w).astype(np.int64)
    n, k = np.meshgrid(np.arange(N), np.arange(K), indexing="ij")
    hm = heatmaps
    inner_x = (x > 0) & (x < w - 1)
    inner_y = (y > 0) & (y < h - 1)
    dx = np.sign(hm[n, k, y, np.minimum(x + 1, w - 1)] - hm[n, k, y, np.maximum(x - 1, 0)]) * 0.25 * inner_x
    dy = np.sign(hm[n, k, np.minimum(y + 1, h - 1), x] - hm[n, k, np.maximum(y - 1, 0), x]) * 0.25 * inner_y
    return np.stack([x + dx, y + dy], axis=-1).astype(np.float64), score


def fit_pose(sig: Signature) -> tuple[str | None, str]:
    """(the pose kind ``sig`` fits or None, why) -- ``gymtrack models check``'s pose logic."""
    if len(sig.inputs) != 1:
        return None, f"a pose model has one image input, this model has {len(sig.inputs)}"
    x = sig.inputs[0]
    if len(x.shape) != 4 or x.dim(1) not in (3, None):
        return None, f"input {x} is not (N, 3, H, W)"
    H, W = x.dim(2), x.dim(3)
    outs = sig.outputs
    if len(outs) == 2 and all(len(o.shape) == 3 for o in outs):
        by = {o.name: o for o in outs}
        ox, oy = by.get("simcc_x", outs[0]), by.get("simcc_y", outs[1])
        if ox.dim(1) is not None and oy.dim(1) is not None and ox.dim(1) != oy.dim(1):
            return None, f"SimCC outputs disagree on the joint count: {ox} vs {oy}"
        rx = ox.dim(2) / W if ox.dim(2) and W else None
        ry = oy.dim(2) / H if oy.dim(2) and H else None
        if rx is not None and ry is not None and abs(rx - ry) > 1e-9:
            return None, f"SimCC outputs {ox} and {oy} have different split ratios for a {H}x{W} input"
        return "simcc", f"{ox} and {oy}: SimCC head, {ox.dim(1) or '?'} joints, split ratio {rx or ry or '?'}"
    if len(outs) == 1 and len(outs[0].shape) == 4:
        o = outs[0]
        h, w = o.dim(2), o.dim(3)
        if h and w and H and W and (H % h or W % w or H // h != W // w):
            return None, f"heatmaps {o} are not the {H}x{W} input divided by one stride"
        return "heatmap", f"{o}: heatmap head, {o.dim(1) or '?'} joints, stride {H // h if h and H else '?'}"
    return None, ("pose outputs must be simcc_x (N, K, W*r) + simcc_y (N, K, H*r) or heatmaps (N, K, h, w); "
                  f"got {', '.join(map(str, outs))}")


def _skeleton(name: str | None, K: int) -> Skeleton:
    if name is not None:
        sk = get_skeleton(name)
    elif K == 17:
        sk = get_skeleton("coco17")
    elif K == 26:
        sk = get_skeleton("halpe26")
    else:
        raise InputError(f"the model gives {K} joints: name its skeleton (skeleton: coco17 | body25 | halpe26) "
                         "in models.yaml", field="pose.skeleton")
    if len(sk.joints) != K:
        raise InputError(f"skeleton {sk.name} has {len(sk.joints)} joints, the model gives {K}", field="pose.skeleton")
    return sk


class PoseModel:
    """A top-down pose model: ``estimate(images, boxes)`` -> :class:`Poses2D` in raw pixels."""

    def __init__(self, path: str | Path, options: PoseOptions | None = None, device: str = "cpu") -> None:
        self.options = o = options or PoseOptions()
        self.session: Session = open_session(path, device)
        sig = self.session.signature
        kind, why = fit_pose(sig)
        if o.kind is not None:
            if o.kind not in POSE_KINDS:
                raise InputError(f"unknown pose kind {o.kind!r}; choose one of {', '.join(POSE_KINDS)}", field="pose.kind")
            kind = o.kind
        if kind is None:
            raise InputError(f"not a pose model gymtrack can run: {why}", source=path)
        self.kind, self.why = kind, why
        self.input_name, self.input_size, self.batched = sig.image_input(o.input_size, path)
        if kind == "simcc":
            by = {t.name: i for i, t in enumerate(sig.outputs)}
            self._order = (by.get("simcc_x", 0), by.get("simcc_y", 1))
        K = sig.outputs[0].dim(1)
        self.skeleton = _skeleton(o.skeleton, K) if K else (get_skeleton(o.skeleton or "coco17"))

    @property
    def provider(self) -> str:
        return self.session.provider

    def prepare(self, images: Sequence[np.ndarray], image_index: np.ndarray, tlwh: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray]:
        """Crops of the boxes: ((N, 3, H, W) float32 input, (N, 2, 3) frame-to-crop affines)."""
        H, W = self.input_size
        c, s = box_to_centre_scale(tlwh, W / H, self.options.padding)
        M = crop_affines(c, s, self.input_size)
        crops = affine_crops(list(images), image_index, M, self.input_size)
        return to_blob(crops, rgb=self.options.rgb, mean=self.options.mean, std=self.options.std), M

    def infer(self, blob: np.ndarray) -> list[np.ndarray]:
        if self.batched or len(blob) == 1:
            return self.session.run({self.input_name: blob})
        parts = [self.session.run({self.input_name: blob[i:i + 1]}) for i in range(len(blob))]
        return [np.concatenate([p[k] for p in parts]) for k in range(len(parts[0]))]

    def decode(self, outputs: list[np.ndarray], affines: np.ndarray) -> np.ndarray:
        """Model outputs -> (N, K, 3) ``[x, y, score]`` in raw frame pixels."""
        H, W = self.input_size
        if self.kind == "simcc":
            sx, sy = outputs[self._order[0]], outputs[self._order[1]]
            ratio = self.options.split_ratio or sx.shape[-1] / W
            xy, score = decode_simcc(sx, sy, ratio)
        else:
            hm = outputs[0]
            xy, score = decode_heatmaps(hm)
            xy = xy * np.array([W / hm.shape[3], H / hm.shape[2]])
        return np.concatenate([undo_affine(xy, affines), score[..., None]], axis=-1)

    def keypoints(self, images: Sequence[np.ndarray], image_index: np.ndarray, tlwh: np.ndarray) -> np.ndarray:
        """(N, K, 3) keypoints of N boxes ``tlwh`` (N, 4) in ``images[image_index[i]]``."""
        if len(tlwh) == 0:
            return np.zeros((0, len(self.skeleton.joints), 3))
        blob, M = self.prepare(images, image_index, tlwh)
        return self.decode(self.infer(blob), M)

    def estimate(self, frame: int, images: Sequence[np.ndarray | None], boxes: Detections) -> Poses2D:
        """The poses in ``boxes`` (one frame's rows; ``camera`` indexes ``images``) -> Poses2D.

        Boxes of a camera without an image are skipped; the caller counts them.
        """
        have = np.array([images[int(c)] is not None for c in boxes.camera], bool) if len(boxes) else np.zeros(0, bool)
        b = boxes.select(have)
        kp = self.keypoints(images, b.camera.astype(np.int64), b.tlwh)  # type: ignore[arg-type]
        return Poses2D(np.full(len(b), frame), b.camera, b.track_id, kp, b.tlwh, self.skeleton, boxes.camera_names)
