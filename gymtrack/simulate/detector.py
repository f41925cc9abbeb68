"""True boxes in every view, and a person detector's imperfect boxes of them.

Paper: Section III-A (the boxes the tracker starts from) and the failure of Section I / III-C:
"due to variations in lighting, background, uniforms, and occlusions, multi-camera gymnast
detection may fail in certain views and only provide valid detections from two opposing views".

True box: the projection (with lens distortion) of every body point of a person, each grown by
its flesh radius in pixels (``f * r / depth``); the box is their bounding box, in the raw image.

Detector model (a YOLOX-like person detector on 1080p frames; every random number is drawn at
full size whatever ``n_cam`` is, so ``n_cam = 2, 3, 4`` of one seed differ only in which views
may see the target):

* localisation noise, temporally correlated (AR(1) over frames): centre noise a few % of the
  box size, size noise a few %, both growing with image speed (motion blur), unusual postures
  (tucked, inverted, split...) and occlusion;
* misses: a small base rate, occlusion by nearer people and by the apparatus (box overlap with
  a nearer person or apparatus part), tiny boxes, fast motion and unusual postures, all with a
  temporally correlated draw so misses come in runs; on top, per-camera failure bursts on the
  target (lighting, background: a few seconds where one view misses it), and bursts where both
  diagonal views (cam2, cam3) fail together, leaving only the opposite pair cam0/cam1;
* ``n_cam``: 4 = all views can see the target, 3 = one view is blind to it, 2 = only the
  opposite pair cam0/cam1 can; other people are detected in every view regardless;
* false positives: clutter at fixed places (a poster, a jacket on a chair) that flickers on and
  off, and random one-off boxes;
* the image border: boxes are clipped to the image; a box mostly outside it is dropped.

Scores are in [0, 1]; each detection keeps the id of the person it came from in memory
(``-1`` for false positives) but is written with id ``-1``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.signal import lfilter
from scipy.special import ndtr

from ..apparatus import Apparatus
from ..geometry.camera import Rig

#: Area fraction a box must keep inside the image to count as in view / to be reported.
MIN_INSIDE = 0.5
#: Occluded fraction at which a person counts as fully hidden (ground-truth ``visible = 0``).
HIDDEN = 0.9
MIN_DEPTH = 0.3


@dataclass
class TrueBoxes:
    """Projected ground truth of every person in every view.

    box: (C, P, T, 4) ``[x0, y0, x1, y1]`` pixels (NaN where the person does not exist or is
    behind the camera); depth: (C, P, T) depth of the body centre; inside: (C, P, T) fraction of
    the box area inside the image; occlusion: (C, P, T) occluded fraction in [0, 1];
    visible: (C, P, T) bool, the ground-truth ``visible`` flag.
    """

    box: np.ndarray
    depth: np.ndarray
    inside: np.ndarray
    occlusion: np.ndarray
    visible: np.ndarray

    @property
    def xywh(self) -> np.ndarray:
        """(C, P, T, 4) centre-form boxes."""
        b = self.box
        return np.stack([(b[..., 0] + b[..., 2]) / 2, (b[..., 1] + b[..., 3]) / 2, b[..., 2] - b[..., 0], b[..., 3] - b[..., 1]], -1)


def _apparatus_pieces(app: Apparatus, piece: float = 0.5) -> np.ndarray:
    """(M, 8, 3) corners of the apparatus' solid blocks cut into pieces at most ``piece`` m long
    (so that a long beam seen at an angle does not become one huge occluding rectangle)."""
    out = []
    for blk in app.blocks:
        lo, hi = np.array(blk.lo, float), np.array(blk.hi, float)
        ax = int(np.argmax(hi - lo))
        k = max(1, int(np.ceil((hi[ax] - lo[ax]) / piece)))
        edges = np.linspace(lo[ax], hi[ax], k + 1)
        for a, b in zip(edges[:-1], edges[1:]):
            l2, h2 = lo.copy(), hi.copy()
            l2[ax], h2[ax] = a, b
            out.append(np.array([[x, y, z] for x in (l2[0], h2[0]) for y in (l2[1], h2[1]) for z in (l2[2], h2[2])]))
    return np.array(out).reshape(-1, 8, 3)


def _inter_area(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Intersection areas of xyxy boxes ``a`` (..., 4) and ``b`` (..., 4), broadcast."""
    w = np.clip(np.minimum(a[..., 2], b[..., 2]) - np.maximum(a[..., 0], b[..., 0]), 0, None)
    h = np.clip(np.minimum(a[..., 3], b[..., 3]) - np.maximum(a[..., 1], b[..., 1]), 0, None)
    return w * h


