"""The benchmark's judging section: pooling of rows, angle histograms, the targets (hand-worked)."""

from __future__ import annotations

import json

import numpy as np
import pytest

from gymtrack.eval.elements import element_parts
from gymtrack.eval.judging import angle_histograms, histogram_stats, judging_claims, judging_markdown, judging_tables


def _doc(*els):
    return {"track_id": 1, "fps": 30, "apparatus": "balance_beam", "elements": list(els)}


def _flight(a, b, saltos, twists=0.0, shape="tuck"):
    return {"kind": "flight", "start_frame": a, "end_frame": b, "saltos": saltos, "twists": twists, "shape": shape, "apex_z": 2.0}


TRUTH = _doc(_flight(10, 29, 1.0), _flight(100, 119, 2.0, 0.5, "pike"))


def _row(method, n_cam, measured, knee_err, truth=False):
    parts = {"elements": element_parts(measured, TRUTH), "angles": angle_histograms({"left_knee": knee_err, "right_knee": knee_err})}
    r = {"routine": f"r{n_cam}", "apparatus": "balance_beam", "n_cam": n_cam, "method": method, "judge_parts": json.dumps(parts)}
    if truth:
        r["judge_truth_parts"] = json.dumps({"elements": element_parts(TRUTH, TRUTH), "angles": angle_histograms({})})
    return r


def test_histogram_stats_pool_exactly_to_a_bin():
    a = angle_histograms({"hip": [1.0, 2.0, 30.2], "com": [0.02]})
    b = angle_histograms({"hip": [4.0]})
    s = histogram_stats([a["hip"], b["hip"]])
    assert s["n"] == 4 and s["mean"] == pytest.approx((1 + 2 + 30.2 + 4) / 4)
    assert s["median"] == pytest.approx(3.0, abs=0.1)  # between 2 and 4 (bin midpoints 2.05 and 4.05)
    assert histogram_stats([a["com"]])["median"] == pytest.approx(2.0, abs=0.1)  # the centre of mass in cm
    assert histogram_stats([])["n"] == 0


def test_tables_and_claims_by_hand():
    good = _doc(_flight(10, 29, 1.0), _flight(100, 119, 2.0, 0.5, "pike"))
    half = _doc(_flight(11, 29, 1.0), _flight(101, 119, 1.75, 0.5, "tuck"))
    rows = [_row("cascade+", 4, good, [2.0, 3.0], truth=True), _row("cascade", 2, good, [5.0]),
            _row("triangulation", 2, half, [12.0]), _row("cascade+", 2, half, [9.0])]
    t = judging_tables(rows)
    c4 = t["overall"][(4, "cascade+")]
    assert c4["kinds"]["flight"]["recall"] == 1.0 and c4["flight"]["saltos_exact"]["share"] == 1.0
    assert c4["angles"]["knee"]["n"] == 4
    tri = t["cells"][("balance_beam", 2, "triangulation")]
    assert tri["flight"]["saltos_exact"]["share"] == 0.5 and tri["flight"]["shape"]["share"] == 0.5
    assert tri["flight"]["time_err_frames"]["median"] == 0.5  # starts 1, 1; ends 0, 0
    assert t["truth"]["all"]["flight"]["twists_exact"]["share"] == 1.0
    claims = {c.name: c for c in judging_claims(rows)}
    assert claims["judging n_cam=4: exact saltos share >= 0.95"].status == "PASS"
    assert claims["judging n_cam=2: exact saltos share >= 0.9"].status == "FAIL"  # cascade+ at n_cam 2: 1 of 2
    more = next(c for n, c in claims.items() if n.startswith("judging n_cam=2: cascade gets more"))
    assert more.value == 1 and more.status == "PASS"  # saltos 2 + twists 2 against 1 + 2
    assert claims["judging n_cam=4: median hip angle error (deg) <= 8"].status == "n/a"  # no hip column given
    md = judging_markdown(rows)
    assert "Definitions check" in md and "| BB | triangulation |" in md


def test_nothing_to_judge_says_so():
    assert "not measured" in judging_markdown([{"routine": "r", "apparatus": "vault", "n_cam": 4, "method": "cascade"}])
