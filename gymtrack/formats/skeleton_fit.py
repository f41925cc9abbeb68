"""Which skeleton a 2D pose file holds: recognised from the joints' layout, never from the count alone.

Rule (``shared/formats.md``, keypoints): the joint order of a file is given (``--skeleton``, the
native ``skeleton`` key) or recognised from the joint count *and* a check that the joints lie
like that skeleton's joints; BODY_25 and BODY_25B both have 25 joints in different orders, and a
file read in the wrong one reprojects as well as the right one, with every joint misnamed.

The checks, over the poses' confident joints (score >= ``min_score``), each scaled by the pose's
size ``s`` (the larger side of its confident joints' box):

* ``mirror``: the median ``|log(left / right)|`` of the lengths of mirrored limbs (upper arm,
  forearm, thigh, shin) -- a body's two sides have about the same lengths in an image, a misread
  order pairs unrelated joints;
* ``neck``: the median distance of the neck from the shoulders' midpoint over ``s`` (skeletons
  with a neck): the neck sits between the shoulders;
* ``upright``: the share of poses whose hips lie below their shoulders in the image (image y
  down): most frames of a person are upright, even in gymnastics.

Arrays: keypoints (N, J, 3) ``[x, y, score]``.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..skeletons import FILE_JOINTS, SKELETONS, Skeleton

__all__ = ["LayoutFit", "layout_fit", "candidates_for", "rank_layouts", "clearly_better", "CLEAR_RATIO", "MIRROR_MAX", "NECK_MAX", "UPRIGHT_MIN", "MIN_POSES"]

#: a fitting layout's limits (calibrated on the simulator's pose model written in BODY_25 and
#: BODY_25B order: right layouts 0.17-0.20 limb mismatch, misread ones 0.39-0.94)
MIRROR_MAX = 0.35
NECK_MAX = 0.08
UPRIGHT_MIN = 0.3
#: poses with the checks' joints needed before a layout can be told
MIN_POSES = 20
#: a layout is told from another when it fits and the other's limb mismatch is this many times larger
CLEAR_RATIO = 1.6

_LIMBS = (("shoulder", "elbow"), ("elbow", "wrist"), ("hip", "knee"), ("knee", "ankle"))


@dataclass(frozen=True)
class LayoutFit:
    """How well poses lie like ``skeleton``'s joints (module docstring); NaN where not measurable."""

    skeleton: Skeleton
    poses: int
    mirror: float
    neck: float
    upright: float

    @property
    def measurable(self) -> bool:
        return self.poses >= MIN_POSES and np.isfinite(self.mirror)

    @property
    def fits(self) -> bool:
        """The layout fits: measurable and no check out of its limit."""
        return (self.measurable and self.mirror <= MIRROR_MAX and not self.neck > NECK_MAX
                and not self.upright < UPRIGHT_MIN)

    def describe(self) -> str:
        parts = [f"left/right limb mismatch {self.mirror:.2f} (fits <= {MIRROR_MAX})"]
        if np.isfinite(self.neck):
            parts.append(f"neck off the shoulders' middle {self.neck:.2f} (fits <= {NECK_MAX})")
        if np.isfinite(self.upright):
            parts.append(f"hips below shoulders in {self.upright:.0%} (fits >= {UPRIGHT_MIN:.0%})")
        return f"{self.skeleton.name}: " + ", ".join(parts) + f" over {self.poses} poses"


def candidates_for(n_joints: int) -> list[Skeleton]:
    """The known skeletons a file with ``n_joints`` joints per pose may hold."""
    return [SKELETONS[n] for n, j in FILE_JOINTS.items() if j == n_joints]


def _idx(sk: Skeleton, name: str) -> int:
    return int(sk.index([name])[0])


def layout_fit(keypoints: np.ndarray, skeleton: Skeleton, min_score: float = 0.3) -> LayoutFit:
    """The checks of the module docstring for ``keypoints`` (N, J, 3) read as ``skeleton``."""
    kp = np.asarray(keypoints, np.float64)
    J = len(skeleton.joints)
    if kp.ndim != 3 or kp.shape[1:] != (J, 3) or not len(kp):
        return LayoutFit(skeleton, 0, np.nan, np.nan, np.nan)
    ok = (kp[..., 2] >= min_score) & np.isfinite(kp[..., 0]) & np.isfinite(kp[..., 1])
    xy = np.where(ok[..., None], kp[..., :2], np.nan)
    with np.errstate(invalid="ignore"), np.testing.suppress_warnings() as sup:
        sup.filter(RuntimeWarning)
        size = np.nanmax(np.nanmax(xy, axis=1) - np.nanmin(xy, axis=1), axis=1)  # (N,)
    size = np.where(size > 0, size, np.nan)

    def length(a: int, b: int) -> np.ndarray:
        return np.linalg.norm(xy[:, a] - xy[:, b], axis=1)

    ratios, have = [], np.zeros(len(kp), bool)
    for a, b in _LIMBS:
        ia, ib = _idx(skeleton, f"left_{a}"), _idx(skeleton, f"left_{b}")
        ja, jb = _idx(skeleton, f"right_{a}"), _idx(skeleton, f"right_{b}")
        if min(ia, ib, ja, jb) < 0:
            continue
        left, right = length(ia, ib), length(ja, jb)
        good = (left > 0) & (right > 0) & np.isfinite(left) & np.isfinite(right)
        have |= good
        ratios.append(np.abs(np.log(left[good] / right[good])))
    r = np.concatenate(ratios) if ratios else np.zeros(0)
    mirror = float(np.median(r)) if r.size else np.nan

    ls, rs = _idx(skeleton, "left_shoulder"), _idx(skeleton, "right_shoulder")
    lh, rh, nk = _idx(skeleton, "left_hip"), _idx(skeleton, "right_hip"), _idx(skeleton, "neck")
    neck = upright = np.nan
    if min(ls, rs, nk) >= 0:
        d = np.linalg.norm(xy[:, nk] - 0.5 * (xy[:, ls] + xy[:, rs]), axis=1) / size
        d = d[np.isfinite(d)]
        neck = float(np.median(d)) if d.size >= MIN_POSES else np.nan
    if min(ls, rs, lh, rh) >= 0:
        dy = 0.5 * (xy[:, lh, 1] + xy[:, rh, 1]) - 0.5 * (xy[:, ls, 1] + xy[:, rs, 1])
        dy = dy[np.isfinite(dy)]
        upright = float((dy > 0).mean()) if dy.size >= MIN_POSES else np.nan
    return LayoutFit(skeleton, int(have.sum()), mirror, neck, upright)


def rank_layouts(keypoints: np.ndarray, candidates: Sequence[Skeleton], min_score: float = 0.3) -> list[LayoutFit]:
    """:func:`layout_fit` of each candidate, fitting ones first, then by ``mirror``."""
    fits = [layout_fit(keypoints, s, min_score) for s in candidates]
    return sorted(fits, key=lambda f: (not f.fits, f.mirror if np.isfinite(f.mirror) else np.inf))


def clearly_better(a: LayoutFit, b: LayoutFit) -> bool:
    """``a`` fits and ``b`` clearly does not: its limb mismatch is :data:`CLEAR_RATIO` times ``a``'s
    or more (random or unrelated joints can pass one check by chance, not both this way)."""
    return a.fits and not b.fits and (not np.isfinite(b.mirror) or b.mirror >= CLEAR_RATIO * a.mirror)
