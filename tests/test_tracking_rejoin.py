"""The recipe's ``rejoin`` (gymtrack.tracking.regroup): a regrouped pair continues the track its
2D tracks belonged to, and a pair's lone view that looks like a gymnast on the apparatus
continues its own track. Hand-worked rows of the gymnast test, and cascade+ with and without it
on two simulated beams seen by two opposite views."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.formats.scene import preset_scene
from gymtrack.modes import RECIPES
from gymtrack.simulate.routine import simulate_routine
from gymtrack.tracking.offline import track_detections
from gymtrack.tracking.regroup import continuing, gymnast_only
from gymtrack.tracking.types import WindowTracklets3D


def _tracklets(members, bottom):
    """Plane tracklets of 3 frames with the given members and body bottoms (top: bottom + 1.6)."""
    M, W = len(members), 3
    xyz = np.zeros((M, W, 3))
    xyz[..., 2] = 1.5
    b = np.repeat(np.asarray(bottom, float)[:, None], W, axis=1)
    return WindowTracklets3D(0, xyz, b + 1.6, b, np.ones((M, W), bool), np.zeros((M, W), np.int8),
                             np.ones((M, W), np.int8), np.array(members), np.full(M, -1, np.int64))


def test_a_lone_view_passes_the_gymnast_test_only_raised_and_continuing():
    """Four regrouped plane tracklets of segments 0-4: one view raised on the beam that may continue
    its track (kept with ``rejoin``, dropped without: one view); one view standing on the floor
    that may continue (dropped either way: not a gymnast by Eq. 13's indicator); two views on the
    floor (dropped); one view raised that may not continue (dropped)."""
    pl = _tracklets([[0, -1], [1, -1], [2, 3], [-1, 4]], bottom=[1.3, 0.0, 0.0, 1.3])
    keep = continuing(pl, np.array([True, True, True, True, False]))
    assert keep.tolist() == [True, True, False, False]
    target = preset_scene("balance_beam").target
    assert target.h_bot < 1.3 and target.h_top < 2.9
    space = np.array([-9.0, -9, -9, 9, 9, 9])
    counts = {"regrouped_left_out": 0}
    assert gymnast_only(pl, np.arange(5), space, target, counts) is None and counts["regrouped_left_out"] == 4
    out = gymnast_only(pl, np.arange(5), space, target, counts, keep)
    assert out.members.tolist() == [[0, -1]] and counts["regrouped_left_out"] == 7


def _near(sim, res, frames):
    """Frames of ``frames`` whose target lies within 0.5 m of the gymnast's centre."""
    rows = np.isin(res.target.frame, frames)
    err = np.linalg.norm(res.target.xyz[rows] - sim.centre[0][res.target.frame[rows] - sim.frames[0]], axis=1)
    return int(np.count_nonzero(err < 0.5))


@pytest.fixture(scope="module")
def beam_wrong_triangulation():
    """A beam seen by two opposite views (suite routine of seed 0, r3): a third view's segment
    joins the gymnast's pair and triangulates her track 1.5 m off the beam; from frame ~320 the
    wrong cluster is dropped and her two views are a regrouped pair on the plane, 1.5 m from where
    her track was: beyond the linking gate, so the pair continued nothing."""
    return simulate_routine("balance_beam", n_cam=2, seed=198478470, seconds=25)


def test_rejoin_lets_a_regrouped_pair_continue_its_2d_tracks_track(beam_wrong_triangulation):
    sim = beam_wrong_triangulation
    plus = RECIPES["cascade+"]
    on, off = (track_detections(sim.rig, sim.scene, sim.detections, mode=m) for m in (plus, plus.without("rejoin")))
    assert "links_own" in on.summary and "links_own" not in off.summary
    frames = np.arange(330, 390)  # both views see her; without it no track is near her
    # (measured: 60 and 0 of 60)
    assert _near(sim, on, frames) >= 55 and _near(sim, off, frames) <= 10


def test_rejoin_links_its_pair_by_2d_tracks_without_the_floor_ingredient(beam_wrong_triangulation):
    """The pair's link by 2D tracks is rejoin's own: an ablation without ``floor`` keeps it
    (measured: 60 of 60 with rejoin, 0 without; before the fix both 0)."""
    sim = beam_wrong_triangulation
    no_floor = RECIPES["cascade+"].without("floor")
    on, off = (track_detections(sim.rig, sim.scene, sim.detections, mode=m) for m in (no_floor, no_floor.without("rejoin")))
    frames = np.arange(330, 390)
    assert on.summary["links_2d"] > 0 and "links_2d" not in off.summary or off.summary["links_2d"] == 0
    assert _near(sim, on, frames) >= 55 and _near(sim, off, frames) <= 10


@pytest.fixture(scope="module")
def beam_one_view():
    """A beam seen by two opposite views (suite routine of seed 2, r1): from frame 416 only one
    view detects the gymnast; a wrong third view's cluster holding her segment is dropped, and
    the regrouped pair's partner does not fuse with her view."""
    return simulate_routine("balance_beam", n_cam=2, seed=3720552013, seconds=25)


def test_rejoin_keeps_the_gymnast_whom_one_view_follows(beam_one_view):
    sim = beam_one_view
    plus = RECIPES["cascade+"]
    on, off = (track_detections(sim.rig, sim.scene, sim.detections, mode=m) for m in (plus, plus.without("rejoin")))
    assert on.summary["links_own"] > 0
    space = np.asarray(sim.scene.performance_space, float)
    inside = np.all((sim.centre[0] >= space[:3]) & (sim.centre[0] <= space[3:]), axis=1)
    perf = sim.frames[inside & sim.performing]
    # (measured: 405 and 366 of 496)
    assert _near(sim, on, perf) >= _near(sim, off, perf) + 25
