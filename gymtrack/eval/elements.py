"""Scoring judging measurements: a measured ``elements.json`` and ``angles.csv`` against the truth.

Paper: Section III-D's last paragraph and Fig. 8 (the 3D pose sequence measured for the judges);
the element definitions are ``shared/formats.md``, "Outputs of the analysis stage"; the truth is
the simulator's ``gt/elements.json`` (:mod:`gymtrack.simulate.elements`) and the angles of its
true skeleton.

Matching: per kind, measured and true elements are paired one to one by the Hungarian assignment
(``scipy.optimize.linear_sum_assignment``) maximising the summed temporal IoU of their frame
spans (inclusive), a pair counting only at IoU >= :data:`MIN_IOU`. A landing is a point; it is
matched by the span the contract judges it over, its first contact and the 2 s after.

Scoring is in two steps so that a benchmark can pool routines: :func:`element_parts` gives one
routine's additive parts (counts and lists of errors), :func:`summarise_elements` turns any
number of them into recall, precision, shares and median / mean errors.
"""

from __future__ import annotations

from typing import Any, Iterable, Mapping, Sequence

import numpy as np
from scipy.optimize import linear_sum_assignment

from ..formats.elements import ANGLE_MEASURES, ELEMENT_KINDS

MIN_IOU = 0.3
LANDING_SPAN_S = 2.0  #: the contract's landing window (steps are counted over it)
#: angle columns scored frame by frame (somersault and twist are unwrapped from each file's first
#: row, so their offsets differ: they are scored through the flights' salto and twist counts)
SCORED_ANGLES: tuple[str, ...] = tuple(c for c in ANGLE_MEASURES if c not in ("somersault", "twist"))


def span(el: Mapping[str, Any], fps: float) -> tuple[int, int]:
    """(first, last) frame of an element, inclusive; a landing spans its first contact and the 2 s after."""
    if el["kind"] == "landing":
        return int(el["frame"]), int(el["frame"]) + int(round(LANDING_SPAN_S * fps)) - 1
    return int(el["start_frame"]), int(el["end_frame"])


