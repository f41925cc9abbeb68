"""Headline ratios pooled over several suites, with a bootstrap interval over routines.

Paper: Section IV (Tables 3 and 5); the rule that a headline ratio is reported with its spread.
The n_cam = 2 ratios (FR of a method over triangulation's, AED over the oracle's) swing from
one simulated suite to the next, so the benchmark pools the rows of suites of different seeds
(``gymtrack benchmark --seeds 0,1,2``) and gives each ratio a percentile bootstrap interval:

* the statistic is the report's own: per apparatus, FR pooled over (frame, view) pairs and AED
  over frames (sums over routines); then the plain mean over apparatus (:func:`.aggregate.averaged`);
  a ratio divides two such means; MOTA / IDF1 are routine means per apparatus, then averaged;
* one bootstrap draw resamples the routines with replacement *within each apparatus* (the mean
  over apparatus is kept as the report defines it) and keeps every method's row of a routine
  together (the ratios are paired);
* ``n_boot`` draws from ``numpy.random.default_rng(seed)``; the interval is the
  ``(1 - level) / 2`` and ``(1 + level) / 2`` percentiles of the draws.

Arrays: for one n_cam and apparatus, ``(R, M)`` sums per routine and method; draws ``(B, R)``.

The judging targets (:func:`.judging.judging_claims`, Section III-D's measurements for the judges)
get the same treatment (:func:`pooled_judging`): the claims' own statistic on all rows, then on
each draw that resamples the routines within each (n_cam, apparatus) with every method's row of
a routine together. A draw re-pools every element and angle histogram of the drawn rows (about
0.1 s for three 28-routine suites), hence fewer draws by default (1000).

A suite is a row's ``suite`` field when it has one (``gymtrack benchmark-pool``:
:mod:`.pool_outputs`), else its routine name's ``s<seed>/`` prefix.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from ..apparatus import APPARATUS_NAMES
from .aggregate import N_CAMS, ok_rows, present

__all__ = ["Ratio", "HEADLINES", "bootstrap_ratio", "pooled_ratios", "pooled_markdown", "PooledClaim", "pooled_judging",
           "pooled_judging_markdown", "suite_of"]

#: (name, kind, numerator method, denominator method or None); kind: fr | aed | mota | idf1
HEADLINES: tuple[tuple[str, str, str, str | None], ...] = (
    ("FR cascade+ / triangulation", "fr", "cascade+", "triangulation"),
    ("FR cascade / triangulation", "fr", "cascade", "triangulation"),
    ("FR cascade+ / oracle", "fr", "cascade+", "oracle"),
    ("FR cascade+ / cascade", "fr", "cascade+", "cascade"),
    ("AED cascade+ / oracle", "aed", "cascade+", "oracle"),
    ("AED cascade / triangulation", "aed", "cascade", "triangulation"),
    ("FR cascade+", "fr", "cascade+", None),
    ("FR oracle", "fr", "oracle", None),
    ("MOTA cascade+", "mota", "cascade+", None),
    ("IDF1 cascade+", "idf1", "cascade+", None),
)
_PARTS = {"fr": ("fr_failures", "fr_evaluated"), "aed": ("aed_sum", "aed_n")}


@dataclass(frozen=True)
class Ratio:
    """A pooled headline figure and its bootstrap interval."""

    name: str
    n_cam: int
    value: float
    low: float
    high: float
    routines: int  #: routines (with a row of every method needed) at this n_cam
    suites: int  #: distinct suite seeds among them

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def _num(v) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return float("nan")
    return f


def _stat(kind: str, num: np.ndarray, den: np.ndarray) -> np.ndarray:
    """Per apparatus: pooled sums (``kind`` fr/aed: ``num / den``) or routine means (mota/idf1:
    ``num`` summed values, ``den`` counts) -> the same shape; NaN where the count is zero."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(den > 0, num / np.where(den > 0, den, 1.0), np.nan)


def bootstrap_ratio(groups: Sequence[np.ndarray], kind: str, n_boot: int = 2000, level: float = 0.9,
                    seed: int = 0) -> tuple[float, float, float]:
    """Point value and percentile interval of an apparatus-averaged figure or ratio.

    groups: one array per apparatus, ``(R_a, 2, 2)``: per routine, for the numerator method
    (index 0) and the denominator method (index 1), the two additive parts (``fr_failures``,
    ``fr_evaluated`` for fr; ``aed_sum``, ``aed_n`` for aed; the value and 1 for mota / idf1,
    0 and 0 where the value is missing). With no denominator method, pass index 1 as NaN parts:
    the figure itself is returned. Resampling is within each apparatus (see the module).
    """
    groups = [np.asarray(g, dtype=np.float64) for g in groups if len(g)]
    if not groups:
        return float("nan"), float("nan"), float("nan")
    ratio = not np.isnan(groups[0][0, 1, 1])
    rng = np.random.default_rng(seed)

    def figure(sums: list[np.ndarray]) -> np.ndarray:  # sums: per apparatus (..., 2, 2) -> (...)
        per = np.stack([_stat(kind, s[..., 0], s[..., 1]) for s in sums])  # (A, ..., 2)
        with np.errstate(invalid="ignore"):
            mean = np.nanmean(per, axis=0) if np.isfinite(per).any() else np.full(per.shape[1:], np.nan)
        with np.errstate(invalid="ignore", divide="ignore"):
            return mean[..., 0] / mean[..., 1] if ratio else mean[..., 0]

    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an all-NaN draw of an apparatus: NaN, dropped below
        point = float(figure([g.sum(axis=0) for g in groups]))
        draws = figure([g[rng.integers(0, len(g), size=(n_boot, len(g)))].sum(axis=1) for g in groups])
    draws = draws[np.isfinite(draws)]
    if not draws.size:
        return point, float("nan"), float("nan")
    lo, hi = np.percentile(draws, [50 * (1 - level), 50 * (1 + level)])
    return point, float(lo), float(hi)


