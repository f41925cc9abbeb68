"""Tables, claims and the written report of a benchmark run (paper Tables 3, 5, 6 and Fig. 6).

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
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Iterable, Sequence

import numpy as np

from ..apparatus import ABBREVIATIONS, APPARATUS_NAMES

METHODS: tuple[str, ...] = ("cascade", "triangulation", "plane", "mvpt", "oracle")
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


def _ok_rows(rows: Iterable[dict]) -> list[dict]:
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
    for r in _ok_rows(rows):
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


def _present(rows: Sequence[dict], field: str, order: Sequence) -> list:
    have = {r[field] if field != "n_cam" else int(r[field]) for r in _ok_rows(rows)}
    return [x for x in order if x in have] + sorted(x for x in have if x not in order)


def table3(rows: Sequence[dict]) -> list[dict]:
    """Table 3 rows: one per (apparatus, n_cam, method) with idsw, aed, fr, coverage."""
    p = pooled(rows)
    out = []
    for app in _present(rows, "apparatus", APPARATUS_NAMES):
        for n in _present(rows, "n_cam", N_CAMS):
            for m in _present(rows, "method", METHODS):
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
    for r in _ok_rows(rows):
        f[r["method"]] = f.get(r["method"], 0.0) + float(r["frames"])
        s[r["method"]] = s.get(r["method"], 0.0) + float(r["seconds"])
    return {m: _div(f[m], s[m]) for m in f}


def table5(rows: Sequence[dict]) -> list[dict]:
    """Table 5 rows: per method, average FR at each n_cam and frames per second."""
    fr = averaged(rows, "fr")
    fps = speed(rows)
    out = []
    for m in _present(rows, "method", METHODS):
        row: dict[str, Any] = {"method": m}
        for n in _present(rows, "n_cam", N_CAMS):
            row[f"fr_{n}"] = fr.get((m, n), float("nan"))
        row["fps"] = fps.get(m, float("nan"))
        out.append(row)
    return out


def table6(rows: Sequence[dict]) -> list[dict]:
    """Table 6 rows (ablation): per mode, apparatus-averaged FR and AED at each n_cam."""
    fr = averaged(rows, "fr")
    aed = averaged(rows, "aed")
    out = []
    for m in [x for x in ABLATION if x in {r["method"] for r in _ok_rows(rows)}]:
        row: dict[str, Any] = {"method": m}
        for n in _present(rows, "n_cam", N_CAMS):
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
    for n in _present(rows, "n_cam", N_CAMS):
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


def claims(rows: Sequence[dict]) -> list[Claim]:
    """The issue's targets, each PASS / FAIL (n/a when a method or n_cam is missing).

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
        out.append(_claim("n_cam=2: FR cascade <= 0.3 x triangulation", _div(c, t) if t else (0.0 if c == 0 else math.inf), 0.3,
                          c <= 0.3 * t, f"cascade {c:.4f}, triangulation {t:.4f}"))
        c, t = aed[("cascade", 2)], aed[("triangulation", 2)]
        out.append(_claim("n_cam=2: AED cascade <= 0.85 x triangulation", _div(c, t), 0.85, c <= 0.85 * t, f"cascade {c:.3f} m, triangulation {t:.3f} m"))
        c, t = sw.get(("cascade", 2), 0), sw.get(("triangulation", 2), 0)
        out.append(_claim("n_cam=2: ID switches cascade <= triangulation", float(c - t), 0.0, c <= t, f"cascade {c}, triangulation {t} (value = difference)"))
    else:
        out.append(_claim("n_cam=2: cascade vs triangulation", nan, nan, None, "needs cascade and triangulation at n_cam = 2"))
    if has("cascade", 4) and has("triangulation", 4):
        c, t = aed[("cascade", 4)], aed[("triangulation", 4)]
        r = _div(c, t)
        out.append(_claim("n_cam=4: AED cascade <= 1.05 x triangulation (no worse)", r, 1.05, r <= 1.05, f"cascade {c:.3f} m, triangulation {t:.3f} m"))
    else:
        out.append(_claim("n_cam=4: AED cascade <= 1.05 x triangulation (no worse)", nan, 1.05, None, "needs cascade and triangulation at n_cam = 4"))
    for n in _present(rows, "n_cam", N_CAMS):
        if has("cascade", n) and has("oracle", n):
            c, o = aed[("cascade", n)], aed[("oracle", n)]
            out.append(_claim(f"n_cam={n}: AED cascade <= 1.25 x oracle", _div(c, o), 1.25, c <= 1.25 * o, f"cascade {c:.3f} m, oracle {o:.3f} m"))
        else:
            out.append(_claim(f"n_cam={n}: AED cascade <= 1.25 x oracle", nan, 1.25, None, "needs cascade and oracle"))
    if "cascade" in fps:
        out.append(_claim("speed: cascade >= 1000 frames/s", fps["cascade"], 1000.0, fps["cascade"] >= 1000.0, f"{fps['cascade']:.0f} frames/s"))
        if "triangulation" in fps:
            r = _div(fps["cascade"], fps["triangulation"])
            out.append(_claim("speed: cascade >= 0.9 x triangulation", r, 0.9, r >= 0.9, f"cascade {fps['cascade']:.0f}, triangulation {fps['triangulation']:.0f} frames/s"))
    return out


