"""Somersault and twist: the body's rotation about the apparatus' somersault axis and its long axis.

Paper: Section III-C (the vertical plane the gymnast's saltos and giants turn in) and III-D,
last paragraph. Rule (``shared/formats.md``): ``somersault`` about the plane's normal ``n``,
``twist`` about the body's long axis ``L`` = H->S, right-hand signs, unwrapped since the first row.
Refined (``docs/analysis.md``): ``n`` is the preset's somersault axis
(:attr:`~gymtrack.apparatus.Apparatus.somersault_axis`), the plane's normal on every apparatus
but the pommel horse, whose dismounts turn over the horse about its length.

The orientation is split as ``R = R_n(somersault) R_e(lean) R_L(twist)`` (``e = n x z``): an Euler
sequence whose only singular pose is the long axis along ``n`` (the body lying across the plane),
never met in saltos or giants -- unlike yaw/pitch/roll about world z, which lock in every
handstand and every horizontal pose. So:

* somersault = ``atan2(L . (n x z), L . z)``, the angle of ``L`` in the plane, from +z;
* twist = the angle about ``L`` of the body's left-right line, from ``n`` made perpendicular to ``L``.

A tuck folds the shoulder line towards the hips, so where the trunk is folded (a hip angle under
:data:`FOLDED_HIP`) the twist is the pelvis line's alone; elsewhere the mean of the shoulder and
pelvis lines. Frames where the two lines disagree by more than :data:`DISAGREE` (as axes) are
flagged, and not read: :func:`unwrap_axial` bridges them, unwrapping the twist as a line's angle
so that a left/right swap of the pose estimate cannot add half twists (``docs/analysis.md``).
Frames within :data:`LOCK` of the singular pose are NaN and bridged when unwrapping.
"""

from __future__ import annotations

import numpy as np

from .joints import I

FOLDED_HIP = 120.0  #: degrees: below this hip angle the trunk is folded (twist from the pelvis)
DISAGREE = 30.0  #: degrees: shoulder and pelvis lines further apart than this are flagged
LOCK = 15.0  #: degrees: the long axis this close to the plane's normal has no somersault or twist
TWIST_SD_MAX = 45.0  #: degrees: a frame whose twist line is known worse than this is not read
Z = np.array([0.0, 0.0, 1.0])


