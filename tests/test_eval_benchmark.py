"""One small end-to-end benchmark: a simulated suite (1 apparatus, 1 routine per n_cam, 10 s each),
every method, in this process (the Dask runner: tests/test_batch.py), then the written report."""

from __future__ import annotations

import json

import pytest

from gymtrack.errors import RoutineError
from gymtrack.eval.benchmark import read_suite, run_suite, write_benchmark
from gymtrack.eval.aggregate import METHODS, pooled


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from gymtrack.simulate import simulate_suite

    out = tmp_path_factory.mktemp("suite")
    simulate_suite(out, 1, seconds=10.0, seed=3, apparatus=["uneven_bars"])
    return out


def test_end_to_end_benchmark(suite, tmp_path):
    specs = read_suite(suite)
    assert sorted(s.n_cam for s in specs) == [2, 3, 4] and {s.apparatus for s in specs} == {"uneven_bars"}
    assert len({s.name for s in specs}) == 3  # names are the relative paths, unique
    run = run_suite(specs, METHODS, jobs=2)
    assert len(run.rows) == 3 * len(METHODS)
    errors = [(r["routine"], r["method"], r["error"]) for r in run.rows if r["error"]]
    assert not errors
    for r in run.rows:
        assert 0 <= r["fr_failures"] <= r["fr_evaluated"] and r["fr_evaluated"] > 0
        assert r["cov_covered"] <= r["cov_frames"] and r["frames"] == 300 and r["seconds"] > 0
        assert r["mota"] <= 1.0 and 0.0 <= r["idf1"] <= 1.0
    p = pooled(run.rows)
    # the tracker against the ground truth: with all four views the cascade follows the gymnast
    # most of the time (a wrong output would be metres off on average)
    c4 = p[("uneven_bars", 4, "cascade")]
    assert c4["coverage"] > 0.5 and c4["aed"] < 1.0
    # the oracle's association comes from the GT: most detections are labelled with a person
    o = [r for r in run.rows if r["method"] == "oracle"]
    assert all(r["oracle_matched"] > r["oracle_unmatched"] for r in o)
    # the n_cam = 2 routine of uneven bars is drawn like Fig. 6
    assert "uneven_bars/ncam2/r0" in run.trajectories
    files = write_benchmark(run, tmp_path, wildtrack={"available": False, "note": "not in this test"})
    md = files["report"].read_text()
    assert "UB 2" in md and "UB 4" in md and "fig6_uneven_bars.png" in md and "not in this test" in md
    assert (tmp_path / "fig6_uneven_bars.png").stat().st_size > 10_000
    data = json.loads(files["json"].read_text())
    assert len(data["table3"]) == 3 * len(METHODS) and len(data["claims"]) >= 5


def test_read_suite_errors(tmp_path):
    with pytest.raises(RoutineError, match="suite folder not found"):
        read_suite(tmp_path / "nope")
    (tmp_path / "suite.json").write_text('{"routines": [{"path": "missing", "apparatus": "vault", "n_cam": 2}]}')
    with pytest.raises(RoutineError, match=r"suite.json: field 'routines\[0\]': routine folder 'missing' not found"):
        read_suite(tmp_path)
    (tmp_path / "suite.json").write_text('{"routines": [}')
    with pytest.raises(RoutineError, match="not valid JSON"):
        read_suite(tmp_path)