# ----------------------------------------------------------------------------- writing
def _fmt(v: Any, kind: str = "") -> str:
    if v is None:
        return "-"
    if isinstance(v, (int, np.integer)) and not isinstance(v, bool):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        if not np.isfinite(v):
            return "-" if np.isnan(v) else ("inf" if v > 0 else "-inf")
        if kind == "pct":
            return f"{100 * v:.2f}%"
        if kind == "fps":
            return f"{v:.0f}"
        if kind == "ratio":
            return f"{v:.2f}"
        return f"{v:.3f}"
    return str(v)


def markdown_table(header: Sequence[str], body: Sequence[Sequence[Any]]) -> str:
    """A GitHub markdown table from a header and already formatted cells."""
    lines = ["| " + " | ".join(header) + " |", "|" + "|".join(" --- " for _ in header) + "|"]
    lines += ["| " + " | ".join(str(c) for c in row) + " |" for row in body]
    return "\n".join(lines)


def table3_markdown(rows: Sequence[dict]) -> str:
    """Table 3 laid out like the paper: one block per metric, rows = methods, columns = apparatus x n_cam."""
    p = pooled(rows)
    apps = _present(rows, "apparatus", APPARATUS_NAMES)
    ns = _present(rows, "n_cam", N_CAMS)
    methods = _present(rows, "method", METHODS)
    header = ["method"] + [f"{ABBREVIATIONS.get(a, a)} {n}" for a in apps for n in ns]
    blocks = []
    for metric, title, kind in (
        ("idsw", "ID switches of the target (sum over routines; lower is better)", ""),
        ("aed", "AED of the target centre in metres (lower is better)", ""),
        ("fr", "FR of the target's expanded boxes (lower is better)", "pct"),
        ("coverage", "coverage: share of performing frames with a target output (higher is better)", "pct"),
    ):
        body = [[m] + [_fmt(p[(a, n, m)][metric], kind) if (a, n, m) in p else "-" for a in apps for n in ns] for m in methods]
        blocks.append(f"**{title}**\n\n" + markdown_table(header, body))
    return "\n\n".join(blocks)