def suite_of(row: dict) -> str:
    """The suite a row belongs to: its ``suite`` field, else its routine name's ``s<seed>/`` prefix ("" without)."""
    if row.get("suite"):
        return str(row["suite"])
    m = re.match(r"s(\d+)/", str(row["routine"]))
    return m.group(1) if m else ""


def _parts(row: dict, kind: str) -> tuple[float, float]:
    if kind in _PARTS:
        a, b = _PARTS[kind]
        return _num(row.get(a)), _num(row.get(b))
    v = _num(row.get(kind))
    return (v, 1.0) if np.isfinite(v) else (0.0, 0.0)


def pooled_ratios(rows: Sequence[dict], n_boot: int = 2000, level: float = 0.9, seed: int = 0,
                  headlines=HEADLINES, apparatus: str | None = None) -> list[Ratio]:
    """Every headline of ``headlines`` at every n_cam the rows have (methods missing: left out).

    Routines are the rows' ``routine`` names (unique across the pooled suites); a routine enters a
    ratio only when both methods ran on it without error. ``apparatus``: that apparatus alone.
    """
    rows = [r for r in ok_rows(rows) if apparatus is None or r["apparatus"] == apparatus]
    by: dict[tuple[int, str, str], dict[str, dict]] = {}
    for r in rows:
        by.setdefault((int(r["n_cam"]), r["apparatus"], r["routine"]), {})[r["method"]] = r
    out = []
    for n in present(rows, "n_cam", N_CAMS):
        for name, kind, a, b in headlines:
            groups, seeds, count = [], set(), 0
            for app in present(rows, "apparatus", APPARATUS_NAMES):
                g = []
                for (nn, aa, routine), ms in by.items():
                    if nn != n or aa != app or a not in ms or (b is not None and b not in ms):
                        continue
                    den = _parts(ms[b], kind) if b is not None else (np.nan, np.nan)
                    g.append([_parts(ms[a], kind), den])
                    seeds.add(suite_of(ms[a]))
                if g:
                    groups.append(np.array(g))
                    count += len(g)
            if not groups:
                continue
            v, lo, hi = bootstrap_ratio(groups, kind, n_boot, level, seed)
            out.append(Ratio(name, n, v, lo, hi, count, len(seeds)))
    return out


def pooled_markdown(rows: Sequence[dict], level: float = 0.9, n_boot: int = 2000, seed: int = 0) -> str:
    """The headline ratios of every n_cam with their bootstrap intervals, and per apparatus at
    n_cam = 2 the target FR of cascade+ and of the cascade, as a markdown section."""
    from .render import markdown_table

    found = pooled_ratios(rows, n_boot, level, seed)
    if not found:
        return ""
    pct = int(round(100 * level))
    body = [[r.name, r.n_cam, _fmt(r), r.routines, r.suites] for r in found]
    text = (f"## Headline figures pooled over suites ({pct} % bootstrap intervals over routines)\n\n"
            f"Each figure as the report averages it (per apparatus pooled, then the mean over apparatus); the "
            f"interval resamples routines within each apparatus ({n_boot} draws, seed {seed}), every method's "
            f"row of a routine together. Routines: routines with both methods; suites: suites of distinct seeds "
            f"(the routine names' ``s<seed>/`` prefixes of ``--seeds``; ``benchmark-pool``: each output, or each seed of one).\n\n" + markdown_table(["figure", "n_cam", f"value [{pct} % interval]", "routines", "suites"], body))
    per = []
    heads = (("FR cascade+", "fr", "cascade+", None), ("FR cascade", "fr", "cascade", None), ("FR oracle", "fr", "oracle", None))
    for app in present(rows, "apparatus", APPARATUS_NAMES):
        got = {r.name: r for r in pooled_ratios(rows, n_boot, level, seed, heads, apparatus=app) if r.n_cam == 2}
        if got:
            per.append([app, *[_fmt(got[h[0]], pct=True) if h[0] in got else "-" for h in heads]])
    if per:
        text += ("\n\nTarget FR at n_cam = 2 per apparatus, pooled (intervals over that apparatus' routines):\n\n"
                 + markdown_table(["apparatus", "cascade+", "cascade", "oracle"], per))
    return text + "\n"


