"""Image geometry around the models: letterboxing for detectors, affine crops for pose models.

Paper: Section III-A -- the detector sees every frame rescaled to its input (608 x 608 for the
paper's YOLOX-S); Section III-D -- the pose model runs on high-resolution crops of the expanded
box ``b_buf`` (Eq. 14) taken from the full-resolution frame. Both mappings are kept so the
models' outputs go back to raw (distorted) pixels of the frame.

* letterbox: one scale ``r = min(H / h, W / w)``; the resized frame at the top-left (YOLOX) or
  centred (ultralytics) on a canvas filled with 114. Inverse: ``x = (x' - pad_x) / r``.
* affine crop: a box -> centre and scale (padding 1.25, aspect fixed to the model's W / H, as
  mmpose's ``bbox_xyxy2cs`` and ``_fix_aspect_ratio``), then ``cv2.warpAffine`` to ``(H, W)``;
  inverse ``x = (x' - tx) / s``.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np

__all__ = ["PAD_VALUE", "Letterbox", "letterbox", "letterbox_batch", "to_blob", "box_to_centre_scale",
           "crop_affines", "affine_crops", "undo_affine"]

PAD_VALUE = 114
LETTERBOX_MODES = ("topleft", "centre")


@dataclass(frozen=True)
class Letterbox:
    """How a frame went into a detector's input: ``scale`` r and ``pad`` (x, y) in input pixels."""

    scale: float
    pad: tuple[float, float]

    def to_image(self, xy: np.ndarray) -> np.ndarray:
        """(..., 2k) input-pixel coordinates (x, y pairs) -> frame pixels."""
        xy = np.asarray(xy, dtype=np.float64)
        p = np.tile(np.asarray(self.pad, np.float64), xy.shape[-1] // 2)
        return (xy - p) / self.scale

    def to_input(self, xy: np.ndarray) -> np.ndarray:
        """Inverse of :meth:`to_image`."""
        xy = np.asarray(xy, dtype=np.float64)
        p = np.tile(np.asarray(self.pad, np.float64), xy.shape[-1] // 2)
        return xy * self.scale + p


def letterbox(image: np.ndarray, size: tuple[int, int], mode: str = "topleft", out: np.ndarray | None = None
              ) -> tuple[np.ndarray, Letterbox]:
    """``image`` (h, w, 3) uint8 -> ((H, W, 3) uint8 canvas, Letterbox); ``size`` = (H, W).

    mode ``topleft`` (YOLOX) or ``centre`` (ultralytics; pads split as ultralytics rounds them).
    ``out``: an (H, W, 3) uint8 buffer to fill (saves an allocation per frame).
    """
    if mode not in LETTERBOX_MODES:
        raise ValueError(f"letterbox mode must be one of {LETTERBOX_MODES}, got {mode!r}")
    H, W = size
    h, w = image.shape[:2]
    r = min(H / h, W / w)
    nh, nw = int(round(h * r)), int(round(w * r))
    canvas = np.empty((H, W, 3), np.uint8) if out is None else out
    canvas[...] = PAD_VALUE
    if mode == "topleft":
        px = py = 0
    else:
        px, py = int(round((W - nw) / 2 - 0.1)), int(round((H - nh) / 2 - 0.1))
    resized = image if (nh, nw) == (h, w) else cv2.resize(image, (nw, nh), interpolation=cv2.INTER_LINEAR)
    canvas[py:py + nh, px:px + nw] = resized
    return canvas, Letterbox(float(r), (float(px), float(py)))


def letterbox_batch(images: list[np.ndarray], size: tuple[int, int], mode: str = "topleft"
                    ) -> tuple[np.ndarray, list[Letterbox]]:
    """B frames -> ((B, H, W, 3) uint8, B Letterbox)."""
    batch = np.empty((len(images), size[0], size[1], 3), np.uint8)
    lbs = [letterbox(im, size, mode, out=batch[i])[1] for i, im in enumerate(images)]
    return batch, lbs


def to_blob(batch: np.ndarray, rgb: bool = False, mean=None, std=None, scale: float = 1.0) -> np.ndarray:
    """(B, H, W, 3) uint8 BGR -> (B, 3, H, W) float32: optional BGR->RGB, ``(x * scale - mean) / std``.

    One pass per channel straight into the planar output (5x faster than converting the whole
    batch to float and transposing it).
    """
    B, H, W, _ = batch.shape
    mean = np.zeros(3) if mean is None else np.asarray(mean, np.float64)
    std = np.ones(3) if std is None else np.asarray(std, np.float64)
    out = np.empty((B, 3, H, W), np.float32)
    for c in range(3):
        plane = out[:, c]
        np.multiply(batch[..., 2 - c if rgb else c], np.float32(scale / std[c]), out=plane, casting="unsafe")
        if mean[c]:
            plane -= np.float32(mean[c] / std[c])
    return out


def box_to_centre_scale(tlwh: np.ndarray, aspect: float, padding: float = 1.25) -> tuple[np.ndarray, np.ndarray]:
    """(N, 4) ``[left, top, w, h]`` -> centre (N, 2), scale (N, 2) = (w, h) grown to ``aspect`` (= W / H) times ``padding``."""
    b = np.asarray(tlwh, dtype=np.float64).reshape(-1, 4)
    centre = b[:, :2] + b[:, 2:] / 2
    w, h = b[:, 2].copy(), b[:, 3].copy()
    wide = w > h * aspect
    h[wide] = w[wide] / aspect
    w[~wide] = h[~wide] * aspect
    return centre, np.column_stack([w, h]) * padding


def crop_affines(centre: np.ndarray, scale: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """(N, 2) centres, (N, 2) scales, ``size`` (H, W) -> (N, 2, 3) frame-to-crop affines (no rotation)."""
    H, W = size
    s = W / np.asarray(scale, np.float64)[:, 0]  # == H / scale_h once the aspect is fixed
    M = np.zeros((len(s), 2, 3))
    M[:, 0, 0] = M[:, 1, 1] = s
    M[:, 0, 2] = W / 2 - s * centre[:, 0]
    M[:, 1, 2] = H / 2 - s * centre[:, 1]
    return M


def affine_crops(images: list[np.ndarray], image_index: np.ndarray, affines: np.ndarray, size: tuple[int, int]
                 ) -> np.ndarray:
    """Crops (N, H, W, 3) uint8: crop i is ``images[image_index[i]]`` warped by ``affines[i]``.

    Outside the frame is filled with 0 (mmpose's border value).
    """
    H, W = size
    out = np.empty((len(affines), H, W, 3), np.uint8)
    for i, (k, M) in enumerate(zip(np.asarray(image_index, np.int64), affines)):
        cv2.warpAffine(images[k], M, (W, H), dst=out[i], flags=cv2.INTER_LINEAR,
                       borderMode=cv2.BORDER_CONSTANT, borderValue=(0, 0, 0))
    return out


def undo_affine(xy: np.ndarray, affines: np.ndarray) -> np.ndarray:
    """(N, K, 2) crop coordinates, (N, 2, 3) affines -> (N, K, 2) frame pixels."""
    s = affines[:, 0, 0][:, None]
    return np.stack([(xy[..., 0] - affines[:, 0, 2][:, None]) / s, (xy[..., 1] - affines[:, 1, 2][:, None]) / s], axis=-1)