def true_boxes(rig: Rig, points: np.ndarray, pad: np.ndarray, centre: np.ndarray, app: Apparatus) -> TrueBoxes:
    """Project every person's body into every view.

    Parameters
    ----------
    rig: the cameras (C).
    points: (P, T, K, 3) body points (NaN where a person does not exist).
    pad: (P, K) flesh radius of every point, metres.
    centre: (P, T, 3) body centres.
    app: the apparatus (its blocks occlude people behind them).
    """
    P, T, K, _ = points.shape
    C = len(rig)
    box = np.full((C, P, T, 4), np.nan)
    depth = np.full((C, P, T), np.nan)
    inside = np.zeros((C, P, T))
    occl = np.zeros((C, P, T))
    pieces = _apparatus_pieces(app)
    live = np.all(np.isfinite(points), axis=(-1, -2))  # (P, T)
    pi, ti = np.nonzero(live)
    flat = points[pi, ti].reshape(-1, 3)  # only the people who exist; flat for fast matrix products
    padf = pad[pi]  # (N, K)
    for c, cam in enumerate(rig):
        W, H = cam.size
        d = (flat @ cam.R[2] + cam.t[2]).reshape(-1, K)  # camera z (a matrix-vector product: cheaper than to_camera)
        uv = cam.project(flat).reshape(-1, K, 2)
        ok_n = np.all(d > MIN_DEPTH, axis=-1)
        r = cam.K[0, 0] * padf / np.where(d > MIN_DEPTH, d, 1.0)
        bn = np.stack([(uv[..., 0] - r).min(-1), (uv[..., 1] - r).min(-1), (uv[..., 0] + r).max(-1), (uv[..., 1] + r).max(-1)], -1)
        bn[~ok_n] = np.nan
        bx = np.full((P, T, 4), np.nan)
        bx[pi, ti] = bn
        ok = np.zeros((P, T), bool)
        ok[pi, ti] = ok_n
        box[c] = bx
        dc = np.full((P, T), np.nan)
        dc[pi, ti] = cam.depth(centre[pi, ti])
        depth[c] = np.where(ok, dc, np.nan)
        area = (bx[..., 2] - bx[..., 0]) * (bx[..., 3] - bx[..., 1])
        img = np.array([0.0, 0.0, W, H])
        inside[c] = np.where(ok, _inter_area(bx, img) / np.maximum(area, 1e-9), 0.0)
        # Occlusion by nearer people: 1 - prod(1 - coverage). A box overstates a body: a person of
        # about one's own size in front hides ~85% of the overlap, a much larger (much nearer) one
        # only ~50% (its silhouette fills half its box).
        cov = _inter_area(bx[:, None], bx[None, :]) / np.maximum(area[:, None], 1e-9)  # (P, P, T): j covers i
        ratio = area[None, :] / np.maximum(area[:, None], 1e-9)
        fill = 0.5 + 0.35 * np.clip((4.0 - np.nan_to_num(ratio, nan=4.0)) / 3.0, 0.0, 1.0)
        nearer = depth[c][None, :, :] < depth[c][:, None, :] - 0.2  # [i, j]: j nearer than i
        cov = np.where(nearer & ok[None] & ok[:, None], np.nan_to_num(fill * cov), 0.0)
        free = np.prod(1.0 - np.clip(cov, 0, 1), axis=1)
        # Occlusion by the apparatus.
        if len(pieces):
            pu = cam.project(pieces)  # (M, 8, 2)
            pd = cam.depth(pieces).mean(axis=1)
            pb = np.stack([pu[..., 0].min(1), pu[..., 1].min(1), pu[..., 0].max(1), pu[..., 1].max(1)], -1)
            pcov = _inter_area(bx[:, :, None], pb[None, None]) / np.maximum(area[..., None], 1e-9)  # (P, T, M)
            pn = pd[None, None, :] < depth[c][..., None]
            free = free * np.prod(1.0 - np.clip(np.where(pn, pcov, 0.0), 0, 1), axis=-1)
        occl[c] = np.where(ok, 1.0 - free, 0.0)
    visible = (inside >= MIN_INSIDE) & (occl < HIDDEN) & np.isfinite(depth)
    return TrueBoxes(box, depth, inside, occl, visible)


def _ar1(rng: np.random.Generator, shape: tuple[int, ...], rho: float, burn: int = 60) -> np.ndarray:
    """Stationary AR(1) standard-normal sequences along the last axis."""
    e = rng.standard_normal(shape[:-1] + (shape[-1] + burn,))
    x = lfilter([np.sqrt(1 - rho * rho)], [1.0, -rho], e, axis=-1)
    return x[..., burn:]


