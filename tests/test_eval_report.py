"""The report (gymtrack.eval.aggregate and gymtrack.eval.render) on a small fake results table worked out by hand."""

from __future__ import annotations

import csv
import json

import pytest

from gymtrack.eval.aggregate import claims, pooled, ratios, table3, table5, table6
from gymtrack.eval.render import write_report


def row(app, n, method, fr, aed, idsw, frames=300, seconds=0.1, routine=None, error=""):
    return {
        "routine": routine or f"{app}-{n}", "apparatus": app, "n_cam": n, "seed": 0, "method": method,
        "frames": frames, "seconds": seconds, "idsw": idsw, "idsw_track": idsw, "idsw_person": 0,
        "aed_sum": aed[0], "aed_n": aed[1], "fr_failures": fr[0], "fr_evaluated": fr[1],
        "fr_missing": fr[0], "fr_outside": 0, "fr_too_small": 0, "cov_covered": 90, "cov_frames": 100,
        "mota": 0.8, "idf1": 0.9, "mot_idsw": 0, "mot_fp": 0, "mot_fn": 0, "mot_objects": 100,
        "target_switches": 0, "error": error,
    }


@pytest.fixture
def rows():
    BB, UB = "balance_beam", "uneven_bars"
    return [
        # n_cam = 2; balance beam has two cascade routines, pooled:
        # FR (1 + 2) / (100 + 100) = 0.015, AED (10 + 30) / (100 + 100) = 0.2, ID switches 1 + 1 = 2
        row(BB, 2, "cascade", (1, 100), (10, 100), 1, routine="bb2a"),
        row(BB, 2, "cascade", (2, 100), (30, 100), 1, routine="bb2b"),
        row(BB, 2, "triangulation", (10, 100), (20, 100), 2, seconds=0.05, routine="bb2a"),
        row(BB, 2, "oracle", (0, 100), (18, 100), 0, routine="bb2a"),
        row(UB, 2, "cascade", (3, 100), (30, 100), 0),  # FR 0.03, AED 0.3
        row(UB, 2, "triangulation", (20, 100), (50, 100), 3, seconds=0.05),  # FR 0.2, AED 0.5
        row(UB, 2, "oracle", (0, 100), (22, 100), 0),  # AED 0.22
        # n_cam = 4
        row(BB, 4, "cascade", (0, 100), (8, 100), 0),
        row(BB, 4, "triangulation", (0, 100), (7, 100), 0, seconds=0.05),
        row(UB, 4, "cascade", (0, 100), (10, 100), 0),
        row(UB, 4, "triangulation", (0, 100), (10, 100), 0, seconds=0.05),
        row(BB, 4, "oracle", (0, 100), (5, 100), 0),
        row(UB, 4, "oracle", (0, 100), (5, 100), 0),
        # a failed run is left out of every number and listed
        row(UB, 4, "plane", (0, 0), (0, 0), 0, error="boom: no plane"),
    ]


def test_pooling_and_tables(rows):
    p = pooled(rows)
    bb = p[("balance_beam", 2, "cascade")]
    assert bb["fr"] == pytest.approx(0.015) and bb["aed"] == pytest.approx(0.2) and bb["idsw"] == 2 and bb["routines"] == 2
    assert ("uneven_bars", 4, "plane") not in p
    t3 = {(r["apparatus"], r["n_cam"], r["method"]): r for r in table3(rows)}
    assert t3[("uneven_bars", 2, "triangulation")]["fr"] == pytest.approx(0.2)
    assert t3[("uneven_bars", 2, "cascade")]["coverage"] == pytest.approx(0.9)
    t5 = {r["method"]: r for r in table5(rows)}
    # FR averaged over apparatus at n_cam = 2: cascade (0.015 + 0.03) / 2, triangulation (0.1 + 0.2) / 2
    assert t5["cascade"]["fr_2"] == pytest.approx(0.0225)
    assert t5["triangulation"]["fr_2"] == pytest.approx(0.15)
    # speed: cascade 5 runs x 300 frames / 0.5 s = 3000; triangulation 4 x 300 / 0.2 = 6000
    assert t5["cascade"]["fps"] == pytest.approx(3000) and t5["triangulation"]["fps"] == pytest.approx(6000)
    t6 = {r["method"]: r for r in table6(rows)}
    assert set(t6) == {"cascade", "triangulation"}  # plane only failed
    assert t6["cascade"]["aed_2"] == pytest.approx((0.2 + 0.3) / 2)
    assert t6["triangulation"]["aed_4"] == pytest.approx((0.07 + 0.10) / 2)


def test_ratios_and_claims(rows):
    r = {x["n_cam"]: x for x in ratios(rows)}
    assert r[2]["fr_cascade_over_triangulation"] == pytest.approx(0.0225 / 0.15)  # 0.15
    assert r[2]["aed_cascade_over_triangulation"] == pytest.approx(0.25 / 0.35)
    assert r[2]["aed_cascade_over_oracle"] == pytest.approx(0.25 / 0.20)  # oracle (0.18 + 0.22) / 2
    c = {x.name: x for x in claims(rows)}
    assert c["n_cam=2: FR cascade <= 0.3 x triangulation"].status == "PASS"
    assert c["n_cam=2: AED cascade <= 0.85 x triangulation"].status == "PASS"  # 0.714
    assert c["n_cam=2: ID switches cascade <= triangulation"].status == "PASS"  # 2 <= 5
    # n_cam = 4: cascade (0.08 + 0.10) / 2 = 0.09 vs triangulation 0.085: 5.9 % worse -> FAIL
    x = c["n_cam=4: AED cascade <= 1.05 x triangulation (no worse)"]
    assert x.status == "FAIL" and x.value == pytest.approx(0.09 / 0.085)
    assert c["n_cam=2: AED cascade <= 1.25 x oracle"].status == "PASS"  # exactly 1.25
    assert c["n_cam=4: AED cascade <= 1.25 x oracle"].status == "FAIL"  # 0.09 / 0.05 = 1.8
    assert c["speed: cascade >= 1000 frames/s"].status == "PASS"
    assert c["speed: cascade >= 0.9 x triangulation"].status == "FAIL"  # 0.5
    # without triangulation the comparisons are n/a, not PASS
    c2 = {x.name: x for x in claims([q for q in rows if q["method"] != "triangulation"])}
    assert c2["n_cam=2: cascade vs triangulation"].status == "n/a"


def test_write_report_files(rows, tmp_path):
    files = write_report(tmp_path, rows, meta={"suite": "fake"}, plots=["fig6_balance_beam.png"])
    md = files["report"].read_text()
    for heading in ("Table 3", "Table 5", "Table 6", "Ratios", "## Targets", "Failed runs"):
        assert heading in md
    assert "boom: no plane" in md and "fig6_balance_beam.png" in md
    assert "| cascade | 1.50% |" in md  # Table 3 FR block, BB n_cam=2 pooled 0.015
    with open(files["table3"]) as fh:
        t3 = list(csv.DictReader(fh))
    assert len(t3) == 12  # 2 apparatus x 2 n_cam x 3 methods (the failed plane run is absent)
    data = json.loads(files["json"].read_text())
    assert {c["status"] for c in data["claims"]} == {"PASS", "FAIL"}
    assert len(data["rows"]) == len(rows)
