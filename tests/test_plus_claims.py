"""cascade+'s benchmark targets against hand-worked answers on made-up rows."""

from __future__ import annotations

import math

import pytest

from gymtrack.eval.plus_claims import mot_averaged, plus_claims


def row(app, n, method, mota, idf1, aed=0.1, fr=(1, 10), frames=100, seconds=0.1):
    return {"routine": f"{app}/ncam{n}/r0", "apparatus": app, "n_cam": n, "method": method, "mota": mota, "idf1": idf1,
            "aed_sum": aed * 10, "aed_n": 10, "fr_failures": fr[0], "fr_evaluated": fr[1], "frames": frames,
            "seconds": seconds, "error": ""}


def rows():
    out = []
    for app, plus4, tri4 in (("vault", (0.90, 0.85), (0.80, 0.90)), ("balance_beam", (0.86, 0.81), (0.70, 0.70))):
        out += [row(app, 4, "cascade+", *plus4, aed=0.11, seconds=0.12), row(app, 4, "triangulation", *tri4, seconds=0.1),
                row(app, 4, "oracle", 0.95, 0.95, aed=0.1), row(app, 4, "cascade", 0.7, 0.7),
                row(app, 2, "cascade+", 0.80, 0.75, aed=0.12, fr=(2, 10), seconds=0.12),
                row(app, 2, "triangulation", 0.6, 0.6, seconds=0.1),
                row(app, 2, "oracle", 0.9, 0.9, aed=0.1), row(app, 2, "cascade", 0.6, 0.6, aed=0.14, fr=(1, 10))]
    return out


def by_name(found):
    return {c.name: c for c in found}


def test_mot_is_averaged_over_apparatus():
    m = mot_averaged(rows(), "mota")
    assert m[("cascade+", 4)] == pytest.approx((0.90 + 0.86) / 2)
    assert m[("triangulation", 2)] == pytest.approx(0.6)


def test_claims_hand_worked():
    wt = {"available": True, "modes": {"cascade+": {"mota": 0.7, "idf1": 0.55, "fp_ghosts": 100, "fp_duplicates": 400},
                                       "cascade": {"mota": 0.2, "idf1": 0.4, "fp_ghosts": 600, "fp_duplicates": 900}}}
    c = by_name(plus_claims(rows(), wt))
    assert c["all people n_cam=4: MOTA cascade+ >= 0.85"].status == "PASS"  # 0.88
    assert c["all people n_cam=4: IDF1 cascade+ >= 0.8"].status == "PASS"  # 0.83
    assert c["all people n_cam=2: MOTA cascade+ >= 0.75"].status == "PASS"  # 0.80
    below = c["all people: cascade+ >= triangulation on every apparatus and n_cam"]
    assert below.status == "FAIL" and below.value == 1 and "vault n_cam=4 (IDF1)" in below.detail
    assert c["n_cam=4: AED cascade+ <= 1.15 x oracle"].value == pytest.approx(1.1)
    assert c["n_cam=2: AED cascade+ <= 1.15 x oracle"].status == "FAIL"  # 1.2
    assert c["n_cam=2: FR cascade+ no worse than cascade"].status == "FAIL"  # 0.2 vs 0.1
    assert c["n_cam=2: AED cascade+ no worse than cascade"].status == "PASS"  # 0.12 vs 0.14
    speed = c["speed: cascade+ >= 0.85 x triangulation"]
    assert speed.value == pytest.approx(0.1 / 0.12) and speed.status == "FAIL"
    assert c["WILDTRACK: MOTA cascade+ >= 0.6"].status == "PASS"
    assert c["WILDTRACK: IDF1 cascade+ >= 0.6"].status == "FAIL"
    assert c["WILDTRACK: ghosts cascade+ < 0.33 x cascade"].status == "PASS"  # 100 < 200
    assert c["WILDTRACK: duplicates cascade+ < 0.33 x cascade"].status == "FAIL"  # 400 >= 300


def test_missing_parts_are_not_applicable():
    only = [r for r in rows() if r["method"] == "cascade+"]
    c = by_name(plus_claims(only, None))
    assert c["all people: cascade+ >= triangulation on every apparatus and n_cam"].status == "n/a"
    assert c["n_cam=2: AED cascade+ <= 1.15 x oracle"].status == "n/a"
    assert c["WILDTRACK: MOTA cascade+ >= 0.6"].status == "n/a"
    assert math.isnan(c["WILDTRACK: ghosts cascade+ < 0.33 x cascade"].value)
