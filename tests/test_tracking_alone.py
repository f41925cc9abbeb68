"""The recipe's ``alone`` (gymtrack.tracking.regroup.alone / continuing): a dropped cluster's
segment that continued a track continues it from its one view on the plane. Hand-worked index
cases, and cascade+ with and without it on a simulated beam where one view alone follows the
gymnast while a wrong third view's cluster is dropped."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.formats.scene import preset_scene
from gymtrack.modes import RECIPES
from gymtrack.simulate.routine import simulate_routine
from gymtrack.tracking.offline import track_detections
from gymtrack.tracking.regroup import alone, continuing, gymnast_only
from gymtrack.tracking.types import WindowTracklets3D


def test_alone_sends_a_dropped_segment_that_may_continue_alone_to_the_plane_in_a_group_of_its_own():
    """Segments 0-6; those that may continue a track alone (the tracker's: their 2D track
    belonged to a tracklet of the previous window): 0, 3 and 5. Clusters {0, 1, 2} and {3, 4} were dropped,
    {5, 6} kept; 1 and 2 are a regrouped pair (label 1), 3 is left to the floor. Only 0 qualifies:
    3 is the floor's, 4 may not continue alone, 5 was kept, 1 and 2 are regrouped already."""
    tested = np.array([[0, 1, 2, -1], [3, 4, -1, -1], [5, 6, -1, -1]])
    kept = np.array([[5, 6, -1, -1]])
    may = np.array([True, False, False, True, False, True, False])
    groups = np.array([0, 1, 1, 0, 0, 0, 0])
    counts = {"segments_alone": 0}
    reg, g, to_plane = alone(tested, kept, may, np.array([1, 2]), groups, np.array([6]), np.array([3]), counts)
    assert reg.tolist() == [0, 1, 2] and to_plane.tolist() == [0, 6]
    assert g[0] == 2 and np.array_equal(np.delete(g, 0), np.delete(groups, 0))  # a label nobody else has
    assert groups[0] == 0 and counts["segments_alone"] == 1  # (the caller's labels untouched)
    # nothing may continue alone: everything unchanged, no labels made
    counts = {"segments_alone": 0}
    reg, g, to_plane = alone(tested, kept, np.zeros(7, bool), np.array([1, 2]), None, np.array([6]), np.array([3]), counts)
    assert g is None and to_plane.tolist() == [6] and reg.tolist() == [1, 2] and counts["segments_alone"] == 0


def _tracklets(members, bottom):
    M = len(members)
    W = 3
    xyz = np.zeros((M, W, 3))
    xyz[..., 2] = 1.5
    return WindowTracklets3D(0, xyz, np.full((M, W), bottom + 1.6), np.full((M, W), bottom), np.ones((M, W), bool),
                             np.zeros((M, W), np.int8), np.ones((M, W), np.int8), np.array(members),
                             np.full(M, -1, np.int64))


def test_continuing_rows_are_kept_by_the_gymnast_test():
    """Three regrouped plane tracklets standing on the floor (bottom 0: not a gymnast by Eq. 13's
    indicator): one view that may continue alone (kept with ``alone``), two views (dropped), one
    view that may not (dropped)."""
    pl = _tracklets([[0, -1], [1, 2], [-1, 3]], bottom=0.0)
    keep = continuing(pl, np.array([True, True, True, False]))
    assert keep.tolist() == [True, False, False]
    target = preset_scene("balance_beam").target
    space = np.array([-9.0, -9, -9, 9, 9, 9])
    counts = {"regrouped_left_out": 0}
    assert gymnast_only(pl, np.array([0, 1, 2, 3]), space, target, counts) is None and counts["regrouped_left_out"] == 3
    out = gymnast_only(pl, np.array([0, 1, 2, 3]), space, target, counts, keep)
    assert out.members.tolist() == [[0, -1]] and counts["regrouped_left_out"] == 5


@pytest.fixture(scope="module")
def beam_one_view():
    """A beam seen by two opposite views (suite routine of seed 2, r1): from frame 416 to 545 only
    one view detects the gymnast, and windows of that stretch drop a cluster holding her segment
    (a third segment joined it and it failed Eq. 4)."""
    sim = simulate_routine("balance_beam", n_cam=2, seed=3720552013, seconds=25)
    return sim


def test_alone_keeps_the_gymnast_whom_one_view_follows(beam_one_view):
    sim = beam_one_view
    plus = RECIPES["cascade+"]
    on, off = (track_detections(sim.rig, sim.scene, sim.detections, mode=m) for m in (plus, plus.without("alone")))
    assert on.summary["segments_alone"] > 0 and "segments_alone" not in off.summary
    space = np.asarray(sim.scene.performance_space, float)
    inside = np.all((sim.centre[0] >= space[:3]) & (sim.centre[0] <= space[3:]), axis=1)
    perf = sim.frames[inside & sim.performing]

    def near(res):  # performing frames whose target lies within 0.5 m of the gymnast's centre
        rows = np.isin(res.target.frame, perf)
        err = np.linalg.norm(res.target.xyz[rows] - sim.centre[0][res.target.frame[rows] - sim.frames[0]], axis=1)
        return int(np.count_nonzero(err < 0.5))

    # (measured: 442 and 366 of 496)
    assert near(on) >= 0.85 * len(perf) and near(on) >= near(off) + 50


@pytest.fixture(scope="module")
def beam_wrong_triangulation():
    """A beam seen by two opposite views (suite routine of seed 0, r3): a third view's segment
    joins the gymnast's pair and triangulates her track 1.5 m off the beam; from frame ~320 the
    wrong cluster is dropped and her two views are a regrouped pair on the plane, 1.5 m from where
    her track was: beyond the linking gate, so the pair continued nothing."""
    return simulate_routine("balance_beam", n_cam=2, seed=198478470, seconds=25)


def test_alone_lets_a_regrouped_pair_continue_its_2d_tracks_track(beam_wrong_triangulation):
    sim = beam_wrong_triangulation
    plus = RECIPES["cascade+"]
    on, off = (track_detections(sim.rig, sim.scene, sim.detections, mode=m) for m in (plus, plus.without("alone")))
    frames = np.arange(330, 390)  # both views see her; without it no track is near her

    def near(res):
        rows = np.isin(res.target.frame, frames)
        err = np.linalg.norm(res.target.xyz[rows] - sim.centre[0][res.target.frame[rows] - sim.frames[0]], axis=1)
        return int(np.count_nonzero(err < 0.5))

    # (measured: 60 and 0 of 60)
    assert near(on) >= 55 and near(off) <= 10
