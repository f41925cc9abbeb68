"""Headline figures pooled over suites with a bootstrap interval (gymtrack.eval.pooled), against
hand-worked small cases, and ``gymtrack benchmark --seeds``' option checks."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.errors import InputError
from gymtrack.eval.pooled import bootstrap_ratio, pooled_markdown, pooled_ratios


def _row(routine, app_, method, fail, ev, n_cam=2, **kw):
    return {"routine": routine, "apparatus": app_, "n_cam": n_cam, "method": method, "fr_failures": fail,
            "fr_evaluated": ev, "aed_sum": kw.pop("aed_sum", 0.0), "aed_n": kw.pop("aed_n", 0), "error": kw.pop("error", ""), **kw}


def test_two_routines_of_one_apparatus_give_the_three_resampled_ratios_as_point_and_ends():
    # cascade+ 1/10 and 3/10, triangulation 5/10 and 5/10: pooled 4/20 over 10/20 = 0.4; the draws
    # (a, a) 0.1/0.5 = 0.2 (p = 1/4), (a, b) 0.4 (p = 1/2), (b, b) 0.6 (p = 1/4): 5th and 95th percentiles 0.2 and 0.6
    g = np.array([[[1, 10], [5, 10]], [[3, 10], [5, 10]]], dtype=float)
    v, lo, hi = bootstrap_ratio([g], "fr", n_boot=4000, seed=3)
    assert v == pytest.approx(0.4)
    assert lo == pytest.approx(0.2) and hi == pytest.approx(0.6)
    # a narrower level moves the ends inwards (the 25th and 75th percentiles fall on the (a, b) draws)
    v, lo, hi = bootstrap_ratio([g], "fr", n_boot=4000, level=0.3, seed=3)
    assert lo == pytest.approx(0.4) and hi == pytest.approx(0.4)


def test_apparatus_are_averaged_not_pooled_and_one_routine_each_has_no_spread():
    # apparatus 1: cascade+ 1/10, triangulation 4/10; apparatus 2: 3/20 and 2/20.
    # mean over apparatus: (0.1 + 0.15) / 2 = 0.125 over (0.4 + 0.1) / 2 = 0.25 -> 0.5
    # (pooling all pairs would give 4/30 over 6/30 = 0.667)
    rows = [_row("s0/a/r0", "vault", "cascade+", 1, 10), _row("s0/a/r0", "vault", "triangulation", 4, 10),
            _row("s1/b/r0", "balance_beam", "cascade+", 3, 20), _row("s1/b/r0", "balance_beam", "triangulation", 2, 20)]
    got = {r.name: r for r in pooled_ratios(rows)}
    r = got["FR cascade+ / triangulation"]
    assert (r.value, r.low, r.high) == pytest.approx((0.5, 0.5, 0.5))
    assert (r.routines, r.suites, r.n_cam) == (2, 2, 2)
    assert got["FR cascade+"].value == pytest.approx(0.125)
    assert "FR cascade+ / oracle" not in got  # no oracle rows: left out, not NaN


def test_a_routine_without_both_methods_or_with_an_error_is_left_out_of_a_ratio():
    rows = [_row("r0", "vault", "cascade+", 1, 10), _row("r0", "vault", "triangulation", 5, 10),
            _row("r1", "vault", "cascade+", 9, 10),  # no triangulation row
            _row("r2", "vault", "cascade+", 9, 10), _row("r2", "vault", "triangulation", 1, 10, error="boom")]
    got = {r.name: r for r in pooled_ratios(rows)}
    assert got["FR cascade+ / triangulation"].value == pytest.approx(0.2)
    assert got["FR cascade+ / triangulation"].routines == 1
    assert got["FR cascade+"].value == pytest.approx(19 / 30)  # the figure alone takes every cascade+ row that ran
    assert got["FR cascade+"].suites == 1


def test_mota_is_the_mean_of_routine_values_per_apparatus_then_over_apparatus():
    rows = [_row("r0", "vault", "cascade+", 0, 1, mota=0.5), _row("r1", "vault", "cascade+", 0, 1, mota=0.7),
            _row("r2", "vault", "cascade+", 0, 1, mota=float("nan")),  # no value: not counted
            _row("r3", "balance_beam", "cascade+", 0, 1, mota=0.9)]
    got = {r.name: r for r in pooled_ratios(rows)}
    assert got["MOTA cascade+"].value == pytest.approx((0.6 + 0.9) / 2)
    assert got["MOTA cascade+"].low >= 0.5 - 1e-12 and got["MOTA cascade+"].high <= 0.7 / 2 + 0.45 + 1e-12


def test_aed_ratio_pools_frames_and_the_markdown_lists_every_n_cam():
    rows = [_row("r0", "vault", "cascade+", 1, 10, aed_sum=2.0, aed_n=10, n_cam=2),
            _row("r0", "vault", "oracle", 1, 10, aed_sum=1.0, aed_n=10, n_cam=2),
            _row("r1", "vault", "cascade+", 1, 10, aed_sum=3.0, aed_n=30, n_cam=3),
            _row("r1", "vault", "oracle", 1, 10, aed_sum=1.5, aed_n=30, n_cam=3)]
    got = {(r.name, r.n_cam): r for r in pooled_ratios(rows)}
    assert got[("AED cascade+ / oracle", 2)].value == pytest.approx(2.0)
    assert got[("AED cascade+ / oracle", 3)].value == pytest.approx(2.0)
    md = pooled_markdown(rows)
    assert "| AED cascade+ / oracle | 2 | 2.000 [2.000, 2.000]" in md and "| 3 |" in md
    assert "| vault | 10.00 % [10.00, 10.00] | - | 10.00 % [10.00, 10.00] |" in md


def test_seeds_option_is_checked_before_anything_runs(tmp_path):
    from gymtrack.cli.benchmark import _seeds

    assert _seeds("0, 1,2", None) == [0, 1, 2] and _seeds(None, None) == []
    for bad, suite in (("0,x", None), ("1,1", None), ("0,1", tmp_path)):
        with pytest.raises(InputError, match="--seeds"):
            _seeds(bad, suite)
    res = CliRunner().invoke(app, ["benchmark", "--out", str(tmp_path / "b"), "--seeds", "0,x"])
    assert res.exit_code != 0 and not (tmp_path / "b").exists()
