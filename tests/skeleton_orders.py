"""The simulator's COCO-17 poses written in another skeleton's joint order (test helper).

The missing joints are made from the COCO ones the way the tools place them: BODY_25's neck and
mid hip at the shoulders' and hips' middles; BODY_25B's upper neck a fifth of the way from the
shoulders' middle to the nose and its head top past the nose; toes and heels beyond the ankle
along the shin. Arrays: (N, 17, 3) in, (N, J, 3) out.
"""

from __future__ import annotations

import numpy as np

from gymtrack.skeletons import BODY25B, COCO17, Skeleton


def _mid(a: np.ndarray, b: np.ndarray, w: float = 0.5) -> np.ndarray:
    p = np.empty_like(a)
    p[:, :2] = (1 - w) * a[:, :2] + w * b[:, :2]
    p[:, 2] = np.minimum(a[:, 2], b[:, 2])
    return p


def to_order(kp17: np.ndarray, sk: Skeleton) -> np.ndarray:
    c = {n: kp17[:, i] for i, n in enumerate(COCO17.joints)}
    sh = _mid(c["left_shoulder"], c["right_shoulder"])
    extra = {"neck": _mid(sh, c["nose"], 0.2) if sk == BODY25B else sh,
             "mid_hip": _mid(c["left_hip"], c["right_hip"]), "hip": _mid(c["left_hip"], c["right_hip"]),
             "head": _mid(sh, c["nose"], 1.5)}
    for side in ("left", "right"):
        a, k = c[f"{side}_ankle"], c[f"{side}_knee"]
        for name, w in (("heel", 0.08), ("big_toe", 0.18), ("small_toe", 0.16)):
            p = a.copy()
            p[:, :2] = a[:, :2] + w * (a[:, :2] - k[:, :2])
            extra[f"{side}_{name}"] = p
    return np.stack([c[n] if n in c else extra[n] for n in sk.joints], axis=1)