def _unit(v: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / np.linalg.norm(v, axis=-1, keepdims=True)


def _about(axis: np.ndarray, ref: np.ndarray, v: np.ndarray) -> np.ndarray:
    """Angle (radians) of v about ``axis`` from ``ref`` (both perpendicular to axis), right-hand."""
    v = v - np.sum(v * axis, -1, keepdims=True) * axis
    return np.arctan2(np.sum(np.cross(ref, v) * axis, -1), np.sum(ref * v, -1))


def raw_rotation(X: np.ndarray, normal: np.ndarray, min_hip: np.ndarray) -> dict[str, np.ndarray]:
    """Per-frame wrapped angles (radians) from joints X (..., M, K, 3) and the somersault axis (3,).

    min_hip: (..., M) the smaller hip angle (degrees). Returns ``somersault``, ``twist`` (wrapped,
    NaN where undefined), ``twist_shoulders``, ``twist_pelvis``, ``pelvis`` (bool, the twist came from
    the pelvis alone) and ``disagree`` (bool).
    """
    n = np.asarray(normal, float)
    e = np.cross(n, Z)
    S = 0.5 * (X[..., I["left_shoulder"], :] + X[..., I["right_shoulder"], :])
    H = 0.5 * (X[..., I["left_hip"], :] + X[..., I["right_hip"], :])
    L = _unit(S - H)
    som = np.arctan2(L @ e, L @ Z)
    ref = _unit(n - (L @ n)[..., None] * L)
    sh = X[..., I["left_shoulder"], :] - X[..., I["right_shoulder"], :]
    pe = X[..., I["left_hip"], :] - X[..., I["right_hip"], :]
    t_sh, t_pe = _about(L, ref, sh), _about(L, ref, pe)
    # the lines' difference as axes (in [-90, 90] deg): a left/right swap of the legs alone turns the
    # pelvis line by 180 deg and leaves it the same axis
    gap = 0.5 * np.angle(np.exp(2j * (t_sh - t_pe)))
    pelvis = np.nan_to_num(min_hip, nan=180.0) < FOLDED_HIP
    both = t_pe + 0.5 * gap  # the two lines' mean axis
    tw = np.where(pelvis | ~np.isfinite(t_sh), t_pe, np.where(np.isfinite(t_pe), both, t_sh))
    with np.errstate(invalid="ignore"):
        locked = np.abs(L @ n) > np.cos(np.radians(LOCK))
    som = np.where(locked, np.nan, som)
    tw = np.where(locked, np.nan, tw)
    with np.errstate(invalid="ignore"):
        disagree = np.abs(gap) > np.radians(DISAGREE)
    return {"somersault": som, "twist": tw, "twist_shoulders": t_sh, "twist_pelvis": t_pe, "pelvis": pelvis,
            "disagree": disagree}


def unwrap(angle: np.ndarray, valid: np.ndarray) -> np.ndarray:
    """Unwrap wrapped angles (..., M) along the last axis over the ``valid`` (M,) frames, bridging
    the others (each step between valid frames taken as the shortest turn); returns radians
    relative to the first valid frame, NaN where not valid."""
    out = np.full(angle.shape, np.nan)
    idx = np.flatnonzero(valid)
    if idx.size == 0:
        return out
    a = angle[..., idx]
    a = np.where(np.isfinite(a), a, np.nan)
    # a sample's own NaN (noise at the singular pose) takes the previous value: no jump
    if np.isnan(a).any():
        a = _ffill(a)
    u = np.unwrap(a, axis=-1)
    out[..., idx] = u - u[..., :1]
    return out


def unwrap_axial(angle: np.ndarray, trusted: np.ndarray) -> np.ndarray:
    """Unwrap the angle (..., M) of a *line* (an axis: theta and theta + 180 deg are one line) over
    the ``trusted`` (M,) frames: 2 theta unwrapped, halved. A left/right swap of the pose estimate
    turns the left-right line by 180 deg and leaves it the same axis, so swaps cannot add or take
    away half turns; a true turn of under 90 deg between trusted frames (7.5 rev/s at 30 fps) unwraps
    as it does on the vector. The other frames (untrusted, or NaN in a sample) take the value
    interpolated between their trusted neighbours. Radians, relative to the first trusted frame."""
    out = np.full(angle.shape, np.nan)
    idx = np.flatnonzero(trusted)
    if idx.size == 0:
        return out
    if idx.size == 1:
        out[..., idx] = 0.0
        return out
    a = angle[..., idx]
    a = np.where(np.isfinite(a), a, np.nan)
    if np.isnan(a).any():
        a = _ffill(a)
    u = 0.5 * np.unwrap(2.0 * a, axis=-1)
    u = u - u[..., :1]
    lo, hi = idx[0], idx[-1]
    span = np.arange(lo, hi + 1)
    if idx.size == span.size:
        out[..., span] = u
        return out
    # linear interpolation between trusted frames, vectorised over the leading (sample) axes
    k = np.clip(np.searchsorted(idx, span, side="right") - 1, 0, idx.size - 2)
    w = (span - idx[k]) / np.maximum(idx[k + 1] - idx[k], 1)
    out[..., span] = u[..., k] * (1 - w) + u[..., k + 1] * w
    return out


def _ffill(a: np.ndarray) -> np.ndarray:
    ok = np.isfinite(a)
    pos = np.where(ok, np.arange(a.shape[-1]), 0)
    np.maximum.accumulate(pos, axis=-1, out=pos)
    filled = np.take_along_axis(a, pos, axis=-1)
    return np.where(np.isfinite(filled), filled, 0.0)


def heading(X: np.ndarray) -> np.ndarray:
    """(..., M) the horizontal heading (radians) of the body's front: the pelvis and shoulder lines
    (right->left) summed, turned -90 deg about z (the pelvis alone where a shoulder is missing);
    meaningful when the body is upright."""
    v = X[..., I["left_hip"], :] - X[..., I["right_hip"], :]
    w = X[..., I["left_shoulder"], :] - X[..., I["right_shoulder"], :]
    v = np.where(np.isfinite(w), v / np.linalg.norm(v, axis=-1, keepdims=True)
                 + w / np.linalg.norm(w, axis=-1, keepdims=True), v)
    return np.arctan2(v[..., 1], v[..., 0]) - np.pi / 2


def twist_sd(X: np.ndarray, sigma: np.ndarray, pelvis: np.ndarray) -> np.ndarray:
    """(M,) first-order sd (degrees) of the twist line's direction at each frame: a line between two
    joints of sds s1, s2 and length l turns by sqrt(s1^2 + s2^2) / l; the pelvis line alone where
    ``pelvis`` (M,) (the trunk folded), else the mean of the shoulder and pelvis lines (the
    shoulder line alone where a hip is missing). X (M, K, 3), sigma (M, K) metres."""
    def line(a, b):
        with np.errstate(invalid="ignore", divide="ignore"):
            return np.degrees(np.hypot(sigma[:, I[a]], sigma[:, I[b]]) / np.linalg.norm(X[:, I[a]] - X[:, I[b]], axis=-1))

    sh, pe = line("left_shoulder", "right_shoulder"), line("left_hip", "right_hip")
    both = np.where(np.isfinite(sh) & np.isfinite(pe), 0.5 * np.hypot(sh, pe), np.where(np.isfinite(pe), pe, sh))
    return np.where(pelvis, pe, both)