def temporal_iou(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """(N, M) IoU of inclusive frame spans ``a`` (N, 2) and ``b`` (M, 2)."""
    a, b = np.asarray(a, float).reshape(-1, 2), np.asarray(b, float).reshape(-1, 2)
    inter = np.minimum(a[:, None, 1], b[None, :, 1]) - np.maximum(a[:, None, 0], b[None, :, 0]) + 1
    union = (a[:, None, 1] - a[:, None, 0] + 1) + (b[None, :, 1] - b[None, :, 0] + 1) - np.clip(inter, 0, None)
    return np.clip(inter, 0, None) / union


def match(gt_spans: np.ndarray, meas_spans: np.ndarray, min_iou: float = MIN_IOU) -> list[tuple[int, int, float]]:
    """One-to-one pairs ``(gt index, measured index, iou)`` maximising the summed IoU, each >= ``min_iou``."""
    if len(gt_spans) == 0 or len(meas_spans) == 0:
        return []
    iou = temporal_iou(gt_spans, meas_spans)
    gain = np.where(iou >= min_iou, iou, 0.0)
    r, c = linear_sum_assignment(-gain)
    return [(int(i), int(j), float(iou[i, j])) for i, j in zip(r, c) if iou[i, j] >= min_iou]


def _num(v) -> float:
    return float("nan") if v is None else float(v)


def element_parts(measured: Mapping[str, Any], truth: Mapping[str, Any], frames: np.ndarray | None = None,
                  true_com_z: tuple[np.ndarray, np.ndarray] | None = None) -> dict[str, Any]:
    """One routine's additive scoring parts.

    measured, truth: elements documents (``read_elements``). frames: the frames the measurement
    covers (``angles.csv``'s); a true element with less than half its span among them is left out
    and counted under ``not_analysed`` (nothing to measure it from). true_com_z: ``(frame, com_z)``
    of the true skeleton, the apex truth where ``truth`` has no ``apex_z``.
    """
    fps = float(truth["fps"])
    fset = None if frames is None else np.unique(np.asarray(frames, np.int64))
    parts: dict[str, Any] = {"kinds": {}, "not_analysed": {}, "flight": {k: [] for k in (
        "saltos_exact", "twists_exact", "shape_exact", "start_err", "end_err", "apex_err", "iou")},
        "hold": {"duration_err": [], "deviation_err": [], "position_exact": []},
        "landing": {"stuck_exact": [], "steps_err": []}, "turn": {"degrees_exact": []}}
    for kind in ELEMENT_KINDS:
        g = [e for e in truth["elements"] if e["kind"] == kind]
        m = [e for e in measured["elements"] if e["kind"] == kind]
        gs = np.array([span(e, fps) for e in g], np.int64).reshape(-1, 2)
        if fset is not None:
            cov = np.array([np.isin(np.arange(a, b + 1), fset).mean() for a, b in gs])
            keep = cov >= 0.5 if kind != "landing" else np.isin(gs[:, 0], fset)
            parts["not_analysed"][kind] = int((~keep).sum())
            g, gs = [e for e, k in zip(g, keep) if k], gs[keep]
        ms = np.array([span(e, fps) for e in m], np.int64).reshape(-1, 2)
        pairs = match(gs, ms)
        parts["kinds"][kind] = {"gt": len(g), "measured": len(m), "matched": len(pairs)}
        for i, j, iou in pairs:
            _score_pair(kind, g[i], m[j], iou, parts, true_com_z)
    return parts


def _score_pair(kind: str, t: dict, m: dict, iou: float, parts: dict, true_com_z) -> None:
    if kind == "flight":
        p = parts["flight"]
        p["iou"].append(iou)
        p["saltos_exact"].append(float(_num(m.get("saltos")) == _num(t.get("saltos"))))
        p["twists_exact"].append(float(_num(m.get("twists")) == _num(t.get("twists"))))
        p["shape_exact"].append(float(m.get("shape") == t.get("shape")))
        p["start_err"].append(abs(m["start_frame"] - t["start_frame"]))
        p["end_err"].append(abs(m["end_frame"] - t["end_frame"]))
        apex = _num(t.get("apex_z"))
        if np.isnan(apex) and true_com_z is not None:
            f, z = true_com_z
            sel = (f >= t["start_frame"]) & (f <= t["end_frame"])
            apex = float(np.nanmax(z[sel])) if sel.any() else float("nan")
        p["apex_err"].append(abs(_num(m.get("apex_z")) - apex))
    elif kind == "hold":
        p = parts["hold"]
        p["duration_err"].append(abs(_num(m.get("duration_s")) - _num(t.get("duration_s"))))
        p["deviation_err"].append(abs(_num(m.get("deviation")) - _num(t.get("deviation"))))
        p["position_exact"].append(float(m.get("position") == t.get("position")))
    elif kind == "landing":
        parts["landing"]["stuck_exact"].append(float(m.get("stuck") == t.get("stuck")))
        parts["landing"]["steps_err"].append(abs(_num(m.get("steps")) - _num(t.get("steps"))))
    elif kind == "turn":
        parts["turn"]["degrees_exact"].append(float(_num(m.get("degrees")) == _num(t.get("degrees"))))


def _stats(v: Sequence[float]) -> dict[str, float | int]:
    a = np.asarray(v, float)
    a = a[np.isfinite(a)]
    if a.size == 0:
        return {"median": float("nan"), "mean": float("nan"), "n": 0}
    return {"median": float(np.median(a)), "mean": float(np.mean(a)), "n": int(a.size)}


def _share(v: Sequence[float]) -> dict[str, float | int]:
    a = np.asarray(v, float)
    return {"share": float(a.mean()) if a.size else float("nan"), "n": int(a.size)}


def summarise_elements(parts: Iterable[Mapping[str, Any]]) -> dict[str, Any]:
    """Pool routines' :func:`element_parts`: per kind recall and precision; over matched flights
    the exact-salto, exact-twist and shape shares, start / end errors (frames) and apex error (m);
    hold duration (s) and deviation (deg) errors; landing stuck accuracy; turn degrees accuracy."""
    parts = list(parts)
    out: dict[str, Any] = {"kinds": {}, "not_analysed": {}}
    for kind in ELEMENT_KINDS:
        n = {k: sum(p["kinds"].get(kind, {}).get(k, 0) for p in parts) for k in ("gt", "measured", "matched")}
        out["kinds"][kind] = n | {"recall": n["matched"] / n["gt"] if n["gt"] else float("nan"),
                                  "precision": n["matched"] / n["measured"] if n["measured"] else float("nan")}
        out["not_analysed"][kind] = sum(p["not_analysed"].get(kind, 0) for p in parts)
    cat = lambda group, key: [x for p in parts for x in p[group][key]]  # noqa: E731
    out["flight"] = {"saltos_exact": _share(cat("flight", "saltos_exact")), "twists_exact": _share(cat("flight", "twists_exact")),
                     "shape": _share(cat("flight", "shape_exact")), "start_err_frames": _stats(cat("flight", "start_err")),
                     "end_err_frames": _stats(cat("flight", "end_err")),
                     "time_err_frames": _stats(cat("flight", "start_err") + cat("flight", "end_err")),
                     "apex_err_m": _stats(cat("flight", "apex_err")), "iou": _stats(cat("flight", "iou"))}
    out["hold"] = {"duration_err_s": _stats(cat("hold", "duration_err")), "deviation_err_deg": _stats(cat("hold", "deviation_err")),
                   "position": _share(cat("hold", "position_exact"))}
    out["landing"] = {"stuck": _share(cat("landing", "stuck_exact")), "steps_err": _stats(cat("landing", "steps_err"))}
    out["turn"] = {"degrees": _share(cat("turn", "degrees_exact"))}
    return out


def angle_parts(measured: Mapping[str, np.ndarray], truth: Mapping[str, np.ndarray]) -> dict[str, list[float]]:
    """Per scored angle column the absolute errors (deg) at the frames both have (``com`` the centre
    of mass distance, m); inputs are ``read_angles``-like column dicts with ``frame``."""
    fm, ft = np.asarray(measured["frame"]), np.asarray(truth["frame"])
    common, im, it = np.intersect1d(fm, ft, return_indices=True)
    out = {c: np.abs(np.asarray(measured[c], float)[im] - np.asarray(truth[c], float)[it]).tolist()
           for c in SCORED_ANGLES if c in measured and c in truth}
    if all(k in measured and k in truth for k in ("com_x", "com_y", "com_z")):
        d = np.stack([np.asarray(measured[k], float)[im] - np.asarray(truth[k], float)[it] for k in ("com_x", "com_y", "com_z")], 1)
        out["com"] = np.linalg.norm(d, axis=1).tolist()
    return out


def summarise_angles(parts: Iterable[Mapping[str, Sequence[float]]]) -> dict[str, dict[str, float | int]]:
    """Pool :func:`angle_parts`: per column the median and mean absolute error and the frames compared."""
    parts = list(parts)
    cols = [c for c in (*SCORED_ANGLES, "com") if any(c in p for p in parts)]
    return {c: _stats([x for p in parts for x in p.get(c, [])]) for c in cols}
