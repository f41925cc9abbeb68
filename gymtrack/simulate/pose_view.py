"""What a top-down pose model sees in a crop: whose body, which joints are self-occluded, from
which side and how rotated (geometry for :mod:`.pose_model`).

Paper: Section III-D ("Identify Target Gymnast for Pose Estimation": HRNet runs on the target's
expanded box ``b_buf``; Fig. 7: a biased box shows the pose model the wrong thing). Everything
here is per crop and vectorised over the N crops (no loop per joint):

* :func:`project_people`: (N, P, 17, 2) pixels and (N, P, 17) depths of every person in the view
  and frame of each crop;
* :func:`choose_person`: the person a crop holds most (the projected body's visible overlap with
  the crop and its centring), the person a top-down model locks on to;
* :func:`self_occluded`: (N, 17) joints whose line of sight passes through the body's own
  capsules (torso, limbs, head) before reaching them;
* :func:`view_of_body`: (N,) how much the body is seen from behind and how far it is rotated
  in the image from upright;
* :func:`uniforms`: counter-based random numbers keyed by (seed, frame, camera, person), so the
  same person in the same view and frame gets the same draws whichever method's box it is in
  (common random numbers: method comparisons see the same model errors).
"""

from __future__ import annotations

import numpy as np
from scipy.special import ndtri

from ..geometry.camera import Rig

# COCO-17 indices.
NOSE, L_EAR, R_EAR, L_SH, R_SH, L_HIP, R_HIP = 0, 3, 4, 5, 6, 11, 12
FACE = np.arange(5)
#: Capsules of the body as (joint a, joint b, radius as a fraction of body height); the last
#: three use virtual ends (mid-shoulder -1, mid-hip -2, head centre -3) and the head is a sphere.
#: Radii: anthropometric half-thicknesses of a 1.70 m body (upper arm ~5 cm, thigh ~8 cm,
#: trunk ~12 cm), the same order as the flesh pads of :mod:`.body`.
CAPSULES = np.array([
    (5, 7, 0.028), (7, 9, 0.022), (6, 8, 0.028), (8, 10, 0.022),        # arms
    (11, 13, 0.042), (13, 15, 0.030), (12, 14, 0.042), (14, 16, 0.030),  # legs
    (5, 11, 0.045), (6, 12, 0.045), (5, 6, 0.035), (11, 12, 0.045),      # torso rim
    (-1, -2, 0.065),                                                      # torso core
    (-3, -3, 0.052),                                                      # head (a sphere)
])
#: Chain shoulder-hip-knee-ankle as a fraction of height (the segment table of :mod:`.body`).
_CHAIN_H = 0.785
MIN_DEPTH = 0.3


def body_height(X: np.ndarray) -> np.ndarray:
    """(...) body height estimated from COCO-17 joints ``X`` (..., 17, 3): the mean of the two
    shoulder-hip-knee-ankle chains over :data:`_CHAIN_H`."""
    def chain(a):
        idx = [a, a + 6, a + 8, a + 10]
        return sum(np.linalg.norm(X[..., i, :] - X[..., j, :], axis=-1) for i, j in zip(idx[:-1], idx[1:]))
    return 0.5 * (chain(L_SH) + chain(R_SH)) / _CHAIN_H


