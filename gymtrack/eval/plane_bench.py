"""The plane-fitting experiment (beyond the paper; issue 12): a wrong preset plane, then the fitted one.

Paper: Section III-C's vertical plane (Eq. 7) is typed in; the cascade's plane candidates are
only as good as it. Per routine this runs the cascade three times and compares the target's
AED (Section IV's average Euclidean distance over the performing frames):

* ``true``: the scene's plane (the simulated apparatus);
* ``wrong``: that plane shifted ``shift`` metres along its normal and turned ``turn`` degrees
  about the vertical through the scene's focus;
* ``fitted``: the plane fitted from the data (:mod:`gymtrack.tracking.plane_fit`, a
  ``triangulation``-mode pass; the preset plane plays no part in it).

It also reports the fitted plane's distance from the true one (offset at the focus, metres;
angle, degrees). ``fitted_over_true`` <= 1.1 is the issue's target.
"""

from __future__ import annotations

import numpy as np

from ..geometry.plane import Plane
from ..geometry.plane_fit import plane_difference
from ..scene import Scene
from ..tracking.plane_fit import fit_scene_planes, with_plane
from ..tracking.tracker import track_detections
from .metrics import average_euclidean_distance

__all__ = ["perturbed_plane", "plane_experiment"]


def perturbed_plane(plane: Plane, at: np.ndarray, shift: float, turn_deg: float) -> Plane:
    """``plane`` shifted ``shift`` m along its normal and turned ``turn_deg`` about the vertical
    axis through ``at`` (3,)."""
    a = np.radians(turn_deg)
    Rz = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    on = plane.project(np.asarray(at, dtype=np.float64))
    n = Rz @ plane.normal
    return Plane(on + shift * n, n)


def plane_experiment(routine, gt, shift: float = 0.3, turn_deg: float = 10.0, mode: str = "cascade") -> dict:
    """One routine (a loaded :class:`~gymtrack.formats.routine.Routine`) and its ground truth
    (:class:`~gymtrack.formats.ground_truth.GroundTruth`): AED with the true, wrong and fitted
    planes, and the fitted plane's offset (m) and angle (deg) from the true one."""
    rig, scene, det = routine.rig, routine.scene, routine.detections
    true = Plane.from_spec(scene.planes[0])
    focus = scene.focus_point
    t = gt.target()
    perf = np.unique(t.frame[t.performing(np.asarray(scene.performance_space, dtype=np.float64))])

    def aed(sc: Scene) -> float:
        res = track_detections(rig, sc, det, mode=mode)
        a = average_euclidean_distance(t.frame, t.xyz, res.target.frame, res.target.xyz, frames=perf)
        return a.total / a.n if a.n else float("nan")

    wrong = with_plane(scene, perturbed_plane(true, focus, shift, turn_deg))
    fit = fit_scene_planes(track_detections(rig, scene, det, mode="triangulation"), scene)
    out = {"aed_true": aed(scene), "aed_wrong": aed(wrong), "target_points": fit.n_target}
    if fit.plane is None:
        return out | {"aed_fitted": float("nan"), "offset_m": float("nan"), "angle_deg": float("nan")}
    off, ang = plane_difference(fit.plane.plane, true, focus)
    out |= {"aed_fitted": aed(with_plane(scene, fit.plane.plane)), "offset_m": off, "angle_deg": ang}
    out["fitted_over_true"] = out["aed_fitted"] / out["aed_true"] if out["aed_true"] > 0 else float("nan")
    return out
