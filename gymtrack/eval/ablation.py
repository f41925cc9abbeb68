"""cascade+'s ablation (``gymtrack benchmark --ablation``): what each ingredient beyond the paper earns.

Paper: Table 4 (the paper's ablation of its cascade) extended to the tracker's recipes
(:class:`gymtrack.modes.Method`). Two families of recipes, each run on every routine of the suite
through :func:`.benchmark.run_suite` (the same runners, rows and pooling as the benchmark) and on
WILDTRACK (:func:`.wildtrack.run_wildtrack`):

* from ``cascade+``, each ingredient switched off alone (``cascade+ -floor``, ...): what the
  ingredient earns inside cascade+;
* from the paper's ``cascade``, each ingredient added alone (``cascade +floor``, ...): what it
  earns by itself.

Per recipe and n_cam: the target's FR and AED (Table 4's columns; mean over apparatus of the
pooled values, as Table 6) and all people's MOTA and IDF1 (mean over apparatus); WILDTRACK's MOTA
and IDF1; frames per second over the whole suite. Ingredients the scene must ask for (fusion,
online plane refinement: ``params.fuse_plane``, ``params.refine_plane``) change nothing on scenes
that do not ask; the report says so rather than running them.
"""

from __future__ import annotations

from typing import Callable, Sequence

from ..modes import INGREDIENTS, OPTIONAL, RECIPES, Method
from .aggregate import N_CAMS, averaged, present, speed

__all__ = ["SCENE_GATED", "ablation_recipes", "ablation_table", "ablation_markdown"]

#: ingredients that act only where the scene asks for them (off in the preset scenes and WILDTRACK's)
SCENE_GATED = ("fusion", "refine_plane")


def ablation_recipes(ingredients: Sequence[str] = INGREDIENTS) -> list[Method]:
    """cascade+, cascade+ without each ingredient (with each of :data:`~gymtrack.modes.OPTIONAL`), the
    cascade, the cascade with each ingredient (scene-gated ingredients left out: on the preset
    scenes they change nothing)."""
    plus, cascade = RECIPES["cascade+"], RECIPES["cascade"]
    used = [i for i in ingredients if i not in SCENE_GATED]
    optional = [i for i in used if i in OPTIONAL]  # (not in cascade+: added to it, not taken away)
    inside = [i for i in used if i not in OPTIONAL]
    return [plus, *(plus.without(i) for i in inside), *(plus.adding(i) for i in optional), cascade,
            *(cascade.adding(i) for i in used)]


def ablation_table(rows: Sequence[dict], recipes: Sequence[Method], wildtrack: dict | None = None) -> list[dict]:
    """One row per recipe: ``fr_<n>``, ``aed_<n>``, ``mota_<n>``, ``idf1_<n>`` per n_cam, ``fps``,
    and ``wt_mota``, ``wt_idf1`` when WILDTRACK ran (its ``modes`` keyed by recipe name)."""
    metric = {k: averaged(rows, k) for k in ("fr", "aed", "mota", "idf1")}
    fps = speed(rows)
    wt = (wildtrack or {}).get("modes", {})
    out = []
    for m in recipes:
        row: dict = {"recipe": m.name}
        for n in present(rows, "n_cam", N_CAMS):
            for k, v in metric.items():
                row[f"{k}_{n}"] = v.get((m.name, n), float("nan"))
        row["fps"] = fps.get(m.name, float("nan"))
        if m.name in wt:
            row["wt_mota"], row["wt_idf1"] = wt[m.name]["mota"], wt[m.name]["idf1"]
        out.append(row)
    return out


def ablation_markdown(table: Sequence[dict], note: Callable[[], str] | None = None) -> str:
    """The report: Table 4's layout, one row per recipe (FR / AED of the target, MOTA / IDF1 of
    everyone, per n_cam; WILDTRACK; speed)."""
    from .render import fmt, markdown_table

    if not table:
        return "## cascade+'s ablation\n\nNo rows.\n"
    ns = sorted({int(k.split("_")[1]) for k in table[0] if k.startswith("fr_")})
    head = ["recipe"] + [f"FR / AED n={n}" for n in ns] + [f"MOTA / IDF1 n={n}" for n in ns]
    has_wt = any("wt_mota" in r for r in table)
    head += (["WILDTRACK MOTA / IDF1"] if has_wt else []) + ["frames/s"]
    body = []
    for r in table:
        cells = [r["recipe"]]
        cells += [f"{fmt(r[f'fr_{n}'], 'pct')} / {fmt(r[f'aed_{n}'])}" for n in ns]
        cells += [f"{fmt(r[f'mota_{n}'])} / {fmt(r[f'idf1_{n}'])}" for n in ns]
        if has_wt:
            cells.append(f"{fmt(r['wt_mota'])} / {fmt(r['wt_idf1'])}" if "wt_mota" in r else "-")
        cells.append(fmt(r["fps"], "fps"))
        body.append(cells)
    lines = [
        "## cascade+'s ablation", "",
        "Each ingredient beyond the paper switched off alone in cascade+ (`-name`) and added alone to the paper's "
        "cascade (`+name`); what each does: `gymtrack.modes.Method`. FR (failure rate) and AED (m) of the target, "
        "MOTA and IDF1 of all people in S_track, each averaged over apparatus; WILDTRACK: the real-data section's "
        "set-up (2 fps, 7 views). Ray/plane fusion and online plane refinement act only where the scene asks for "
        "them (`params.fuse_plane`, `params.refine_plane`), which the preset scenes do not: not run.", "",
        markdown_table(head, body), "",
    ]
    if note:
        lines += [note(), ""]
    return "\n".join(lines)
