"""cascade+'s ablation (gymtrack.eval.ablation, ``gymtrack benchmark --ablation``): the recipes it
runs, its pooling against hand-worked answers on made-up rows, and the command on a tiny suite."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.eval.ablation import SCENE_GATED, ablation_markdown, ablation_recipes, ablation_table
from gymtrack.modes import INGREDIENTS, OPTIONAL, RECIPES


def test_recipes_switch_each_ingredient_off_in_cascade_plus_and_on_in_cascade():
    recipes = ablation_recipes()
    names = [m.name for m in recipes]
    used = [i for i in INGREDIENTS if i not in SCENE_GATED]
    sign = {i: "+" if i in OPTIONAL else "-" for i in used}  # (an optional one is added to cascade+)
    assert names == (["cascade+"] + [f"cascade+ {sign[i]}{i}" for i in used if i not in OPTIONAL]
                     + [f"cascade+ +{i}" for i in used if i in OPTIONAL] + ["cascade"] + [f"cascade +{i}" for i in used])
    order = [i for i in used if i not in OPTIONAL] + [i for i in used if i in OPTIONAL]
    for i, m in zip(order, recipes[1:1 + len(used)]):  # exactly one field differs from cascade+
        diff = [f for f in INGREDIENTS if getattr(m, f) != getattr(RECIPES["cascade+"], f)]
        assert diff == [i]
    assert len(set(recipes)) == len(recipes)


def _row(app_, n, method, fr, aed, mota, idf1, frames=100, seconds=0.1):
    return {"routine": f"{app_}/{n}", "apparatus": app_, "n_cam": n, "method": method, "frames": frames,
            "seconds": seconds, "fr_failures": fr[0], "fr_evaluated": fr[1], "aed_sum": aed[0], "aed_n": aed[1],
            "mota": mota, "idf1": idf1, "error": ""}


def test_table_pools_per_apparatus_then_averages_like_table_6():
    plus = RECIPES["cascade+"]
    rows = [  # two routines of the beam (pooled), one of the vault; n_cam = 2
        _row("balance_beam", 2, "cascade+", (1, 10), (2.0, 10), 0.8, 0.7),
        _row("balance_beam", 2, "cascade+", (3, 30), (6.0, 10), 0.6, 0.5),
        _row("vault", 2, "cascade+", (5, 10), (1.0, 5), 0.5, 0.9, seconds=0.2),
    ]
    wt = {"modes": {"cascade+": {"mota": 0.7, "idf1": 0.75}}}
    (r,) = ablation_table(rows, [plus], wt)
    # beam: FR 4 / 40 = 0.1, AED 8 / 20 = 0.4, MOTA (0.8 + 0.6) / 2; vault: 0.5, 0.2, 0.5 -> means over apparatus
    assert r["fr_2"] == pytest.approx((0.1 + 0.5) / 2) and r["aed_2"] == pytest.approx((0.4 + 0.2) / 2)
    assert r["mota_2"] == pytest.approx((0.7 + 0.5) / 2) and r["idf1_2"] == pytest.approx((0.6 + 0.9) / 2)
    assert r["fps"] == pytest.approx(300 / 0.4) and (r["wt_mota"], r["wt_idf1"]) == (0.7, 0.75)
    md = ablation_markdown([r])
    assert "| cascade+ | 30.00% / 0.300 | 0.600 / 0.750 | 0.700 / 0.750 |" in md


def test_benchmark_ablation_command_on_a_tiny_suite(tmp_path):
    from gymtrack.simulate import simulate_routine

    suite = tmp_path / "suite"  # one routine (a folder with a scene.yaml)
    simulate_routine("vault", n_cam=2, seed=0, seconds=10, out=suite / "vault2")
    out = tmp_path / "out"
    r = CliRunner().invoke(app, ["benchmark", "--suite", str(suite), "--out", str(out), "-j", "1", "--ablation",
                                 "--no-wildtrack"])
    assert r.exit_code == 0, r.output
    table = json.loads((out / "ablation.json").read_text())["table"]
    assert [t["recipe"] for t in table] == [m.name for m in ablation_recipes()]
    for t in table:  # every recipe ran and was evaluated (one n_cam: the routine's)
        cols = [k for k in t if k.startswith(("mota_", "fr_"))]
        assert len(cols) == 2 and all(np.isfinite(t[k]) for k in cols), t
    assert "cascade+ -floor" in (out / "ablation.md").read_text()
