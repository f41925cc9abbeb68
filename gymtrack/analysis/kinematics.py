"""Per-frame joint angles, inclination and the centre of mass (de Leva 1996).

Paper: Section III-D, last paragraph and Fig. 8 -- the 3D pose measured for the judges. Rules:
``shared/formats.md``, "Outputs of the analysis stage": ``knee`` = angle(hip, knee, ankle),
``elbow`` = angle(shoulder, elbow, wrist), ``hip`` = angle(S, hip, knee), ``shoulder`` =
angle(hip, shoulder, elbow), ``split`` the angle between the two hip->ankle vectors (hip->knee
where an ankle is missing), ``inclination`` the angle between world +z and A->S.

Every function takes joints ``X`` of shape (..., M, K, 3) (:data:`.joints.USED` order; the
leading axes may hold Monte Carlo samples) and returns arrays of shape (..., M); NaN where a
joint is missing.
"""

from __future__ import annotations

import numpy as np

from ..segments import BODIES, DE_LEVA, HAND_OVER_FOREARM, HEAD, com_weights, segment_table
from .joints import I

__all__ = ["BODIES", "DE_LEVA", "HAND_OVER_FOREARM", "segment_table", "frame_angles", "centre_of_mass", "com_sd",
           "head_centre", "included", "mid", "vector_angle", "angle_sd"]


def _j(X: np.ndarray, name: str) -> np.ndarray:
    return X[..., I[name], :]


def mid(X: np.ndarray, a: str, b: str) -> np.ndarray:
    """(..., M, 3) the mid-point of two joints (NaN if either is missing)."""
    return 0.5 * (_j(X, a) + _j(X, b))


def vector_angle(u: np.ndarray, v: np.ndarray) -> np.ndarray:
    """(...) the angle between vectors (..., 3) in degrees, [0, 180] (atan2 form: exact near 0 and 180)."""
    c = np.linalg.norm(np.cross(u, v), axis=-1)
    d = np.sum(u * v, axis=-1)
    return np.degrees(np.arctan2(c, d))


def included(a: np.ndarray, b: np.ndarray, c: np.ndarray) -> np.ndarray:
    """The included angle at ``b`` of (a, b, c), degrees in [0, 180]; 180 = straight."""
    return vector_angle(a - b, c - b)


def frame_angles(X: np.ndarray) -> dict[str, np.ndarray]:
    """The contract's angles (degrees, (..., M) each): knees, hips, elbows, shoulders, split, inclination."""
    S = mid(X, "left_shoulder", "right_shoulder")
    out = {}
    for side in ("left", "right"):
        hip, knee, ankle = _j(X, f"{side}_hip"), _j(X, f"{side}_knee"), _j(X, f"{side}_ankle")
        sh, el, wr = _j(X, f"{side}_shoulder"), _j(X, f"{side}_elbow"), _j(X, f"{side}_wrist")
        out[f"{side}_knee"] = included(hip, knee, ankle)
        out[f"{side}_hip"] = included(S, hip, knee)
        out[f"{side}_elbow"] = included(sh, el, wr)
        out[f"{side}_shoulder"] = included(hip, sh, el)
    lh, rh = _j(X, "left_hip"), _j(X, "right_hip")
    la, ra = _j(X, "left_ankle"), _j(X, "right_ankle")
    by_ankle = vector_angle(la - lh, ra - rh)
    by_knee = vector_angle(_j(X, "left_knee") - lh, _j(X, "right_knee") - rh)
    out["split"] = np.where(np.isfinite(by_ankle), by_ankle, by_knee)
    A = 0.5 * (la + ra)
    out["inclination"] = vector_angle(S - A, np.array([0.0, 0.0, 1.0]))
    return out


def head_centre(X: np.ndarray) -> np.ndarray:
    """(..., M, 3) the head's centre: the mid-ears, else the ear found, else the nose."""
    le, re_, no = _j(X, "left_ear"), _j(X, "right_ear"), _j(X, "nose")
    both = 0.5 * (le + re_)
    one = np.where(np.isfinite(le), le, re_)
    h = np.where(np.isfinite(both), both, one)
    return np.where(np.isfinite(h), h, no)


def centre_of_mass(X: np.ndarray, body: str = "mean") -> tuple[np.ndarray, np.ndarray]:
    """The centre of mass (..., M, 3) and a (..., M) bool flag: True where a joint a segment needs
    is missing and the mid-hip ``H`` stands in for the centre of mass.

    Segments: de Leva 1996 placed on the COCO joints (:func:`gymtrack.segments.com_weights`: trunk
    from the mid-shoulder to the mid-hip, hands beyond the wrists, feet at the ankles), the head at
    :func:`head_centre` (the mid-ears, else an ear, else the nose).
    """
    W = com_weights(body)
    com = (W[HEAD[0]] + W[HEAD[1]]) * head_centre(X)
    for name, w in W.items():
        if name not in HEAD:
            com = com + w * _j(X, name)
    fallback = ~np.all(np.isfinite(com), axis=-1)
    return np.where(fallback[..., None], mid(X, "left_hip", "right_hip"), com), fallback


def com_sd(sigma: np.ndarray, body: str = "mean") -> np.ndarray:
    """(M,) the centre of mass' position sd (m, per axis) from the joints' isotropic, independent
    sds ``sigma`` (M, K): the centre of mass is a fixed linear combination of the joints
    (:func:`gymtrack.segments.com_weights`), so sd = sqrt(sum_k w_k^2 sigma_k^2); where a joint
    is missing, the mid-hip's sd (the fallback)."""
    W = com_weights(body)
    w = np.zeros(sigma.shape[-1])
    for name, wk in W.items():
        w[I[name]] = wk
    with np.errstate(invalid="ignore"):
        sd = np.sqrt(np.sum((w * sigma) ** 2, axis=-1))
        hip = 0.5 * np.sqrt(sigma[..., I["left_hip"]] ** 2 + sigma[..., I["right_hip"]] ** 2)
    return np.where(np.isfinite(sd), sd, hip)


def angle_sd(X: np.ndarray, sigma: np.ndarray) -> dict[str, np.ndarray]:
    """First-order sd (degrees, (M,) each) of the knee and hip angles of joints X (M, K, 3) with
    isotropic joint sds ``sigma`` (M, K) (m): an end joint moved by s across its segment of length
    l turns the angle by s / l; the vertex joint moves both segments. (The Monte Carlo samples give
    the full sd; this one needs none, for rules that read the measurement alone.)"""
    S = mid(X, "left_shoulder", "right_shoulder")
    sS = 0.5 * np.sqrt(sigma[:, I["left_shoulder"]] ** 2 + sigma[:, I["right_shoulder"]] ** 2)
    out = {}

    def sd(a, sa, b, sb, c, sc):
        with np.errstate(invalid="ignore", divide="ignore"):
            iu, iv = 1.0 / np.sum((a - b) ** 2, -1), 1.0 / np.sum((c - b) ** 2, -1)
            return np.degrees(np.sqrt(sa ** 2 * iu + sc ** 2 * iv + sb ** 2 * (iu + iv)))

    for side in ("left", "right"):
        h, k, a = (I[f"{side}_{j}"] for j in ("hip", "knee", "ankle"))
        out[f"{side}_knee"] = sd(X[:, h], sigma[:, h], X[:, k], sigma[:, k], X[:, a], sigma[:, a])
        out[f"{side}_hip"] = sd(S, sS, X[:, h], sigma[:, h], X[:, k], sigma[:, k])
    return out
