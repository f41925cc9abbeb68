"""The plane-fitting experiment (beyond the paper): a wrong preset plane, then the fitted one.

Paper: Section III-C's vertical plane (Eq. 7) is typed in; the cascade's plane candidates are
only as good as it. Per routine this runs the cascade three times and compares the target's
AED (Section IV's average Euclidean distance over the performing frames):

* ``true``: the scene's plane (the simulated apparatus);
* ``wrong``: that plane shifted ``shift`` metres along its normal and turned ``turn`` degrees
  about the vertical through the scene's focus;
* ``fitted``: the plane fitted from the data (:mod:`gymtrack.tracking.plane_fit`, a
  ``triangulation``-mode pass; the wrong plane is its preset, whose direction it keeps where
  the data do not determine one).

and ``cascade+`` twice: with the true plane (``aed_true_plus``) and with the wrong one refined
online (:mod:`gymtrack.tracking.plane_refine`, every ``refine_every`` windows; ``aed_online``;
its final plane's offset and angle from the true one). It reports the fitted plane's distance
from the true one (offset at the focus, metres; angle, degrees) and whether its direction was
determined. ``fitted_over_true`` <= 1.1 is the issue's target; :func:`plane_table` groups the
rows by apparatus and n_cam.
"""

from __future__ import annotations

import numpy as np

from ..errors import InputError
from ..geometry.plane import Plane
from ..geometry.plane_fit import plane_difference
from ..scene import Scene
from ..tracking.plane_fit import REFINE_EVERY, fit_scene_planes, with_plane
from ..tracking.offline import track_detections
from .metrics import average_euclidean_distance

__all__ = ["FIT_PASSES", "perturbed_plane", "plane_experiment", "plane_table", "plane_markdown"]



def perturbed_plane(plane: Plane, at: np.ndarray, shift: float, turn_deg: float) -> Plane:
    """``plane`` shifted ``shift`` m along its normal and turned ``turn_deg`` about the vertical
    axis through ``at`` (3,)."""
    a = np.radians(turn_deg)
    Rz = np.array([[np.cos(a), -np.sin(a), 0.0], [np.sin(a), np.cos(a), 0.0], [0.0, 0.0, 1.0]])
    on = plane.project(np.asarray(at, dtype=np.float64))
    n = Rz @ plane.normal
    return Plane(on + shift * n, n)


#: what the offline fit may read first (:func:`plane_experiment`'s ``fit_pass``)
FIT_PASSES = ("triangulation", "cascade", "both")


def plane_experiment(routine, gt, shift: float = 0.3, turn_deg: float = 10.0, mode: str = "cascade",
                     refine_every: int = REFINE_EVERY, fit_pass: str = "both") -> dict:
    """One routine (a loaded :class:`~gymtrack.formats.routine.Routine`) and its ground truth
    (:class:`~gymtrack.formats.ground_truth.GroundTruth`): AED with the true, wrong and fitted
    planes, and the fitted plane's offset (m) and angle (deg) from the true one. ``fit_pass``:
    the first pass the fit reads, ``triangulation`` (needs no plane), ``cascade`` with the wrong
    plane (its two-view target frames re-triangulated from their boxes) or ``both`` (what
    ``planes: auto`` does: the cascade's target frames the triangulation pass lacks added)."""
    if fit_pass not in FIT_PASSES:
        raise InputError(f"fit_pass must be one of {', '.join(FIT_PASSES)}, got {fit_pass!r}", field="fit_pass")
    rig, scene, det = routine.rig, routine.scene, routine.detections
    true = Plane.from_spec(scene.planes[0])
    focus = scene.focus_point
    t = gt.target()
    perf = np.unique(t.frame[t.performing(np.asarray(scene.performance_space, dtype=np.float64))])

    def aed(sc: Scene, m: str = mode, keep: list | None = None) -> float:
        res = track_detections(rig, sc, det, mode=m)
        if keep is not None:
            keep.append(res)
        a = average_euclidean_distance(t.frame, t.xyz, res.target.frame, res.target.xyz, frames=perf)
        return a.total / a.n if a.n else float("nan")

    wrong = with_plane(scene, perturbed_plane(true, focus, shift, turn_deg))
    # the wrong plane is the preset: the fit's starting guess, kept where the data do not fix the direction
    first = track_detections(rig, wrong, det, mode="cascade" if fit_pass == "cascade" else "triangulation")
    extra = track_detections(rig, wrong, det, mode="cascade") if fit_pass == "both" else None
    fit = fit_scene_planes(first, wrong, rig=rig, extra=extra)
    out = {"aed_true": aed(scene), "aed_wrong": aed(wrong), "target_points": fit.n_target}
    online = wrong.model_copy(update={"params": wrong.params.model_copy(update={"refine_plane": refine_every})})
    runs: list = []
    out |= {"aed_true_plus": aed(scene, "cascade+"), "aed_online": aed(online, "cascade+", runs)}
    moved = runs[0].summary["plane_refinement"]
    o_off, o_ang = plane_difference(Plane(np.array(moved["point"]), np.array(moved["normal"])), true, focus)
    out |= {"online_offset_m": o_off, "online_angle_deg": o_ang, "online_refits": moved["refits"],
            "online_over_true": _ratio(out["aed_online"], out["aed_true_plus"])}
    if fit.plane is None:
        return out | {"aed_fitted": float("nan"), "offset_m": float("nan"), "angle_deg": float("nan"),
                      "fitted_over_true": float("nan"), "direction_determined": False, "why_not": "too few points"}
    off, ang = plane_difference(fit.plane.plane, true, focus)
    out |= {"aed_fitted": aed(with_plane(scene, fit.plane.plane)), "offset_m": off, "angle_deg": ang,
            "direction_determined": fit.plane.determined, "why_not": fit.plane.reason}
    out["fitted_over_true"] = _ratio(out["aed_fitted"], out["aed_true"])
    return out