def report_markdown(rows: Sequence[dict], meta: dict | None = None, plots: Sequence[str] = (), wildtrack: str | None = None) -> str:
    """The whole report.md: setup, Tables 3, 5, 6, ratios, claims, plots, failures, WILDTRACK."""
    meta = meta or {}
    ok = _ok_rows(rows)
    failed = [r for r in rows if r.get("error")]
    parts = ["# gymtrack benchmark", ""]
    if meta:
        parts += ["## Setup", ""] + [f"- {k}: {v}" for k, v in meta.items()] + [""]
    parts += [
        f"{len({r['routine'] for r in ok})} routines, {len(ok)} (routine, method) runs"
        + (f", {len(failed)} failed (listed at the end)." if failed else "."),
        "",
        "Metrics are on the target gymnast while performing (the simulator's performance phase, when the "
        "ground truth has it, and the ground-truth centre inside the performance space). ID switches: a transition between consecutive evaluated frames counts once when the output "
        "target's track id changes or the ground-truth person it is nearest to (within 1 m) changes. AED pooled "
        "over frames, FR pooled over (frame, view) pairs with a visible ground-truth box: b_buf missing, not "
        "covering the true box, or more than twice its length. Averages over apparatus are plain means of the "
        "per-apparatus values. The oracle is the ground-truth association fed to the cascade's 3D estimation: "
        "the limit better association could reach, not a method.",
        "",
        "## Table 3: per apparatus and number of cameras",
        "",
        table3_markdown(rows),
        "",
        "## Table 5: average FR and speed",
        "",
        "Frames per second of the tracker alone (detector, file reading and evaluation excluded), measured in this "
        "run: all frames / all seconds of the method's tracker calls, each routine in a worker process (see the "
        "parallel jobs and CPUs above: with as many jobs as CPUs each call has about one core). The methods run "
        "in an order rotated per routine (the first run on a new rig pays one-off costs) and numba's compilation "
        "or cache load happens before any clock starts.",
        "",
    ]
    t5 = table5(rows)
    ns = _present(rows, "n_cam", N_CAMS)
    parts.append(markdown_table(["method"] + [f"FR n_cam={n}" for n in ns] + ["frames/s"],
                                [[r["method"]] + [_fmt(r[f"fr_{n}"], "pct") for n in ns] + [_fmt(r["fps"], "fps")] for r in t5]))
    t6 = table6(rows)
    if t6:
        parts += ["", "## Table 6: ablation (FR | AED, averaged over apparatus)", ""]
        parts.append(markdown_table(["mode"] + [f"n_cam={n}" for n in ns],
                                    [[r["method"]] + [f"{_fmt(r[f'fr_{n}'], 'pct')} \\| {_fmt(r[f'aed_{n}'])}" for n in ns] for r in t6]))
    parts += ["", "## Ratios", ""]
    parts.append(markdown_table(["n_cam", "FR cascade / triangulation", "AED cascade / triangulation", "AED cascade / oracle"],
                                [[r["n_cam"], _fmt(r["fr_cascade_over_triangulation"], "ratio"), _fmt(r["aed_cascade_over_triangulation"], "ratio"),
                                  _fmt(r["aed_cascade_over_oracle"], "ratio")] for r in ratios(rows)]))
    parts += ["", "## Targets of the issue", ""]
    parts.append(markdown_table(["target", "value", "limit", "result", "detail"],
                                [[c.name, _fmt(c.value, "ratio") if abs(c.value) < 100 or not np.isfinite(c.value) else _fmt(c.value, "fps"),
                                  _fmt(c.limit, "ratio") if c.limit < 100 else _fmt(c.limit, "fps"), f"**{c.status}**", c.detail] for c in claims(rows)]))
    mot = [r for r in table3(rows)]
    if mot:
        parts += ["", "## All people: MOT metrics of the 3D tracks", "",
                  "py-motmetrics on 3D centre distances (gate 1 m), people inside the tracking space; mean over routines.", ""]
        parts.append(markdown_table(["apparatus", "n_cam", "method", "MOTA", "IDF1"],
                                    [[ABBREVIATIONS.get(r["apparatus"], r["apparatus"]), r["n_cam"], r["method"], _fmt(r["mota"]), _fmt(r["idf1"])] for r in mot]))
    if plots:
        parts += ["", "## Target centre against time (like the paper's Fig. 6)", ""]
        parts += [f"![{Path(p).stem}]({p})" for p in plots]
    if wildtrack:
        parts += ["", wildtrack]
    if failed:
        parts += ["", "## Failed runs", ""]
        parts += [f"- {r['routine']} / {r['method']}: {r['error']}" for r in failed]
    return "\n".join(parts) + "\n"


