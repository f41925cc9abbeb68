"""Lifting single snapshots: what a track measures on itself, pooled over many persons instead.

Beyond the paper (Section III-D lifts a track's frames). Where each "track" is one snapshot --
a still, or a data set of independent multi-view frames such as MVOR -- two of the lifting's
track-level rules have nothing to stand on:

* bone lengths: the weak joints' pull to their bone's length (:func:`.anchor.pull_to_bones`: a
  joint one view sees gets its depth from its placed neighbour) needs the person's lengths over
  its frames. A body's proportions vary little between adults, so the lengths are measured over
  many persons' joints triangulated from 2+ views (median; no ground truth), the way the 2D noise
  level is pooled (:func:`measure_noise`), and given as ``LiftOptions.bone_lengths_m``;
* views that agree on no body: a track's neighbouring frames tell which view is the person
  (:mod:`.temporal`); a snapshot has none, and two views of different bodies triangulate to a
  point of neither. ``LiftOptions.decline_disagreeing`` then gives no joint, counted
  (``joints_declined``), rather than a guess.
"""

from __future__ import annotations

import numpy as np

from ..poses import HOW_TRIANGULATED
from ..geometry import Rig
from ..skeletons import Skeleton
from .anchor import bone_lengths


def pooled_bone_lengths(xyz: np.ndarray, how: np.ndarray, n_views: np.ndarray, skeleton: Skeleton,
                        min_persons: int = 20) -> tuple[float, ...]:
    """Each bone's median length over persons (K snapshots) whose two ends were triangulated from
    2+ views: xyz (K, J, 3), how and n_views (K, J) as :class:`.lift.Lifted` gives them. NaN for a
    bone with fewer than ``min_persons`` such persons. For ``LiftOptions.bone_lengths_m``."""
    strong = (how == HOW_TRIANGULATED) & (n_views >= 2) & np.isfinite(xyz).all(axis=-1)
    bones = np.asarray(skeleton.bones, np.int64).reshape(-1, 2)
    return tuple(float(x) for x in bone_lengths(xyz, strong, bones, min_persons))


def measure_noise(rig: Rig, keypoints: np.ndarray, skeleton: Skeleton, options=None) -> float:
    """The 2D noise level (std per coordinate over the box, pooled over joints) of keypoints
    (T, C, J, 3) raw pixels: :func:`.lift.noise_level` of their all-view solution. For
    ``LiftOptions.noise_frac`` when single snapshots are lifted one by one (T rows = snapshots,
    e.g. persons); it uses no ground truth."""
    from .lift import LiftOptions, _all_views, _box_size, _check, _prepare, noise_level

    options = options or LiftOptions()
    kp, _, _ = _check(rig, keypoints, skeleton, "robust", None, None, options)
    u, v, ok, sc = _prepare(rig, kp, options)
    box = _box_size(u, v, ok)
    X, w, _ = _all_views(rig.projections, u, v, ok, sc, box, options)
    return float(np.median(noise_level(rig.projections, X, u, v, w, box, min_samples=np.iinfo(np.int64).max)))