def _ratio(a: float, b: float) -> float:
    return a / b if b > 0 else float("nan")


#: the columns :func:`plane_table` averages per apparatus and n_cam
TABLE_COLUMNS = ("offset_m", "angle_deg", "aed_true", "aed_wrong", "aed_fitted", "fitted_over_true", "aed_true_plus",
                 "aed_online", "online_over_true", "online_offset_m", "online_angle_deg")


def plane_table(rows: list[dict]) -> list[dict]:
    """Rows of :func:`plane_experiment` (with ``apparatus`` and ``n_cam``) -> one row per
    (apparatus, n_cam) and per n_cam over all apparatus: the means of :data:`TABLE_COLUMNS` (NaN
    rows skipped, counted in ``no_fit``), routines, and routines whose direction was determined.
    The ratios are of the mean AEDs (fitted / true), not means of per-routine ratios."""
    groups: dict = {}
    for r in rows:
        groups.setdefault((r["apparatus"], r["n_cam"]), []).append(r)
        groups.setdefault(("all", r["n_cam"]), []).append(r)
    out = []
    for (app, n), rs in sorted(groups.items(), key=lambda kv: (kv[0][0] == "all", kv[0][0], kv[0][1])):
        row = {"apparatus": app, "n_cam": n, "routines": len(rs),
               "determined": sum(bool(r.get("direction_determined")) for r in rs),
               "no_fit": sum(not np.isfinite(r.get("aed_fitted", np.nan)) for r in rs)}
        for c in TABLE_COLUMNS:
            v = np.array([r.get(c, np.nan) for r in rs], dtype=np.float64)
            row[c] = float(np.nanmean(v)) if np.isfinite(v).any() else float("nan")
        row["fitted_over_true"] = _ratio(row["aed_fitted"], row["aed_true"])
        row["online_over_true"] = _ratio(row["aed_online"], row["aed_true_plus"])
        out.append(row)
    return out


def plane_markdown(table: list[dict]) -> str:
    """The table of :func:`plane_table` as markdown."""
    head = ["apparatus", "n_cam", "routines", "determined", "offset_m", "angle_deg", "aed_true", "aed_wrong",
            "aed_fitted", "fitted_over_true", "aed_true_plus", "aed_online", "online_over_true", "online_offset_m",
            "online_angle_deg"]
    lines = ["| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for r in table:
        lines.append("| " + " | ".join(f"{r[h]:.3f}" if isinstance(r[h], float) else str(r[h]) for h in head) + " |")
    return "\n".join(lines) + "\n"
