"""The benchmark's pose part: columns per method, pooling, claims and the report section."""

from __future__ import annotations

import pytest

from gymtrack.eval.benchmark import BenchmarkRun, read_suite, run_routine, write_benchmark
from gymtrack.eval.config import BenchmarkConfig
from gymtrack.eval.pose_bench import COMPARISONS, LIFTS, PARTS, pooled_common, pooled_pose, pose_claims, pose_markdown, pose_tables
from gymtrack.eval.pose_metrics import PoseError


@pytest.fixture(scope="module")
def rows(tmp_path_factory):
    from gymtrack.simulate import simulate_suite

    out = tmp_path_factory.mktemp("suite")
    simulate_suite(out, 1, seconds=10.0, seed=5, apparatus=["balance_beam"])
    specs = [s for s in read_suite(out) if s.n_cam in (2, 4)]
    res = [run_routine(s, ["cascade", "triangulation", "plane", "oracle"], mot=False) for s in specs]
    return [r for x in res for r in x["rows"]], specs


def test_pose_columns_per_method(rows):
    rows, _ = rows
    for r in rows:
        assert not r["error"] and not r.get("pose_error"), r.get("pose_error")
        if r["method"] == "plane":  # not a pose method: no pose columns
            assert not any(k.startswith("pose_") for k in r)
            continue
        lifts = LIFTS if r["method"] == "cascade" else ["robust"]
        for lift in lifts:
            e = PoseError(**{k: r[f"pose_{lift}_{k}"] for k in PARTS})
            assert e.frames > 0 and 0 < e.pose_frames <= e.frames
            assert e.pck_hits <= e.pck_joints and e.mpjpe_n > 0
            assert 10 < e.mpjpe < 1000  # millimetres
        # all three lifts see the same 2D keypoints: the same performing frames
        if r["method"] == "cascade":
            assert len({r[f"pose_{lift}_frames"] for lift in LIFTS}) == 1


def test_pooling_tables_and_claims(rows):
    rows, _ = rows
    p = pooled_pose(rows)
    a, n = "balance_beam", 2
    r = next(x for x in rows if x["method"] == "cascade" and x["n_cam"] == n)
    assert p[(a, n, "cascade", "robust")].mpjpe == pytest.approx(r["pose_robust_mpjpe_sum"] / r["pose_robust_mpjpe_n"])
    t = pose_tables(rows)
    assert {x["method"] for x in t["fig7"]} == {"cascade", "triangulation", "oracle"}
    c = {x.name: x for x in pose_claims(rows)}
    k = "pose n_cam=2: MPJPE cascade <= 0.7 x triangulation"
    # the claims compare on common frames and joints: each output's MPJPE over the pairs both estimated
    pc = pooled_common(rows)
    common = pc[(a, 2, "cascade_triangulation")]
    assert common.n <= min(p[(a, 2, "cascade", "robust")].mpjpe_n, p[(a, 2, "triangulation", "robust")].mpjpe_n)
    assert common.frames <= min(p[(a, 2, m, "robust")].pose_frames for m in ("cascade", "triangulation"))
    want = common.a / common.b
    assert c[k].value == pytest.approx(want) and c[k].status == ("PASS" if want <= 0.7 else "FAIL")
    assert "own MPJPE" in c[k].detail and "PCK@150 all frames" in c[k].detail
    # the cascade's row carries every comparison; same keypoints for robust and dlt: same frames
    r2 = next(x for x in rows if x["method"] == "cascade" and x["n_cam"] == 2)
    assert all(f"posecmp_{name}_n" in r2 for name in COMPARISONS)
    assert not any(k_.startswith("_") for x in rows for k_ in x)  # the per-joint scratch is gone
    # the limits come from the config
    strict = {x.name: x for x in pose_claims(rows, BenchmarkConfig(pose_cascade_over_triangulation_2=1e-3))}
    assert strict["pose n_cam=2: MPJPE cascade <= 0.001 x triangulation"].status == "FAIL"
    assert c["pose n_cam=2: MPJPE cascade <= 1.3 x oracle"].status in ("PASS", "FAIL")
    assert "pose n_cam=3: MPJPE cascade <= 1.3 x oracle" not in c  # no n_cam = 3 routine here
    assert c["pose n_cam=4: MPJPE robust <= dlt (no worse)"].status in ("PASS", "FAIL")


def test_report_section(rows, tmp_path):
    rows, specs = rows
    files = write_benchmark(BenchmarkRun(rows, {}, specs, 1.0, 1), tmp_path, mvor={"available": False, "note": "no MVOR here"})
    md = files["report"].read_text()
    assert "Fig. 7 as a table" in md and "Lifting ablation" in md and "no MVOR here" in md
    from gymtrack.version import version

    assert f"- gymtrack version: {version()}" in md  # the report says which gymtrack wrote it
    assert "pose n_cam=2: MPJPE cascade <= 0.7 x triangulation" in md
    assert files["pose"].read_text().count("\n") == 1 + len(pose_tables(rows)["fig7"])
    assert "not measured" in pose_markdown([{"routine": "x", "apparatus": "vault", "n_cam": 2, "method": "cascade", "error": ""}])