def _fmt(r: Ratio, pct: bool | None = None) -> str:
    pct = r.name.startswith("FR ") and "/" not in r.name if pct is None else pct
    if pct:
        return f"{100 * r.value:.2f} % [{100 * r.low:.2f}, {100 * r.high:.2f}]"
    return f"{r.value:.3f} [{r.low:.3f}, {r.high:.3f}]"


# ----------------------------------------------------------------------------- judging targets
@dataclass(frozen=True)
class PooledClaim:
    """A judging target pooled over suites: the claim on all rows and its bootstrap interval."""

    name: str
    value: float
    low: float
    high: float
    limit: float
    status: str  #: the pooled value's PASS / FAIL / n/a
    passing: float  #: share of the draws (with a value) whose claim passes
    detail: str
    routines: int  #: routines with a judged row (all n_cam)
    suites: int

    def as_dict(self) -> dict:
        return dict(self.__dict__)


def _judged_strata(rows: Sequence[dict]) -> list[list[list[dict]]]:
    """Per (n_cam, apparatus), per routine, its rows with ``judge_parts`` (parsed, dense bins)."""
    from .judging import _load, dense_parts

    strata: dict[tuple[int, str], dict[str, list[dict]]] = {}
    for r in rows:
        p = _load(r.get("judge_parts"))
        if p is None:
            continue
        keep = {k: r[k] for k in ("routine", "apparatus", "method")} | {"n_cam": int(r["n_cam"]), "judge_parts": dense_parts(p),
                                                                       "suite": suite_of(r)}
        strata.setdefault((keep["n_cam"], r["apparatus"]), {}).setdefault(r["routine"], []).append(keep)
    return [list(strata[k].values()) for k in sorted(strata)]


def pooled_judging(rows: Sequence[dict], n_boot: int = 1000, level: float = 0.9, seed: int = 0, config=None) -> list[PooledClaim]:
    """Every judging target of :func:`.judging.judging_claims` on the pooled rows, with its percentile
    interval over ``n_boot`` draws (routines resampled within each n_cam and apparatus, a routine's
    method rows together); empty when no row has ``judge_parts``."""
    from .config import DEFAULT_CONFIG
    from .judging import judging_claims

    config = DEFAULT_CONFIG if config is None else config
    strata = _judged_strata(rows)
    if not strata:
        return []
    flat = [r for s in strata for routine in s for r in routine]
    point = judging_claims(flat, config)
    names = [c.name for c in point]
    values = np.full((n_boot, len(point)), np.nan)
    passing = np.zeros((n_boot, len(point)), bool)
    rng = np.random.default_rng(seed)
    for b in range(n_boot):
        drawn = [r for s in strata for i in rng.integers(0, len(s), len(s)) for r in s[i]]
        got = {c.name: c for c in judging_claims(drawn, config)}
        for j, name in enumerate(names):
            c = got.get(name)  # the last target's name changes when a draw lacks cascade or triangulation at n_cam 2
            if c is not None:
                values[b, j], passing[b, j] = c.value, c.status == "PASS"
    routines = sum(len(s) for s in strata)
    suites = len({r["suite"] for r in flat})
    out = []
    for j, c in enumerate(point):
        ok = np.isfinite(values[:, j])
        lo, hi = np.percentile(values[ok, j], [50 * (1 - level), 50 * (1 + level)]) if ok.any() else (np.nan, np.nan)
        out.append(PooledClaim(c.name, c.value, float(lo), float(hi), c.limit, c.status,
                               float(passing[ok, j].mean()) if ok.any() else float("nan"), c.detail, routines, suites))
    return out


def pooled_judging_markdown(found: Sequence[PooledClaim], level: float = 0.9, n_boot: int = 1000, seed: int = 0) -> str:
    """The judging targets of :func:`pooled_judging` as a markdown section ("" without any)."""
    from .render import markdown_table

    if not found:
        return ""
    pct = int(round(100 * level))
    def g(v: float) -> str:
        return "-" if not np.isfinite(v) else f"{v:.3g}"

    body = [[c.name, f"{g(c.value)} [{g(c.low)}, {g(c.high)}]", g(c.limit), f"**{c.status}**",
             "-" if not np.isfinite(c.passing) else f"{100 * c.passing:.0f} %", c.detail] for c in found]
    return (f"## Judging targets pooled over suites ({pct} % bootstrap intervals over routines)\n\n"
            f"The judging targets (cascade+, pooled over apparatus as in the judging section) on the rows of every suite "
            f"together ({found[0].routines} judged routines of {found[0].suites} suite(s)); the interval resamples the routines "
            f"within each n_cam and apparatus ({n_boot} draws, seed {seed}), every method's row of a routine together. "
            f"Draws passing: the share of draws whose target is met.\n\n"
            + markdown_table(["target", f"value [{pct} % interval]", "limit", "result", "draws passing", "detail"], body) + "\n")
