"""Aggregation of a benchmark run: the paper's Tables 3, 5, 6 and the claims, as numbers.

Input: the *rows* of a benchmark, one per (routine, method), each holding the additive parts of
every metric (sums and counts), so that pooling routines is exact:

=================  ===========================================================================
column             meaning
=================  ===========================================================================
routine            routine name; ``apparatus``, ``n_cam``, ``seed`` describe it
method             cascade | triangulation | plane | mvpt | oracle
frames, seconds    frames tracked and tracker seconds (file reading excluded)
idsw, idsw_track,  target ID switches (one per transition) and their two kinds
idsw_person
aed_sum, aed_n     summed target centre error (m) and number of frames with both
fr_failures,       failed and evaluated (frame, view) pairs of the expanded boxes, and the
fr_evaluated,      failure kinds
fr_missing, ...
cov_covered,       performing frames with an output target, and performing frames
cov_frames
mota, idf1,        all-people MOT metrics of the 3D tracks (per routine)
mot_idsw
error              empty, or why the method failed on this routine
=================  ===========================================================================

Aggregation (documented in the report too):

* Table 3, per apparatus x n_cam x method: ID switches summed over routines; AED pooled over
  frames (sum / count); FR pooled over (frame, view) pairs; coverage pooled over frames.
* Table 5, per method: average FR per n_cam = mean over apparatus of the Table 3 FR; frames per
  second = all frames / all tracker seconds of that method.
* Table 6 (ablation: cascade / triangulation / plane): mean over apparatus of FR and AED per n_cam.
* Claims: the ratios and the issue's targets with PASS / FAIL (see :func:`claims`).
Rendering (markdown, CSV, JSON, plots) is :mod:`gymtrack.eval.render`; the claims' thresholds
are :class:`gymtrack.eval.config.BenchmarkConfig`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, Iterable, Sequence

import numpy as np

from ..apparatus import APPARATUS_NAMES
from .config import DEFAULT_CONFIG, BenchmarkConfig

__all__ = [
    "METHODS", "ABLATION", "N_CAMS", "ROW_FIELDS", "ok_rows", "present", "pooled", "table3", "averaged", "summed", "speed",
    "table5", "table6", "Claim", "ratios", "claims",
]

METHODS: tuple[str, ...] = ("cascade", "triangulation", "plane", "mvpt", "oracle", "cascade+")
ABLATION: tuple[str, ...] = ("cascade", "triangulation", "plane")
N_CAMS: tuple[int, ...] = (2, 3, 4)

ROW_FIELDS: tuple[str, ...] = (
    "routine", "apparatus", "n_cam", "seed", "method", "frames", "seconds",
    "idsw", "idsw_track", "idsw_person", "aed_sum", "aed_n",
    "fr_failures", "fr_evaluated", "fr_missing", "fr_outside", "fr_too_small",
    "cov_covered", "cov_frames", "mota", "idf1", "mot_idsw", "mot_fp", "mot_fn", "mot_objects",
    "target_switches", "error",
)
_SUMS = ("frames", "seconds", "idsw", "idsw_track", "idsw_person", "aed_sum", "aed_n", "fr_failures", "fr_evaluated",
         "fr_missing", "fr_outside", "fr_too_small", "cov_covered", "cov_frames")


def _div(a: float, b: float) -> float:
    return a / b if b else float("nan")


def ok_rows(rows: Iterable[dict]) -> list[dict]:
    """The rows of runs that did not fail (empty ``error``)."""
    return [r for r in rows if not r.get("error")]


def _nanmean(v: Sequence[float]) -> float:
    a = np.asarray([x for x in v if x is not None], dtype=np.float64)
    a = a[np.isfinite(a)]
    return float(a.mean()) if a.size else float("nan")


# ----------------------------------------------------------------------------- tables
def pooled(rows: Iterable[dict]) -> dict[tuple, dict]:
    """Sum the additive columns per (apparatus, n_cam, method) and derive the Table 3 metrics.

    Returns ``{(apparatus, n_cam, method): {idsw, aed, fr, coverage, routines, frames, seconds,
    mota, idf1, ...}}`` (MOTA / IDF1 are means over routines).
    """
    groups: dict[tuple, dict] = {}
    for r in ok_rows(rows):
        key = (r["apparatus"], int(r["n_cam"]), r["method"])
        g = groups.setdefault(key, {k: 0.0 for k in _SUMS} | {"routines": 0, "mota_list": [], "idf1_list": []})
        for k in _SUMS:
            v = r.get(k, 0)
            g[k] += 0.0 if v is None or (isinstance(v, float) and math.isnan(v)) else float(v)
        g["routines"] += 1
        g["mota_list"].append(r.get("mota", float("nan")))
        g["idf1_list"].append(r.get("idf1", float("nan")))
    out = {}
    for key, g in groups.items():
        out[key] = {
            "idsw": int(g["idsw"]),
            "aed": _div(g["aed_sum"], g["aed_n"]),
            "fr": _div(g["fr_failures"], g["fr_evaluated"]),
            "coverage": _div(g["cov_covered"], g["cov_frames"]),
            "routines": g["routines"],
            "frames": int(g["frames"]),
            "seconds": g["seconds"],
            "fr_missing": int(g["fr_missing"]), "fr_outside": int(g["fr_outside"]), "fr_too_small": int(g["fr_too_small"]),
            "fr_evaluated": int(g["fr_evaluated"]),
            "mota": _nanmean(g["mota_list"]),
            "idf1": _nanmean(g["idf1_list"]),
        }
    return out


def present(rows: Sequence[dict], field: str, order: Sequence) -> list:
    """The values of ``field`` the successful rows have: those of ``order`` first, in its order, then the rest sorted."""
    have = {r[field] if field != "n_cam" else int(r[field]) for r in ok_rows(rows)}
    return [x for x in order if x in have] + sorted(x for x in have if x not in order)


def table3(rows: Sequence[dict]) -> list[dict]:
    """Table 3 rows: one per (apparatus, n_cam, method) with idsw, aed, fr, coverage."""
    p = pooled(rows)
    out = []
    for app in present(rows, "apparatus", APPARATUS_NAMES):
        for n in present(rows, "n_cam", N_CAMS):
            for m in present(rows, "method", METHODS):
                if (app, n, m) in p:
                    v = p[(app, n, m)]
                    out.append({"apparatus": app, "n_cam": n, "method": m, **{k: v[k] for k in ("idsw", "aed", "fr", "coverage", "routines", "mota", "idf1")}})
    return out


def averaged(rows: Sequence[dict], metric: str) -> dict[tuple[str, int], float]:
    """``{(method, n_cam): mean over apparatus of the pooled metric}`` ('fr', 'aed', 'coverage')."""
    p = pooled(rows)
    acc: dict[tuple[str, int], list[float]] = {}
    for (app, n, m), v in p.items():
        acc.setdefault((m, n), []).append(v[metric])
    return {k: _nanmean(v) for k, v in acc.items()}


def summed(rows: Sequence[dict], metric: str = "idsw") -> dict[tuple[str, int], int]:
    """``{(method, n_cam): sum over apparatus and routines}`` of an integer metric."""
    p = pooled(rows)
    out: dict[tuple[str, int], int] = {}
    for (app, n, m), v in p.items():
        out[(m, n)] = out.get((m, n), 0) + int(v[metric])
    return out


def speed(rows: Sequence[dict]) -> dict[str, float]:
    """Frames per second per method: all frames / all tracker seconds."""
    f: dict[str, float] = {}
    s: dict[str, float] = {}
    for r in ok_rows(rows):
        f[r["method"]] = f.get(r["method"], 0.0) + float(r["frames"])
        s[r["method"]] = s.get(r["method"], 0.0) + float(r["seconds"])
    return {m: _div(f[m], s[m]) for m in f}


def table5(rows: Sequence[dict]) -> list[dict]:
    """Table 5 rows: per method, average FR at each n_cam and frames per second."""
    fr = averaged(rows, "fr")
    fps = speed(rows)
    out = []
    for m in present(rows, "method", METHODS):
        row: dict[str, Any] = {"method": m}
        for n in present(rows, "n_cam", N_CAMS):
            row[f"fr_{n}"] = fr.get((m, n), float("nan"))
        row["fps"] = fps.get(m, float("nan"))
        out.append(row)
    return out


def table6(rows: Sequence[dict]) -> list[dict]:
    """Table 6 rows (ablation): per mode, apparatus-averaged FR and AED at each n_cam."""
    fr = averaged(rows, "fr")
    aed = averaged(rows, "aed")
    out = []
    for m in [x for x in ABLATION if x in {r["method"] for r in ok_rows(rows)}]:
        row: dict[str, Any] = {"method": m}
        for n in present(rows, "n_cam", N_CAMS):
            row[f"fr_{n}"] = fr.get((m, n), float("nan"))
            row[f"aed_{n}"] = aed.get((m, n), float("nan"))
        out.append(row)
    return out


# ----------------------------------------------------------------------------- claims
@dataclass(frozen=True)
class Claim:
    """One target of the issue: ``value`` compared with ``limit``; status PASS / FAIL / n/a."""

    name: str
    value: float
    limit: float
    status: str
    detail: str

    def as_dict(self) -> dict:
        return {"name": self.name, "value": self.value, "limit": self.limit, "status": self.status, "detail": self.detail}


def ratios(rows: Sequence[dict]) -> list[dict]:
    """Per n_cam: cascade / triangulation for FR and AED, cascade / oracle for AED (apparatus-averaged)."""
    fr = averaged(rows, "fr")
    aed = averaged(rows, "aed")
    out = []
    for n in present(rows, "n_cam", N_CAMS):
        out.append({
            "n_cam": n,
            "fr_cascade_over_triangulation": _div(fr.get(("cascade", n), float("nan")), fr.get(("triangulation", n), float("nan"))),
            "aed_cascade_over_triangulation": _div(aed.get(("cascade", n), float("nan")), aed.get(("triangulation", n), float("nan"))),
            "aed_cascade_over_oracle": _div(aed.get(("cascade", n), float("nan")), aed.get(("oracle", n), float("nan"))),
        })
    return out


def _claim(name: str, value: float, limit: float, ok: bool | None, detail: str) -> Claim:
    status = "n/a" if ok is None or not np.isfinite(value) else ("PASS" if ok else "FAIL")
    return Claim(name, float(value), float(limit), status, detail)


def claims(rows: Sequence[dict], config: BenchmarkConfig = DEFAULT_CONFIG) -> list[Claim]:
    """The issue's targets, each PASS / FAIL (n/a when a method or n_cam is missing).

    The limits are ``config``'s (the defaults below are :data:`~gymtrack.eval.config.DEFAULT_CONFIG`'s):

    1. n_cam = 2, averaged over apparatus: cascade FR <= 0.3 x triangulation FR;
    2. ... cascade AED <= 0.85 x triangulation AED;
    3. ... cascade ID switches <= triangulation ID switches (summed);
    4. n_cam = 4: cascade AED at most 5 % above triangulation AED (``ratio <= 1.05``): the claim
       is that the cascade must not hurt when views are plenty, so being better passes;
    5. every n_cam: cascade AED <= 1.25 x oracle AED (one claim per n_cam);
    6. speed: cascade >= 1000 frames per second, and >= 0.9 x triangulation's.
    """
    fr = averaged(rows, "fr")
    aed = averaged(rows, "aed")
    sw = summed(rows, "idsw")
    fps = speed(rows)
    nan = float("nan")
    out = []

    def has(m, n):
        return (m, n) in fr

    if has("cascade", 2) and has("triangulation", 2):
        c, t = fr[("cascade", 2)], fr[("triangulation", 2)]
        k = config.fr_cascade_over_triangulation_2
        out.append(_claim(f"n_cam=2: FR cascade <= {k:g} x triangulation", _div(c, t) if t else (0.0 if c == 0 else math.inf), k,
                          c <= k * t, f"cascade {c:.4f}, triangulation {t:.4f}"))
        c, t = aed[("cascade", 2)], aed[("triangulation", 2)]
        k = config.aed_cascade_over_triangulation_2
        out.append(_claim(f"n_cam=2: AED cascade <= {k:g} x triangulation", _div(c, t), k, c <= k * t, f"cascade {c:.3f} m, triangulation {t:.3f} m"))
        c, t = sw.get(("cascade", 2), 0), sw.get(("triangulation", 2), 0)
        out.append(_claim("n_cam=2: ID switches cascade <= triangulation", float(c - t), 0.0, c <= t, f"cascade {c}, triangulation {t} (value = difference)"))
    else:
        out.append(_claim("n_cam=2: cascade vs triangulation", nan, nan, None, "needs cascade and triangulation at n_cam = 2"))
    k = config.aed_cascade_over_triangulation_4
    name = f"n_cam=4: AED cascade <= {k:g} x triangulation (no worse)"
    if has("cascade", 4) and has("triangulation", 4):
        c, t = aed[("cascade", 4)], aed[("triangulation", 4)]
        r = _div(c, t)
        out.append(_claim(name, r, k, r <= k, f"cascade {c:.3f} m, triangulation {t:.3f} m"))
    else:
        out.append(_claim(name, nan, k, None, "needs cascade and triangulation at n_cam = 4"))
    k = config.aed_cascade_over_oracle
    for n in present(rows, "n_cam", N_CAMS):
        if has("cascade", n) and has("oracle", n):
            c, o = aed[("cascade", n)], aed[("oracle", n)]
            out.append(_claim(f"n_cam={n}: AED cascade <= {k:g} x oracle", _div(c, o), k, c <= k * o, f"cascade {c:.3f} m, oracle {o:.3f} m"))
        else:
            out.append(_claim(f"n_cam={n}: AED cascade <= {k:g} x oracle", nan, k, None, "needs cascade and oracle"))
    if "cascade" in fps:
        k = config.min_fps
        out.append(_claim(f"speed: cascade >= {k:g} frames/s", fps["cascade"], k, fps["cascade"] >= k, f"{fps['cascade']:.0f} frames/s"))
        if "triangulation" in fps:
            k = config.fps_cascade_over_triangulation
            r = _div(fps["cascade"], fps["triangulation"])
            out.append(_claim(f"speed: cascade >= {k:g} x triangulation", r, k, r >= k, f"cascade {fps['cascade']:.0f}, triangulation {fps['triangulation']:.0f} frames/s"))
    return out
