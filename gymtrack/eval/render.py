"""Rendering a benchmark run: report.md, CSV tables, results.json and the Fig. 6 plots.

Paper: Tables 3, 5, 6 and Fig. 6, laid out from the numbers of :mod:`gymtrack.eval.aggregate`
(rows: one dict per (routine, method); trajectories: (T,) frames and (T, 3) centres).
:func:`fmt` is the one number formatting the report, the CLI and the WILDTRACK section share.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any, Sequence

import numpy as np

from ..apparatus import ABBREVIATIONS, APPARATUS_NAMES
from .aggregate import METHODS, N_CAMS, Claim, claims, ok_rows, pooled, present, ratios, table3, table5, table6
from .config import DEFAULT_CONFIG, BenchmarkConfig
from .plus_claims import plus_claims

__all__ = ["fmt", "markdown_table", "table3_markdown", "report_markdown", "write_csv", "write_report", "plot_target_trajectories"]


def fmt(v: Any, kind: str = "") -> str:
    """A table cell: ``-`` for None / NaN, integers as is, floats by ``kind`` (``pct``, ``fps``, ``ratio``, else 3 decimals)."""
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
    apps = present(rows, "apparatus", APPARATUS_NAMES)
    ns = present(rows, "n_cam", N_CAMS)
    methods = present(rows, "method", METHODS)
    header = ["method"] + [f"{ABBREVIATIONS.get(a, a)} {n}" for a in apps for n in ns]
    blocks = []
    for metric, title, kind in (
        ("idsw", "ID switches of the target (sum over routines; lower is better)", ""),
        ("aed", "AED of the target centre in metres (lower is better)", ""),
        ("fr", "FR of the target's expanded boxes (lower is better)", "pct"),
        ("coverage", "coverage: share of performing frames with a target output (higher is better)", "pct"),
    ):
        body = [[m] + [fmt(p[(a, n, m)][metric], kind) if (a, n, m) in p else "-" for a in apps for n in ns] for m in methods]
        blocks.append(f"**{title}**\n\n" + markdown_table(header, body))
    return "\n\n".join(blocks)


def report_markdown(rows: Sequence[dict], meta: dict | None = None, plots: Sequence[str] = (), wildtrack: str | None = None,
                    config: BenchmarkConfig = DEFAULT_CONFIG, plus: Sequence[Claim] = ()) -> str:
    """The whole report.md: setup, Tables 3, 5, 6, ratios, claims (``plus``: cascade+'s,
    :mod:`.plus_claims`), plots, failures, WILDTRACK."""
    meta = meta or {}
    ok = ok_rows(rows)
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
    ns = present(rows, "n_cam", N_CAMS)
    parts.append(markdown_table(["method"] + [f"FR n_cam={n}" for n in ns] + ["frames/s"],
                                [[r["method"]] + [fmt(r[f"fr_{n}"], "pct") for n in ns] + [fmt(r["fps"], "fps")] for r in t5]))
    t6 = table6(rows)
    if t6:
        parts += ["", "## Table 6: ablation (FR | AED, averaged over apparatus)", ""]
        parts.append(markdown_table(["mode"] + [f"n_cam={n}" for n in ns],
                                    [[r["method"]] + [f"{fmt(r[f'fr_{n}'], 'pct')} \\| {fmt(r[f'aed_{n}'])}" for n in ns] for r in t6]))
    parts += ["", "## Ratios", ""]
    parts.append(markdown_table(["n_cam", "FR cascade / triangulation", "AED cascade / triangulation", "AED cascade / oracle"],
                                [[r["n_cam"], fmt(r["fr_cascade_over_triangulation"], "ratio"), fmt(r["aed_cascade_over_triangulation"], "ratio"),
                                  fmt(r["aed_cascade_over_oracle"], "ratio")] for r in ratios(rows)]))
    parts += ["", "## Targets", ""]
    parts.append(_claims_md(claims(rows, config)))
    if plus:
        parts += ["", "## Targets beyond the paper (cascade+)", ""]
        parts.append(_claims_md(plus))
    mot = [r for r in table3(rows)]
    if mot:
        parts += ["", "## All people: MOT metrics of the 3D tracks", "",
                  "py-motmetrics on 3D centre distances (gate 1 m), people inside the tracking space; mean over routines.", ""]
        parts.append(markdown_table(["apparatus", "n_cam", "method", "MOTA", "IDF1"],
                                    [[ABBREVIATIONS.get(r["apparatus"], r["apparatus"]), r["n_cam"], r["method"], fmt(r["mota"]), fmt(r["idf1"])] for r in mot]))
    if plots:
        parts += ["", "## Target centre against time (like the paper's Fig. 6)", ""]
        parts += [f"![{Path(p).stem}]({p})" for p in plots]
    if wildtrack:
        parts += ["", wildtrack]
    if failed:
        parts += ["", "## Failed runs", ""]
        parts += [f"- {r['routine']} / {r['method']}: {r['error']}" for r in failed]
    return "\n".join(parts) + "\n"


def _claims_md(found: Sequence[Claim]) -> str:
    return markdown_table(["target", "value", "limit", "result", "detail"],
                          [[c.name, fmt(c.value, "ratio") if abs(c.value) < 100 or not np.isfinite(c.value) else fmt(c.value, "fps"),
                            fmt(c.limit, "ratio") if c.limit < 100 else fmt(c.limit, "fps"), f"**{c.status}**", c.detail] for c in found])


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
                 wildtrack_md: str | None = None, wildtrack: dict | None = None,
                 config: BenchmarkConfig = DEFAULT_CONFIG, results: dict[str, list[dict]] | None = None) -> dict[str, Path]:
    """Write report.md, rows.csv, table3/5/6.csv, claims.csv and results.json under ``out``;
    ``results``: more record lists (e.g. the pooled figures), each as ``<name>.csv`` and under its name in results.json."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    files = {
        "report": out / "report.md",
        "rows": write_csv(out / "rows.csv", rows),
        "table3": write_csv(out / "table3.csv", table3(rows)),
        "table5": write_csv(out / "table5.csv", table5(rows)),
        "table6": write_csv(out / "table6.csv", table6(rows)),
        "claims": write_csv(out / "claims.csv", [c.as_dict() for c in claims(rows, config)]),
    }
    plus = plus_claims(rows, wildtrack, config) if any(r.get("method") == "cascade+" for r in rows) else []
    if plus:
        files["plus_claims"] = write_csv(out / "plus_claims.csv", [c.as_dict() for c in plus])
    for name, recs in (results or {}).items():
        if recs:
            files[name] = write_csv(out / f"{name}.csv", recs)
    files["report"].write_text(report_markdown(rows, meta, plots, wildtrack_md, config, plus))
    files["json"] = out / "results.json"
    files["json"].write_text(json.dumps(_jsonable({
        "meta": meta or {}, "rows": list(rows), "table3": table3(rows), "table5": table5(rows), "table6": table6(rows),
        "ratios": ratios(rows), "claims": [c.as_dict() for c in claims(rows, config)], "wildtrack": wildtrack,
        "plus_claims": [c.as_dict() for c in plus], **(results or {}),
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
