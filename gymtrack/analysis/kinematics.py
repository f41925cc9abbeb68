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

from .joints import I

#: de Leva (1996), Table 4, segment parameters adjusted to joint centres:
#: segment -> (mass % female, mass % male, CM % from the proximal end female, male)
DE_LEVA: dict[str, tuple[float, float, float, float]] = {
    "head": (6.68, 6.94, 58.94, 59.76),  # vertex -> cervicale
    "trunk": (42.57, 43.46, 41.51, 44.86),  # cervicale -> mid-hip
    "upper_arm": (2.55, 2.71, 57.54, 57.72),  # shoulder -> elbow
    "forearm": (1.38, 1.62, 45.59, 45.74),  # elbow -> wrist
    "hand": (0.56, 0.61, 74.74, 79.00),  # wrist -> 3rd metacarpal head
    "thigh": (14.78, 14.16, 36.12, 40.95),  # hip -> knee
    "shank": (4.81, 4.33, 44.16, 44.59),  # knee -> lateral malleolus
    "foot": (1.29, 1.37, 40.14, 44.15),  # heel -> toe tip
}
#: hand length (wrist to 3rd metacarpal head) over forearm length (de Leva's mean lengths)
HAND_OVER_FOREARM = 0.31
BODIES = ("mean", "female", "male")


def segment_table(body: str = "mean") -> dict[str, tuple[float, float]]:
    """segment -> (mass fraction, CM fraction from the proximal end) for ``body`` (mean | female | male)."""
    if body not in BODIES:
        raise ValueError(f"body must be one of {', '.join(BODIES)}, got {body!r}")
    out = {}
    for seg, (mf, mm, cf, cm) in DE_LEVA.items():
        m, c = {"female": (mf, cf), "male": (mm, cm), "mean": ((mf + mm) / 2, (cf + cm) / 2)}[body]
        out[seg] = (m / 100.0, c / 100.0)
    return out


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

    Segments (de Leva 1996, :data:`DE_LEVA`): head at the head's centre (COCO has no vertex or
    cervicale), trunk from the mid-shoulder (for the cervicale) to the mid-hip, upper arms,
    forearms, hands along the forearm beyond the wrist (hand length ``HAND_OVER_FOREARM`` x the
    forearm), thighs, shanks, feet at the ankles (COCO has no heel or toe).
    """
    T = segment_table(body)
    S, H = mid(X, "left_shoulder", "right_shoulder"), mid(X, "left_hip", "right_hip")

    def along(a, b, seg):
        return a + T[seg][1] * (b - a)

    parts = [(T["head"][0], head_centre(X)), (T["trunk"][0], along(S, H, "trunk"))]
    for side in ("left", "right"):
        sh, el, wr = _j(X, f"{side}_shoulder"), _j(X, f"{side}_elbow"), _j(X, f"{side}_wrist")
        hip, kn, an = _j(X, f"{side}_hip"), _j(X, f"{side}_knee"), _j(X, f"{side}_ankle")
        parts += [(T["upper_arm"][0], along(sh, el, "upper_arm")), (T["forearm"][0], along(el, wr, "forearm")),
                  (T["hand"][0], wr + T["hand"][1] * HAND_OVER_FOREARM * (wr - el)),
                  (T["thigh"][0], along(hip, kn, "thigh")), (T["shank"][0], along(kn, an, "shank")),
                  (T["foot"][0], an)]
    total = sum(m for m, _ in parts)
    com = sum(m * p for m, p in parts) / total
    fallback = ~np.all(np.isfinite(com), axis=-1)
    return np.where(fallback[..., None], H, com), fallback
