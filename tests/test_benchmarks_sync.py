"""benchmarks/bench_sync.py: the recovered-exactly share, and the cases it solves from one set of
pair cost curves (each camera moved by each offset), on hand-made curves."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np

_spec = importlib.util.spec_from_file_location("bench_sync", Path(__file__).resolve().parents[1] / "benchmarks" / "bench_sync.py")
bench_sync = importlib.util.module_from_spec(_spec)
_spec.loader.exec_module(bench_sync)


def test_share_counts_the_exact_cases():
    rows = [{"exact": True}, {"exact": False}, {"exact": True}]
    assert bench_sync.share(rows) == "2/3 (66.7 %)"
    assert bench_sync.share(rows[:1]) == "1/1 (100.0 %)"
    assert bench_sync.share([{"exact": False}]) == "0/1 (0.0 %)"
    assert bench_sync.share([]) == "-"


def test_cases_move_each_cameras_curves_by_its_offset():
    """Three cameras in sync: every pair's cost is lowest at shift 0 (1 + |shift|). Camera c moved
    by d frames moves the lowest cost of its pairs (c, j) to -d and of (i, c) to +d: every case is
    solved exactly, the clean one at 0."""
    S, M = bench_sync.SEARCH, bench_sync.MOST
    shifts = np.arange(-2 * S - M, 2 * S + M + 1)
    cost = np.full((3, 3, len(shifts)), np.nan)
    for i, j in ((0, 1), (0, 2), (1, 2)):
        cost[i, j] = 1.0 + np.abs(shifts)
    rows = bench_sync.cases(cost, 600)
    assert len(rows) == 1 + 2 * 2 * M  # the clean routine, cameras 1 and 2 by +-1..+-M
    assert rows[0]["offset"] == 0 and rows[0]["found"] == [0, 0, 0]
    for r in rows:
        want = [0, 0, 0]
        want[r["cam"]] = r["offset"]
        assert r["found"] == want and r["exact"], r
    assert bench_sync.share(rows) == f"{len(rows)}/{len(rows)} (100.0 %)"
    # camera 2's curves lowest one frame off: every case with camera 2 moved is found one frame off
    cost[0, 2] = 1.0 + np.abs(shifts - 1)
    cost[1, 2] = 1.0 + np.abs(shifts - 1)
    off = bench_sync.cases(cost, 600)
    assert all(r["found"][2] == (r["offset"] if r["cam"] == 2 else 0) + 1 for r in off)
    assert not any(r["exact"] for r in off)


def test_a_wrong_offset_of_an_undecided_camera_is_not_silent():
    """Camera 2's pairs are flat (no shift better than another): it stays at 0 whatever its true
    offset, each such case is wrong but flagged (undecided), never silent; camera 1's cases are
    exact."""
    S, M = bench_sync.SEARCH, bench_sync.MOST
    shifts = np.arange(-2 * S - M, 2 * S + M + 1)
    cost = np.full((3, 3, len(shifts)), np.nan)
    cost[0, 1] = 1.0 + np.abs(shifts)
    cost[0, 2] = cost[1, 2] = 5.0
    rows = bench_sync.cases(cost, 600)
    cam2 = [r for r in rows if r["cam"] == 2]
    assert len(cam2) == 2 * M and all(r["found"][2] == 0 and not r["exact"] for r in cam2)
    assert all(r["flagged"] and not r["silent"] for r in cam2)
    assert all(r["exact"] and not r["silent"] for r in rows if r["cam"] == 1)


def test_oracle_identity_costs_pool_the_people_and_leave_false_positives_out():
    """One person alone: the pooled cost is that person's own (pair_costs on its boxes). Two
    people: each one's curve counts by the moving boxes it weighed, and boxes of no person (-1)
    change nothing."""
    from gymtrack.simulate.routine import simulate_routine
    from gymtrack.tracking.sync import pair_costs

    sim = simulate_routine("vault", n_cam=3, seed=0, seconds=8)
    det, person = sim.detections, sim.det_person
    shifts = np.arange(-4, 5)
    p0, p1 = np.unique(person[person >= 0])[:2]
    one = np.flatnonzero(person == p0)
    alone, frames = bench_sync.oracle_identity_costs(det.select(one), sim.rig, person[one], shifts)
    own, _, _ = pair_costs(det.select(one), sim.rig, shifts)
    np.testing.assert_allclose(alone, own, equal_nan=True)
    assert frames == len(np.unique(det.frame[one]))
    two = np.flatnonzero(np.isin(person, [p0, p1]) | (person < 0))
    pooled, _ = bench_sync.oracle_identity_costs(det.select(two), sim.rig, person[two], shifts)
    (c0, n0, _), (c1, n1, _) = (pair_costs(det.select(np.flatnonzero(person == p)), sim.rig, shifts) for p in (p0, p1))
    want = (np.nan_to_num(c0) * n0 + np.nan_to_num(c1) * n1) / (n0 + n1)
    ok = (n0 + n1) > 0
    np.testing.assert_allclose(pooled[ok], want[ok])
    assert (person < 0).any()  # the routine has false positives, left out above
