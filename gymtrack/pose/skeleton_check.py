"""After lifting: does the 3D skeleton look like a body, or like a misread joint order?

Rule (keypoints contract: a skeleton is never misread silently): a file read in the wrong joint
order still reprojects well -- each "joint" is a real point seen in every view -- but its bones
join unrelated points. Two numbers show it:

* ``bone_cv``: the median over bones of a track's bone length's coefficient of variation over
  frames (a real forearm keeps its length; "right_eye to right_ear" read as an upper arm does,
  but "left_wrist to right_wrist" read as a thigh does not);
* ``asymmetry``: the median ``|log(left / right)|`` of mirrored limbs' median lengths (upper
  arm, forearm, thigh, shin): a body's two sides are within a few per cent.

Right skeletons on the simulator's pose model: ``bone_cv`` ~0.05-0.1, ``asymmetry`` ~0.02;
misread BODY_25 / BODY_25B: ``asymmetry`` 0.3 and more. A right lift from few or noisy views can vary
its bones by 30 % and more (a pivot seen by two views) with its sides still within a few per cent,
so the asymmetry decides; ``bone_cv`` only where no mirrored limb pair was measured.
Arrays: Poses3D xyz (M, J, 3).
"""

from __future__ import annotations

import numpy as np

from ..poses import Poses3D

__all__ = ["skeleton_consistency", "BONE_CV_MAX", "ASYMMETRY_MAX"]

BONE_CV_MAX = 0.3
ASYMMETRY_MAX = 0.15
_LIMBS = (("shoulder", "elbow"), ("elbow", "wrist"), ("hip", "knee"), ("knee", "ankle"))


def skeleton_consistency(p: Poses3D, min_frames: int = 10) -> dict:
    """``{"bone_cv", "asymmetry", "suspect"}`` over the tracks with ``min_frames`` frames or more
    (NaN and not suspect when nothing can be measured)."""
    sk = p.skeleton
    names = sk.joints
    pos = {n: i for i, n in enumerate(names)}
    cvs, asym = [], []
    for tid in np.unique(p.track_id):
        xyz = p.xyz[p.track_id == tid]
        if len(xyz) < min_frames:
            continue
        med = {}
        for a, b in _LIMBS:
            for side in ("left", "right"):
                ia, ib = pos.get(f"{side}_{a}"), pos.get(f"{side}_{b}")
                if ia is None or ib is None:
                    continue
                L = np.linalg.norm(xyz[:, ia] - xyz[:, ib], axis=1)
                L = L[np.isfinite(L)]
                if L.size >= min_frames and np.median(L) > 0:
                    med[(side, a, b)] = np.median(L)
                    cvs.append(np.std(L) / np.median(L))
        for a, b in _LIMBS:
            if ("left", a, b) in med and ("right", a, b) in med:
                asym.append(abs(np.log(med[("left", a, b)] / med[("right", a, b)])))
    cv = float(np.median(cvs)) if cvs else np.nan
    sym = float(np.median(asym)) if asym else np.nan
    # the two sides decide where they can be compared: a noisy but right lift varies its bones (a pivot,
    # two views) while its sides stay equal; bone_cv alone decides only where no mirrored pair was measured
    suspect = sym > ASYMMETRY_MAX if np.isfinite(sym) else cv > BONE_CV_MAX
    return {"bone_cv": cv, "asymmetry": sym, "suspect": bool(suspect)}
