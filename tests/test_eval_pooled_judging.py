"""The judging targets pooled over suites with a bootstrap interval (gymtrack.eval.pooled), and
pooling benchmark outputs already run (gymtrack.eval.pool_outputs, ``gymtrack benchmark-pool``),
against hand-worked small cases."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.errors import InputError
from gymtrack.eval.elements import element_parts
from gymtrack.eval.judging import angle_histograms, judging_claims
from gymtrack.eval.pool_outputs import pool_outputs, read_rows
from gymtrack.eval.pooled import pooled_judging, pooled_judging_markdown
from gymtrack.eval.render import write_csv

RECALL4 = "judging n_cam=4: flight recall >= 0.95"


def _flight(k, saltos=1.0, twists=0.0):
    return {"kind": "flight", "start_frame": 100 * k + 10, "end_frame": 100 * k + 29, "saltos": saltos, "twists": twists,
            "shape": "tuck", "apex_z": 2.0}


def _doc(flights):
    return {"track_id": 1, "fps": 30, "apparatus": "balance_beam", "elements": flights}


def _row(routine, method, n_cam, truth, measured, knee=(4.0,), apparatus="balance_beam"):
    parts = {"elements": element_parts(_doc(measured), _doc(truth)), "angles": angle_histograms({"left_knee": list(knee)})}
    return {"routine": routine, "apparatus": apparatus, "n_cam": n_cam, "method": method, "judge_parts": json.dumps(parts),
            "fr_failures": 1, "fr_evaluated": 10, "aed_sum": 1.0, "aed_n": 10, "frames": 100, "seconds": 1.0, "error": ""}


def _recall_rows(app2="balance_beam"):
    """Suite s0: 3 of 4 true flights found; suite s1: 5 of 6 (cascade+, n_cam = 4)."""
    t0, t1 = [_flight(k) for k in range(4)], [_flight(k) for k in range(6)]
    return [_row("s0/r0", "cascade+", 4, t0, t0[:3]), _row("s1/r0", "cascade+", 4, t1, t1[:5], apparatus=app2)]


def test_two_suites_flight_recall_pools_flights_and_the_draws_are_the_three_resamples():
    # pooled: (3 + 5) / (4 + 6) = 0.8 (not the mean of 0.75 and 0.833); one stratum of two routines:
    # draws (a, a) 0.75 (p = 1/4), (a, b) 0.8 (p = 1/2), (b, b) 5/6 (p = 1/4) -> 5th and 95th percentiles
    got = {c.name: c for c in pooled_judging(_recall_rows(), n_boot=400, seed=1)}
    c = got[RECALL4]
    assert c.value == pytest.approx(0.8) and (c.low, c.high) == pytest.approx((0.75, 5 / 6))
    assert c.status == "FAIL" and c.passing == 0.0  # no draw reaches 0.95
    assert (c.routines, c.suites) == (2, 2)
    assert c.value == judging_claims(_recall_rows())[0].value  # the claim's own statistic
    assert np.isnan(got["judging n_cam=2: flight recall >= 0.9"].value)  # no n_cam = 2 rows: n/a, no interval
    assert np.isnan(got["judging n_cam=2: flight recall >= 0.9"].low)


def test_routines_are_resampled_within_apparatus():
    # the same two routines on two apparatus: each stratum has one routine, so every draw is the pooled set
    c = {c.name: c for c in pooled_judging(_recall_rows("vault"), n_boot=200)}[RECALL4]
    assert (c.value, c.low, c.high) == pytest.approx((0.8, 0.8, 0.8))


def test_method_rows_of_a_routine_are_drawn_together():
    # at n_cam = 2 the cascade gets exactly one salto more right than triangulation in every routine,
    # but the routines differ in size (1, 3, 5 flights: cascade 2, 6, 10 exact saltos + twists,
    # triangulation 1, 5, 9): paired draws of 3 routines always give 3 more; drawing the methods'
    # rows apart would give anything from 3 x 2 - 3 x 9 = -21 to 3 x 10 - 3 x 1 = 27
    rows = []
    for i, n in enumerate((1, 3, 5)):
        truth = [_flight(k) for k in range(n)]
        rows += [_row(f"r{i}", "cascade", 2, truth, truth),
                 _row(f"r{i}", "triangulation", 2, truth, [_flight(0, saltos=2.0)] + truth[1:])]
    name = "judging n_cam=2: cascade gets more saltos and twists exactly right than triangulation (how many more)"
    c = {c.name: c for c in pooled_judging(rows, n_boot=300)}[name]
    assert (c.value, c.low, c.high) == (3.0, 3.0, 3.0) and c.passing == 1.0


def test_interval_contains_the_pooled_value_and_the_markdown_shows_it():
    rng = np.random.default_rng(5)
    rows = []
    for i in range(12):
        truth = [_flight(k, saltos=float(rng.integers(1, 3))) for k in range(int(rng.integers(2, 6)))]
        found = [f for f in truth if rng.random() < 0.85]
        for method, n in (("cascade+", 4), ("cascade+", 2), ("cascade", 2), ("triangulation", 2)):
            rows.append(_row(f"s{i % 3}/{('balance_beam', 'vault')[i % 2]}/ncam{n}/r{i}", method, n, truth, found,
                             knee=rng.exponential(6.0, 30), apparatus=("balance_beam", "vault")[i % 2]))
    found = pooled_judging(rows, n_boot=100, seed=2)
    checked = [c for c in found if np.isfinite(c.value)]
    assert len(checked) >= 5
    for c in checked:
        assert c.low <= c.value <= c.high, c.name
    assert found[0].suites == 3
    md = pooled_judging_markdown(found, n_boot=100, seed=2)
    c = next(c for c in found if c.name.endswith("median knee angle error (deg) <= 8"))
    assert f"| {c.name} | {c.value:.3g} [{c.low:.3g}, {c.high:.3g}] | 8 |" in md
    assert pooled_judging([{"routine": "r", "apparatus": "vault", "n_cam": 4, "method": "cascade"}]) == []


def test_benchmark_results_get_the_pooled_records(tmp_path):
    # gymtrack benchmark (--seeds): the pooled sections in report.md, their records in CSV and results.json
    from gymtrack.eval.pool_outputs import pooled_results
    from gymtrack.eval.render import write_report

    rows = [r | {"judge_parts": json.loads(r["judge_parts"])} for r in _recall_rows()]
    sections, recs = pooled_results(rows, n_boot_judging=20, n_boot=20)
    files = write_report(tmp_path, rows, {}, (), "\n\n".join(sections), results=recs)
    assert "## Judging targets pooled over suites" in files["report"].read_text()
    doc = json.loads(files["json"].read_text())
    assert next(c for c in doc["pooled_judging"] if c["name"] == RECALL4)["value"] == pytest.approx(0.8)
    assert files["pooled_judging"].name == "pooled_judging.csv" and files["pooled_ratios"].is_file()


def _output(folder, rows):
    folder.mkdir()
    write_csv(folder / "rows.csv", rows)
    return folder


def test_benchmark_pool_command_on_two_outputs(tmp_path):
    a, b = _recall_rows()
    for r in (a, b):
        r["routine"] = r["routine"][3:]  # outputs of single suites: no s<seed>/ prefix
    a_out, b_out = _output(tmp_path / "a", [a]), _output(tmp_path / "b", [b])
    res = CliRunner().invoke(app, ["benchmark-pool", str(a_out), str(b_out), "-o", str(tmp_path / "p"), "--n-boot", "50",
                                   "--n-boot-judging", "40"])
    assert res.exit_code == 0, res.output
    with open(tmp_path / "p" / "pooled_judging.csv") as fh:
        got = {r["name"]: r for r in csv.DictReader(fh)}
    assert float(got[RECALL4]["value"]) == pytest.approx(0.8) and got[RECALL4]["suites"] == "2"
    doc = json.loads((tmp_path / "p" / "results.json").read_text())
    assert {r["name"] for r in doc["pooled_ratios"]} >= {"FR cascade+"} and doc["pooled_ratios"][0]["suites"] == 2
    report = (tmp_path / "p" / "report.md").read_text()
    assert "## Judging targets pooled over suites" in report and "## Headline figures pooled" in report
    assert "0.8 [0.75, 0.833]" in res.output
    assert not (a_out / "report.md").exists()  # the inputs are left as they were


def test_bad_outputs_are_named(tmp_path):
    (tmp_path / "empty").mkdir()
    with pytest.raises(InputError, match=r"empty/rows\.csv: missing"):
        pool_outputs([tmp_path / "empty"])
    with pytest.raises(InputError, match="not a folder"):
        read_rows(tmp_path / "nothing")
    bad = _output(tmp_path / "bad", [{"routine": "r0", "method": "cascade", "n_cam": 2}])
    with pytest.raises(InputError, match=r"bad/rows\.csv: line 1: no column apparatus"):
        read_rows(bad)
    row = _recall_rows()[0] | {"routine": "r0"}
    broken = _output(tmp_path / "broken", [row, row | {"judge_parts": "{oops"}])
    with pytest.raises(InputError, match=r"broken/rows\.csv: line 3: field 'judge_parts': not JSON"):
        read_rows(broken)
    mixed = _output(tmp_path / "mixed", [row, row | {"routine": "s1/r0"}])
    with pytest.raises(InputError, match="mixes routine names"):
        pool_outputs([mixed])
    good = _output(tmp_path / "good", [row])
    with pytest.raises(InputError, match="given twice"):
        pool_outputs([good, tmp_path / "good"])
    with pytest.raises(InputError, match="is one of the outputs pooled"):
        pool_outputs([good], out=good)
    res = CliRunner().invoke(app, ["benchmark-pool", str(tmp_path / "empty"), "-o", str(tmp_path / "p")])
    assert res.exit_code != 0 and "rows.csv" in str(res.exception) and not (tmp_path / "p").exists()