def _bursts(rng: np.random.Generator, T: int, fps: float, rate_per_s: float, dur: tuple[float, float]) -> np.ndarray:
    """(T,) bool: random intervals (Poisson starts, uniform durations)."""
    out = np.zeros(T, bool)
    k = rng.poisson(rate_per_s * T / fps)
    starts = rng.integers(0, max(T, 1), k)
    lens = (rng.uniform(*dur, k) * fps).astype(int)
    for s, n in zip(starts, lens):  # a few bursts per routine
        out[s:s + n] = True
    return out


@dataclass
class DetectorParams:
    """Rates and noise levels of the detector model (defaults: a good modern detector)."""

    miss_base_target: float = 0.015
    miss_base_other: float = 0.03
    centre_noise: float = 0.025  #: std of the centre as a fraction of the box size
    size_noise: float = 0.035  #: std of log width / height
    noise_rho: float = 0.8  #: frame-to-frame correlation of the box errors
    miss_rho: float = 0.85  #: frame-to-frame correlation of the miss draws
    burst_rate_s: float = 1 / 50.0  #: per camera: target failure bursts per second
    burst_s: tuple[float, float] = (1.0, 3.0)
    pair_burst_rate_s: float = 1 / 80.0  #: both diagonal views fail together
    pair_burst_s: tuple[float, float] = (2.0, 4.0)
    fp_per_frame: float = 0.05  #: random false positives per frame and camera
    clutter: tuple[int, int] = (0, 2)  #: static false-positive places per camera


@dataclass
class DetectorOutput:
    """Detections of all cameras as columns (rows in (frame, camera) order)."""

    frame_index: np.ndarray  #: (N,) 0-based frame index
    camera: np.ndarray  #: (N,) camera index
    box: np.ndarray  #: (N, 4) centre form, pixels, clipped to the image
    score: np.ndarray  #: (N,) in [0, 1]
    person: np.ndarray  #: (N,) person index (row of the people arrays), -1 = false positive
    dropped_at_border: int  #: detector hits dropped because the box was mostly outside the image


