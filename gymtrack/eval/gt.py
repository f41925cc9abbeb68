"""The oracle association: detections labelled with ground-truth persons.

Paper: Section IV-A evaluates against ground-truth 3D tracklets and 2D boxes of the target
gymnast (read by :mod:`gymtrack.formats.ground_truth`; :class:`GroundTruth` and
:func:`load_ground_truth` are re-exported here). :func:`match_detections_to_gt` labels each
detection with the person whose true box it overlaps (per frame and view, Hungarian on IoU, at
least ``iou_min``; -1 otherwise): fed to the tracker with ``association="oracle"`` this is the
association a perfect cross-view / cross-frame matcher would find, the limit that better
association could reach (not a method).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from ..detections import Detections
from ..formats.ground_truth import GroundTruth, load_ground_truth, read_persons_3d
from .metrics import pairs_by_key

__all__ = ["GroundTruth", "load_ground_truth", "read_persons_3d", "box_iou", "match_detections_to_gt", "with_gt_ids"]


# ----------------------------------------------------------------------------- oracle matching
def box_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """IoU of centre-form boxes ``(..., 4)`` and ``(..., 4)`` (broadcast) -> ``(...)``."""
    a = np.asarray(a, dtype=np.float64)
    b = np.asarray(b, dtype=np.float64)
    lo = np.maximum(a[..., :2] - a[..., 2:] / 2, b[..., :2] - b[..., 2:] / 2)
    hi = np.minimum(a[..., :2] + a[..., 2:] / 2, b[..., :2] + b[..., 2:] / 2)
    inter = np.prod(np.clip(hi - lo, 0, None), axis=-1)
    union = a[..., 2] * a[..., 3] + b[..., 2] * b[..., 3] - inter
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(union > 0, inter / union, 0.0)


@dataclass(frozen=True)
class OracleMatch:
    """GT person id per detection, and how many were matched."""

    person_id: np.ndarray  #: (N,) int64, -1 = no true box with IoU >= iou_min (a false positive)
    matched: int
    unmatched: int
    conflicts_resolved: int  #: (frame, view) groups where the Hungarian had to choose


def match_detections_to_gt(det: Detections, gt: GroundTruth, iou_min: float = 0.5, visible_only: bool = True) -> OracleMatch:
    """Label every detection with the ground-truth person whose true box it overlaps.

    Per (frame, view), a one-to-one assignment maximising the IoU (``scipy``'s
    ``linear_sum_assignment``) between detections and true boxes, keeping pairs with
    ``IoU >= iou_min``. Vectorised: all candidate pairs are built at once by joining on
    (frame, view); the Hungarian only runs on the few groups where one box has more than one
    candidate. ``visible_only``: only true boxes flagged visible can be matched (a hidden person
    cannot have been detected).
    ``det.camera_names`` must be those of ``gt`` (same order).
    """
    from scipy.optimize import linear_sum_assignment

    if tuple(det.camera_names) != tuple(gt.camera_names):
        raise ValueError(f"detections have cameras {det.camera_names}, ground truth {gt.camera_names}")
    n = len(det)
    out = np.full(n, -1, np.int64)
    gsel = np.flatnonzero(gt.box_visible) if visible_only else np.arange(len(gt.box_frame))
    C = max(len(gt.camera_names), 1)
    dkey = det.frame.astype(np.int64) * C + det.camera.astype(np.int64)
    gkey = gt.box_frame[gsel] * C + gt.box_camera[gsel].astype(np.int64)
    ia, ib = pairs_by_key(dkey, gkey)
    iou = box_iou(det.box[ia], gt.box[gsel][ib])
    ok = iou >= iou_min
    ia, ib, iou = ia[ok], ib[ok], iou[ok]
    dup_d = np.bincount(ia, minlength=n) > 1
    dup_g = np.bincount(ib, minlength=gsel.size) > 1
    conflict_pair = dup_d[ia] | dup_g[ib]
    clean = ~conflict_pair
    out[ia[clean]] = gt.box_person[gsel][ib[clean]]
    bad_keys = np.unique(dkey[ia[conflict_pair]])
    for key in bad_keys:  # rare: only groups with competing candidates
        m = dkey[ia] == key
        di, gi = np.unique(ia[m], return_inverse=True)
        gj, gj_inv = np.unique(ib[m], return_inverse=True)
        W = np.zeros((di.size, gj.size))
        W[gi, gj_inv] = iou[m]
        r, c = linear_sum_assignment(-W)
        good = W[r, c] >= iou_min
        out[di[r[good]]] = gt.box_person[gsel][gj[c[good]]]
    matched = int((out >= 0).sum())
    return OracleMatch(out, matched, n - matched, int(bad_keys.size))


def with_gt_ids(det: Detections, gt: GroundTruth, iou_min: float = 0.5) -> tuple[Detections, OracleMatch]:
    """A copy of ``det`` whose ``track_id`` is the matched GT person id (-1 for false positives)."""
    m = match_detections_to_gt(det, gt, iou_min)
    return replace(det, track_id=m.person_id), m