def project_people(rig: Rig, joints3d: np.ndarray, t_idx: np.ndarray, cam: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every person's joints in the view and frame of each crop.

    joints3d: (P, T, 17, 3) world joints (NaN absent); t_idx: (N,) frame index; cam: (N,) camera.
    Returns uv (N, P, 17, 2) raw pixels (NaN where absent or behind the camera) and depth
    (N, P, 17) camera z (NaN likewise).
    """
    N, P = t_idx.size, joints3d.shape[0]
    uv = np.full((N, P, 17, 2), np.nan)
    depth = np.full((N, P, 17), np.nan)
    for c, camera in enumerate(rig):  # a loop over the (few) cameras only
        m = np.flatnonzero(cam == c)
        if m.size == 0:
            continue
        X = np.moveaxis(joints3d[:, t_idx[m]], 0, 1)  # (n, P, 17, 3)
        d = camera.depth(X)
        ok = d > MIN_DEPTH
        uv[m] = np.where(ok[..., None], camera.project(X), np.nan)
        depth[m] = np.where(ok, d, np.nan)
    return uv, depth


def body_boxes(uv: np.ndarray, grow: float) -> np.ndarray:
    """(..., 4) ``[x0, y0, x1, y1]`` around joints ``uv`` (..., 17, 2), grown by ``grow`` of the
    box height on every side (head top, hands and feet lie beyond the joints); NaN if any joint
    is missing."""
    lo, hi = uv.min(axis=-2), uv.max(axis=-2)
    pad = grow * (hi[..., 1] - lo[..., 1])[..., None]
    return np.concatenate([lo - pad, hi + pad], axis=-1)


def _inter(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    w = np.clip(np.minimum(a[..., 2], b[..., 2]) - np.maximum(a[..., 0], b[..., 0]), 0, None)
    h = np.clip(np.minimum(a[..., 3], b[..., 3]) - np.maximum(a[..., 1], b[..., 1]), 0, None)
    return w * h


def choose_person(uv: np.ndarray, depth: np.ndarray, crop: np.ndarray, grow: float,
                  min_overlap: float) -> tuple[np.ndarray, np.ndarray]:
    """The person each crop holds most.

    uv (N, P, 17, 2), depth (N, P, 17), crop (N, 4) xyxy. Person p's hold on crop n is
    ``visible * fill^0.25 * exp(-8 d^2 / area_crop)``: ``visible`` the share of the body's box
    inside the crop and not behind a nearer person's box (85 % of an overlap hides, as in
    :mod:`.detector`), ``fill`` the share of the crop the body fills (a tiny far body counts
    less), ``d`` the distance of the body's centre from the crop's (a top-down crop is built
    around a person: the model locks on to the body in its middle). Ties go to the nearer
    person. Returns person row (N,) (-1 when no hold reaches ``min_overlap``) and the hold (N,).
    """
    N, P = uv.shape[:2]
    if P == 0:
        return np.full(N, -1, np.int64), np.zeros(N)
    bb = body_boxes(uv, grow)  # (N, P, 4)
    area_b = (bb[..., 2] - bb[..., 0]) * (bb[..., 3] - bb[..., 1])
    area_c = (crop[:, 2] - crop[:, 0]) * (crop[:, 3] - crop[:, 1])
    inter = _inter(bb, crop[:, None, :])
    near = np.nan_to_num(depth.mean(axis=-1), nan=np.inf)  # (N, P)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = inter / area_b
        cover = _inter(bb[:, :, None], bb[:, None, :]) / area_b[:, :, None]  # [n, i, j]: j's box covers i's
        nearer = near[:, None, :] < near[:, :, None] - 0.2
        hidden = np.max(np.where(nearer, np.nan_to_num(cover), 0.0), axis=-1)
        fill = np.minimum(inter / area_c[:, None], 1.0)
        d = 0.5 * (bb[..., :2] + bb[..., 2:]) - 0.5 * (crop[:, None, :2] + crop[:, None, 2:])
        hold = share * (1 - 0.85 * np.clip(hidden, 0, 1)) * fill ** 0.25 * np.exp(-8.0 * (d ** 2).sum(-1) / area_c[:, None])
    hold = np.where(np.isfinite(hold), hold, 0.0)
    best = np.argmax(hold - 1e-9 * np.minimum(near, 1e6), axis=1)  # nearer wins an exact tie
    best_h = hold[np.arange(N), best]
    return np.where(best_h >= min_overlap, best, -1).astype(np.int64), best_h


def closest_on_segments(p0, p1, q0, q1):
    """Closest points of segments p0-p1 and q0-q1 (..., 3), broadcast: returns (s, t, distance)
    with s, t in [0, 1] the parameters along each."""
    d1, d2, r = p1 - p0, q1 - q0, p0 - q0
    a = np.einsum("...i,...i", d1, d1)
    e = np.einsum("...i,...i", d2, d2)
    f = np.einsum("...i,...i", d2, r)
    c = np.einsum("...i,...i", d1, r)
    b = np.einsum("...i,...i", d1, d2)
    den = a * e - b * b
    with np.errstate(invalid="ignore", divide="ignore"):
        s = np.where(den > 1e-12, np.clip((b * f - c * e) / den, 0, 1), 0.0)
        s = np.where(e > 1e-12, s, np.clip(-c / np.where(a > 1e-12, a, 1.0), 0, 1))  # q is a point (a sphere)
        t = np.where(e > 1e-12, (b * s + f) / e, 0.0)
        # t outside [0, 1]: clamp it and recompute s for the clamped t
        tc = np.clip(t, 0, 1)
        s = np.where(t != tc, np.clip((b * tc - c) / np.where(a > 1e-12, a, 1.0), 0, 1), s)
    dist = np.linalg.norm(p0 + s[..., None] * d1 - (q0 + tc[..., None] * d2), axis=-1)
    return s, tc, dist


def self_occluded(X: np.ndarray, centre: np.ndarray, margin: float = 0.5) -> np.ndarray:
    """(N, 17) bool: the joint's line of sight from the camera passes through one of the body's
    own :data:`CAPSULES` (not one the joint belongs to) before reaching it.

    X: (N, 17, 3) world joints of the person in each crop; centre: (N, 3) camera centres.
    A capsule counts when the ray's closest approach to its axis is within its radius and at
    least ``margin`` radii in front of the joint (a joint on the capsule's near surface is not
    hidden by it).
    """
    H = body_height(X)[:, None]  # (N, 1)
    mid_sh = 0.5 * (X[:, L_SH] + X[:, R_SH])
    mid_hip = 0.5 * (X[:, L_HIP] + X[:, R_HIP])
    head = 0.5 * (X[:, L_EAR] + X[:, R_EAR])
    ext = np.concatenate([X, head[:, None], mid_hip[:, None], mid_sh[:, None]], axis=1)  # -3, -2, -1 index from the end
    a_i, b_i = (np.where(CAPSULES[:, k] < 0, 20, 0) + CAPSULES[:, k].astype(int) for k in (0, 1))
    A, Bc = ext[:, a_i], ext[:, b_i]  # (N, K, 3)
    rad = CAPSULES[:, 2][None] * H  # (N, K)
    p0 = np.broadcast_to(centre[:, None, None, :], (X.shape[0], 17, 1, 3))
    p1 = X[:, :, None, :]
    s, _, dist = closest_on_segments(p0, p1, A[:, None], Bc[:, None])  # (N, 17, K)
    L = np.linalg.norm(X - centre[:, None, :], axis=-1)[..., None]  # (N, 17, 1)
    blocks = (dist < rad[:, None, :]) & (s * L < L - margin * rad[:, None, :])
    own = (a_i[None, :] == np.arange(17)[:, None]) | (b_i[None, :] == np.arange(17)[:, None])  # (17, K)
    return np.any(blocks & ~own[None], axis=-1)


def view_of_body(X: np.ndarray, centre: np.ndarray, uv: np.ndarray, upright_deg: float) -> tuple[np.ndarray, np.ndarray]:
    """How the body faces the camera and how it lies in the image.

    X (N, 17, 3) world joints, centre (N, 3) camera centres, uv (N, 17, 2) their pixels.
    Returns ``back`` (N,) in [0, 1] (1 = seen straight from behind: the cosine between the
    body's back direction and the line to the camera) and ``rotated`` (N,) in [0, 1]: 0 while the
    hips-to-shoulders direction is within ``upright_deg`` of the image's up, 1 upside down.
    """
    left = X[:, L_SH] - X[:, R_SH] + X[:, L_HIP] - X[:, R_HIP]
    up = X[:, L_SH] + X[:, R_SH] - X[:, L_HIP] - X[:, R_HIP]
    front = np.cross(left, up)  # body frame: x front = y left x z up
    to_cam = centre - 0.25 * (X[:, L_SH] + X[:, R_SH] + X[:, L_HIP] + X[:, R_HIP])
    with np.errstate(invalid="ignore", divide="ignore"):
        cosf = np.einsum("ni,ni->n", front, to_cam) / (np.linalg.norm(front, axis=-1) * np.linalg.norm(to_cam, axis=-1))
    back = np.clip(-np.nan_to_num(cosf), 0.0, 1.0)
    up2 = uv[:, L_SH] + uv[:, R_SH] - uv[:, L_HIP] - uv[:, R_HIP]  # image y grows downwards
    ang = np.degrees(np.arctan2(np.abs(up2[:, 0]), -up2[:, 1]))  # 0 = upright, 180 = upside down
    rotated = np.clip((np.nan_to_num(ang) - upright_deg) / (180.0 - upright_deg), 0.0, 1.0)
    return back, rotated


# ----------------------------------------------------------------------------- random numbers
def _splitmix(z: np.ndarray) -> np.ndarray:
    with np.errstate(over="ignore"):
        z = z + np.uint64(0x9E3779B97F4A7C15)
        z = (z ^ (z >> np.uint64(30))) * np.uint64(0xBF58476D1CE4E5B9)
        z = (z ^ (z >> np.uint64(27))) * np.uint64(0x94D049BB133111EB)
        return z ^ (z >> np.uint64(31))


def crop_keys(seed: int, frame: np.ndarray, camera: np.ndarray, person: np.ndarray) -> np.ndarray:
    """(N,) uint64 random-stream keys of (seed, frame, camera, person)."""
    z = _splitmix(np.full(frame.shape, np.uint64(int(seed) & 0xFFFFFFFFFFFFFFFF)))
    for v in (frame, camera, person):
        z = _splitmix(z ^ np.asarray(v).astype(np.int64).astype(np.uint64))
    return z


def uniforms(keys: np.ndarray, stream: int, size: int) -> np.ndarray:
    """(N, size) uniforms in (0, 1) of stream ``stream`` for keys (N,)."""
    sub = _splitmix(np.uint64(stream) * np.uint64(1 << 20) + np.arange(size, dtype=np.uint64))
    z = _splitmix(keys[:, None] ^ sub[None, :])
    return ((z >> np.uint64(11)).astype(np.float64) + 0.5) * 2.0 ** -53


def normals(keys: np.ndarray, stream: int, size: int) -> np.ndarray:
    """(N, size) standard normals of stream ``stream``."""
    return ndtri(uniforms(keys, stream, size))