def write_csv(path: Path, records: Sequence[dict]) -> Path:
    """Write dict records as CSV (columns = union of keys, first record's order first)."""
    import csv

    cols: list[str] = []
    for r in records:
        cols += [k for k in r if k not in cols]
    with open(path, "w", newline="") as fh:
        w = csv.DictWriter(fh, fieldnames=cols)
        w.writeheader()
        for r in records:
            w.writerow({k: r.get(k, "") for k in cols})
    return path


def _jsonable(v: Any) -> Any:
    if isinstance(v, dict):
        return {str(k): _jsonable(x) for k, x in v.items()}
    if isinstance(v, (list, tuple)):
        return [_jsonable(x) for x in v]
    if isinstance(v, (np.integer,)):
        return int(v)
    if isinstance(v, (float, np.floating)):
        return float(v) if np.isfinite(v) else None
    return v


def write_report(out: str | Path, rows: Sequence[dict], meta: dict | None = None, plots: Sequence[str] = (),
                 wildtrack_md: str | None = None, wildtrack: dict | None = None) -> dict[str, Path]:
    """Write report.md, rows.csv, table3/5/6.csv, claims.csv and results.json under ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = {
        "report": out / "report.md",
        "rows": write_csv(out / "rows.csv", rows),
        "table3": write_csv(out / "table3.csv", table3(rows)),
        "table5": write_csv(out / "table5.csv", table5(rows)),
        "table6": write_csv(out / "table6.csv", table6(rows)),
        "claims": write_csv(out / "claims.csv", [c.as_dict() for c in claims(rows)]),
    }
    files["report"].write_text(report_markdown(rows, meta, plots, wildtrack_md))
    files["json"] = out / "results.json"
    files["json"].write_text(json.dumps(_jsonable({
        "meta": meta or {}, "rows": list(rows), "table3": table3(rows), "table5": table5(rows), "table6": table6(rows),
        "ratios": ratios(rows), "claims": [c.as_dict() for c in claims(rows)], "wildtrack": wildtrack,
    }), indent=1))
    return files


# ----------------------------------------------------------------------------- plots
def plot_target_trajectories(path: str | Path, title: str, series: dict[str, tuple[np.ndarray, np.ndarray]], fps: float = 30.0) -> Path:
    """Fig. 6-like plot: target centre x, y, z against time, one line per series.

    series: name -> (frame (T,), xyz (T, 3)); the name ``"GT"`` is drawn black and underneath.
    matplotlib is imported here (lazily) with the Agg backend.
    """
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(9, 6.5), sharex=True)
    styles = {"GT": dict(color="black", lw=2.2, alpha=0.6), "cascade": dict(color="tab:orange", lw=1.2),
              "triangulation": dict(color="tab:blue", lw=1.0, ls="--")}
    for name, (frame, xyz) in series.items():
        frame = np.asarray(frame)
        xyz = np.asarray(xyz, dtype=np.float64).reshape(-1, 3)
        order = np.argsort(frame)
        t = frame[order] / fps
        for k, ax in enumerate(axes):
            # break the line at gaps so missing frames are not drawn as straight segments
            y = xyz[order, k].copy()
            gap = np.r_[False, np.diff(frame[order]) > 1]
            tt, yy = np.insert(t, np.flatnonzero(gap), np.nan), np.insert(y, np.flatnonzero(gap), np.nan)
            ax.plot(tt, yy, label=name, **styles.get(name, dict(lw=1.0)))
    for ax, lab in zip(axes, ("x (m)", "y (m)", "z (m)")):
        ax.set_ylabel(lab)
        ax.grid(alpha=0.3)
    axes[-1].set_xlabel("time (s)")
    axes[0].legend(loc="upper right", fontsize=8, ncol=len(series))
    fig.suptitle(title)
    fig.tight_layout()
    path = Path(path)
    fig.savefig(path, dpi=90)
    plt.close(fig)
    return path