def detect(rig: Rig, tb: TrueBoxes, unusual: np.ndarray, target_row: int, target_views: np.ndarray, fps: float,
           rng: np.random.Generator, params: DetectorParams = DetectorParams()) -> DetectorOutput:
    """Run the detector model.

    Parameters
    ----------
    rig: cameras (C).
    tb: true boxes (C, P, T).
    unusual: (P, T) how unusual each person's posture is, 0..1.
    target_row: row of the target in the people arrays.
    target_views: (C,) bool, the views that can detect the target (``n_cam``).
    fps: frames per second.
    rng: random generator.
    """
    p = params
    C, P, T = tb.depth.shape
    xywh = tb.xywh
    w, h = xywh[..., 2], xywh[..., 3]
    # image speed relative to the box size (motion blur)
    ctr = np.nan_to_num(xywh[..., :2])
    vel = np.zeros((C, P, T))
    if T > 1:
        dv = np.linalg.norm(np.diff(ctr, axis=2), axis=-1)
        vel[:, :, 1:] = dv
        vel[:, :, 0] = dv[:, :, 0]
    blur = np.clip(vel / np.maximum(h, 1.0) / 0.08, 0.0, 2.0)  # 1 = moving 8 % of the box height per frame
    occ = tb.occlusion
    un = np.broadcast_to(unusual[None], (C, P, T))

    # ---- all random numbers, at full size, in a fixed order
    miss_u = _ar1(rng, (C, P, T), p.miss_rho)
    noise = np.moveaxis(_ar1(rng, (C, P, 4, T), p.noise_rho), 2, -1)  # (C, P, T, 4)
    score_e = rng.standard_normal((C, P, T))
    bursts = np.stack([_bursts(rng, T, fps, p.burst_rate_s, p.burst_s) for _ in range(C)])
    pair = _bursts(rng, T, fps, p.pair_burst_rate_s, p.pair_burst_s)

    # ---- misses
    u = ndtr(miss_u)  # uniform marginals, correlated in time
    base = np.full((C, P, T), p.miss_base_other)
    base[:, target_row] = p.miss_base_target
    p_occ = 0.97 * np.clip((occ - 0.3) / 0.5, 0, 1) ** 1.5
    p_small = 0.9 * np.clip((45.0 - h) / 30.0, 0, 1)
    p_pose = 0.04 * un
    p_blur = 0.06 * np.clip(blur - 0.5, 0, 1.5)
    keep = (1 - base) * (1 - p_occ) * (1 - np.nan_to_num(p_small)) * (1 - p_pose) * (1 - p_blur)
    burst = bursts.copy()
    if C >= 4:
        burst[2] |= pair
        burst[3] |= pair
    keep[:, target_row] = np.where(burst, 0.05, keep[:, target_row])
    det = (u < keep) & tb.visible
    det[:, target_row] &= np.asarray(target_views, bool)[:, None]

    # ---- localisation noise and scores
    sig_c = p.centre_noise * (1 + 0.8 * un + 0.4 * blur + 1.0 * occ)
    sig_s = p.size_noise * (1 + 1.0 * un + 0.5 * blur + 1.5 * occ)
    cx = xywh[..., 0] + noise[..., 0] * sig_c * w
    cy = xywh[..., 1] + noise[..., 1] * sig_c * h * 0.8
    nw = w * np.exp(noise[..., 2] * sig_s)
    nh = h * np.exp(noise[..., 3] * sig_s)
    score = np.clip(0.93 - 0.5 * occ - 0.15 * un - 0.08 * np.clip(blur, 0, 1) + 0.05 * score_e, 0.05, 1.0)

    # ---- clip to the image, drop boxes mostly outside
    W = np.array([cam.size[0] for cam in rig], float)[:, None, None]
    H = np.array([cam.size[1] for cam in rig], float)[:, None, None]
    x0, y0, x1, y1 = cx - nw / 2, cy - nh / 2, cx + nw / 2, cy + nh / 2
    cx0, cy0 = np.clip(x0, 0, W), np.clip(y0, 0, H)
    cx1, cy1 = np.clip(x1, 0, W), np.clip(y1, 0, H)
    kept_frac = (cx1 - cx0) * (cy1 - cy0) / np.maximum(nw * nh, 1e-9)
    inside = kept_frac >= MIN_INSIDE
    dropped = int(np.count_nonzero(det & ~inside))
    det &= inside & np.isfinite(cx)

    ci, pi, ti = np.nonzero(det)
    boxes = np.column_stack([(cx0 + cx1)[det] / 2, (cy0 + cy1)[det] / 2, (cx1 - cx0)[det], (cy1 - cy0)[det]])
    out_f, out_c, out_b, out_s, out_p = [ti], [ci], [boxes], [score[det]], [pi]

    # ---- false positives
    for c, cam in enumerate(rig):
        Wc, Hc = cam.size
        n_cl = int(rng.integers(p.clutter[0], p.clutter[1] + 1))
        for _ in range(n_cl):
            hh = rng.uniform(60, 260)
            bb = np.array([rng.uniform(0.05, 0.95) * Wc, rng.uniform(0.35, 0.85) * Hc, hh * rng.uniform(0.3, 0.7), hh])
            on = ndtr(_ar1(rng, (T,), 0.95)) < rng.uniform(0.05, 0.3)
            k = int(on.sum())
            jitter = rng.normal(0, 0.02, (k, 4)) * bb[[3, 3, 2, 3]]
            out_f.append(np.flatnonzero(on))
            out_c.append(np.full(k, c))
            out_b.append(bb[None] + jitter)
            out_s.append(np.clip(rng.uniform(0.3, 0.6, k), 0, 1))
            out_p.append(np.full(k, -1))
        k = rng.poisson(p.fp_per_frame * T)
        hh = rng.uniform(50, 350, k)
        out_f.append(rng.integers(0, T, k))
        out_c.append(np.full(k, c))
        out_b.append(np.column_stack([rng.uniform(0.03, 0.97, k) * Wc, rng.uniform(0.3, 0.9, k) * Hc, hh * rng.uniform(0.3, 0.7, k), hh]))
        out_s.append(rng.uniform(0.3, 0.55, k))
        out_p.append(np.full(k, -1))
    f = np.concatenate(out_f).astype(np.int64)
    cam_i = np.concatenate(out_c).astype(np.int64)
    b = np.concatenate(out_b)
    s = np.concatenate(out_s)
    per = np.concatenate(out_p).astype(np.int64)
    # clip false positives to the image too
    Wv = np.array([cam.size[0] for cam in rig], float)[cam_i]
    Hv = np.array([cam.size[1] for cam in rig], float)[cam_i]
    xa, ya = np.clip(b[:, 0] - b[:, 2] / 2, 0, Wv), np.clip(b[:, 1] - b[:, 3] / 2, 0, Hv)
    xb, yb = np.clip(b[:, 0] + b[:, 2] / 2, 0, Wv), np.clip(b[:, 1] + b[:, 3] / 2, 0, Hv)
    b = np.column_stack([(xa + xb) / 2, (ya + yb) / 2, xb - xa, yb - ya])
    good = (b[:, 2] > 1) & (b[:, 3] > 1)
    order = np.lexsort((per[good], cam_i[good], f[good]))
    sel = np.flatnonzero(good)[order]
    return DetectorOutput(f[sel], cam_i[sel], b[sel], np.round(s[sel], 4), per[sel], dropped)
