"""gt/elements.json: the choreography's elements, checked against the motion the simulator made."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.apparatus import get_apparatus
from gymtrack.formats.elements import read_elements, validate_elements
from gymtrack.simulate import body as B
from gymtrack.simulate.elements import (HOLD_SPEED, body_angles, ground_truth_elements, rotations, still_runs,
                                        upright_frame)
from gymtrack.simulate.motion import MotionBuilder
from gymtrack.simulate.people import judges_layout
from gymtrack.simulate.skills import target_routine

FPS = 30.0


def _routine(apparatus: str, seed: int, seconds: float):
    """The target's motion, records and true joints, the way simulate_routine makes them."""
    app = get_apparatus(apparatus)
    s_layout, s_target, *_ = np.random.SeedSequence(seed).spawn(6)
    layout = judges_layout(app, np.random.default_rng(s_layout))
    rng = np.random.default_rng(s_target)
    body = B.BodyModel(rng.uniform(1.45, 1.75))
    motion, _, _, records = target_routine(app, seconds, FPS, rng, body, layout)
    kp, _ = body.world_points(motion.centre, motion.angles, motion.yaw, motion.pitch, motion.twist)
    doc = ground_truth_elements(records, motion.yaw, motion.pitch, motion.twist, kp[:, :17], app, FPS, 1)
    return motion, records, kp[:, :17], doc


@pytest.fixture(scope="module")
def rings():
    return _routine("still_rings", 11, 60.0)


@pytest.fixture(scope="module")
def hbar():
    return _routine("horizontal_bar", 11, 60.0)


def test_rotations_hand_worked():
    n = 37
    # a back salto facing +x on the beam (normal +y = the body's left): pitch 0 -> -2 pi
    som, tw = rotations(np.zeros(n), np.linspace(0, -2 * np.pi, n), np.zeros(n), (0, 1, 0))
    assert som[-1] == pytest.approx(-360.0) and np.allclose(tw, 0)
    # the same salto facing -x: the left axis is -y, the somersault about +y turns the other way
    som, _ = rotations(np.full(n, np.pi), np.linspace(0, -2 * np.pi, n), np.zeros(n), (0, 1, 0))
    assert som[-1] == pytest.approx(360.0)
    # standing, turning 180 deg on the spot: a twist about the long axis (vertical), no somersault
    som, tw = rotations(np.linspace(0, np.pi, n), np.zeros(n), np.zeros(n), (1, 0, 0))
    assert tw[-1] == pytest.approx(180.0) and np.allclose(som, 0)
    # upside down (pitch pi) a yaw turn twists the other way about the long axis
    _, tw = rotations(np.linspace(0, np.pi, n), np.full(n, np.pi), np.zeros(n), (1, 0, 0))
    assert tw[-1] == pytest.approx(-180.0)


def test_upright_frame_nearest_of_ties_and_empty_window():
    incl = np.array([0.0, 50, 50, 3.0, 0.0, 0.0, 80, 80])
    assert upright_frame(incl, 0, 5, 5) == 5  # 0, 3 (within 10 deg), 4, 5 tie: nearest the flight
    assert upright_frame(incl, 0, 2, 2) == 0
    assert upright_frame(incl, -10, -1, 0) is None


def test_still_runs_hand_worked():
    kp = np.zeros((8, 17, 3))
    kp[3:, 0, 0] = 0.01 * np.arange(5)  # the nose creeps at 0.3 m/s from frame 3 on (step 3 -> 4)
    kp[5:, 0, 0] = kp[5, 0, 0]           # ... and stops at frame 5
    assert still_runs(kp, FPS).tolist() == [[0, 3], [5, 7]]


def test_body_angles_straight_and_tucked():
    kp = np.zeros((1, 17, 3))
    for i, z in ((5, 1.4), (6, 1.4), (11, 0.9), (12, 0.9), (13, 0.5), (14, 0.5), (15, 0.1), (16, 0.1)):
        kp[0, i] = (0.0, 0.0, z)  # seen side on: both sides in one line
    a = body_angles(kp)
    assert np.allclose(a["hip"], 180) and np.allclose(a["knee"], 180) and a["inclination"][0] == pytest.approx(0)
    kp[0, [13, 14], 0] = 0.4  # thighs forward horizontal: hips at 90 deg
    kp[0, [13, 14], 2] = 0.9
    assert np.allclose(body_angles(kp)["hip"], 90)


def test_records_follow_truncation():
    b = MotionBuilder(B.BodyModel(1.6), FPS, np.random.default_rng(0))
    b.place((0, 0), 0.0, 0.0)
    b.stand(1.0, 0.0)
    n0 = b.n
    b.turn(np.pi, 1.0, 0.0)
    b.truncate(b.n - n0)
    assert [r["kind"] for r in b.records] == ["still"]


def test_flights_are_the_ballistic_runs(hbar):
    motion, records, kp, doc = hbar
    validate_elements(doc)
    fl = motion.flight
    edges = np.diff(np.concatenate([[0], fl.astype(int), [0]]))
    runs = [(s + 1, e) for s, e in zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)) if (e - s) / FPS >= 0.15]
    got = [(e["start_frame"], e["end_frame"]) for e in doc["elements"] if e["kind"] == "flight"]
    assert got == runs and len(got) >= 3
    for e in doc["elements"]:
        if e["kind"] == "flight":
            assert e["saltos"] == np.round(e["somersault_deg"] / 90) / 4
            pre, post = e["upright_frames"]
            assert pre <= e["start_frame"] and post > e["end_frame"]


def test_bar_dismount_and_circles(hbar):
    motion, _, _, doc = hbar
    els = doc["elements"]
    dismount = [e for e in els if e["kind"] == "flight"][-1]
    land = [e for e in els if e["kind"] == "landing"]
    assert land and land[-1]["frame"] == dismount["end_frame"] + 1 and land[-1]["stuck"]
    # the dismount's count is the pitch turned between its two upright frames, in whole saltos
    pre, post = dismount["upright_frames"]
    turned = abs(motion.pitch[post - 1] - motion.pitch[pre - 1]) / (2 * np.pi)
    assert abs(dismount["saltos"]) == pytest.approx(np.round(turned * 4) / 4) and abs(dismount["saltos"]) >= 2
    circles = [e for e in els if e["kind"] == "circle"]
    assert len(circles) >= 3
    for c in circles:  # each circle is one turn of pitch about the bar, to a frame
        dp = abs(motion.pitch[c["end_frame"] - 1] - motion.pitch[c["start_frame"] - 2])
        assert np.degrees(dp) == pytest.approx(360, abs=12)


def test_circles_are_full_turns_of_a_grip_run_in_one_direction():
    """Hand-worked: a cast (half a turn) running on into a giant and a half counts two circles from
    the cast's start; a hold's sway (under 0.5 deg a frame) keeps the direction; a swing back
    starts a new count; a turn held for over 3 s (a press) is no circle; a gap in the grip (a
    flight) ends a run."""
    from gymtrack.simulate.elements import _circles

    fps = 30.0
    som = np.concatenate([np.linspace(0, 180, 16)[:-1],  # cast: 15 frames
                          180 + 0.3 * np.sin(np.arange(10)),  # handstand held, swaying
                          np.linspace(180, 720, 46)[1:]])  # a giant and a half
    got = _circles([{"start": 0, "end": len(som) - 1}], som, fps)
    ends = [e["end_frame"] - 1 for e in got]
    assert [e["start_frame"] for e in got] == [1, ends[0] + 2] and len(got) == 2
    assert som[ends[0]] >= 350 and som[ends[0] - 1] < 350 and som[ends[1]] >= 710
    back = np.concatenate([som, som[-1] - np.linspace(0, 400, 40)[1:]])  # swings back a full turn
    assert len(_circles([{"start": 0, "end": len(back) - 1}], back, fps)) == 3
    slow = np.linspace(0, 360, int(4 * fps))  # a full turn in 4 s
    assert _circles([{"start": 0, "end": len(slow) - 1}], slow, fps) == []
    split = [{"start": 0, "end": 39}, {"start": 45, "end": len(som) - 1}]
    assert len(_circles(split, som, fps)) == 1  # the part after the gap turns 405 deg


def test_holds_are_still_and_rings_handstands(rings):
    motion, _, kp, doc = rings
    holds = [e for e in doc["elements"] if e["kind"] == "hold"]
    assert any(h["position"] == "handstand" for h in holds)
    for h in holds:
        a, b = h["start_frame"] - 1, h["end_frame"] - 1
        assert h["duration_s"] >= 1.0
        speed = np.linalg.norm(np.diff(kp[a:b + 1], axis=0), axis=2).max() * FPS
        assert speed < HOLD_SPEED
        if h["position"] == "handstand":
            assert h["deviation"] < 3.0  # hold_grip keeps the pitch within a sway of pi
            assert np.all(np.abs(np.cos(motion.pitch[a:b + 1]) + 1) < 0.01)


def test_written_and_read_back(tmp_path):
    from gymtrack.simulate import simulate_routine

    sim = simulate_routine("balance_beam", n_cam=2, seed=3, seconds=20, out=tmp_path)
    doc = read_elements(tmp_path / "gt" / "elements.json")
    assert doc["source"] == "ground truth" and doc["fps"] == 30 and doc["apparatus"] == "balance_beam"
    key = lambda e: (e.get("start_frame", e.get("frame")), e["kind"])  # noqa: E731 (written in frame order)
    assert doc["elements"] == sorted(sim.elements["elements"], key=key)
    kinds = {e["kind"] for e in doc["elements"]}
    assert {"flight", "landing"} <= kinds


def test_joint_rotations_follow_the_contract_axis():
    """Somersault = the angle of H->S in the plane about the normal; twist = the pelvis line about H->S."""
    from gymtrack.simulate.elements import joint_rotations
    body = B.BodyModel(1.6)
    n = 61
    pitch = np.linspace(0.0, -2 * np.pi, n)  # a back salto facing +x; the beam's normal is +y (the body's left)
    kp, _ = body.world_points(np.zeros((n, 3)), np.repeat(B.posture_angles(B.LAYOUT)[None], n, 0), np.zeros(n), pitch, np.zeros(n))
    som, tw = joint_rotations(kp[:, :17], (0, 1, 0))
    assert np.allclose(som, np.degrees(pitch), atol=1e-6) and np.allclose(tw, 0, atol=1e-6)
    # a full twist in the layout, upright: the pelvis line turns once about the long axis
    kp, _ = body.world_points(np.zeros((n, 3)), np.repeat(B.posture_angles(B.LAYOUT)[None], n, 0), np.zeros(n), np.zeros(n),
                              np.linspace(0, 2 * np.pi, n))
    som, tw = joint_rotations(kp[:, :17], (0, 1, 0))
    assert tw[-1] == pytest.approx(360.0) and np.allclose(som, 0, atol=1e-6)
    # a crouch's trunk lean is somersault by the contract (the body frame stays upright)
    a = B.posture_angles(B.STAND)
    lean = np.repeat(a[None], 2, 0)
    lean[1, 11] = 35.0
    kp, _ = body.world_points(np.zeros((2, 3)), lean, np.zeros(2), np.zeros(2), np.zeros(2))
    som, _ = joint_rotations(kp[:, :17], (0, 1, 0))
    assert som[1] == pytest.approx(35.0, abs=1e-6)


@pytest.mark.parametrize("apparatus,module", [("horizontal_bar", "bars"), ("still_rings", "rings")])
@pytest.mark.parametrize("saltos", [1, 2])
def test_flyaway_counts_saltos_from_hang_to_stand(apparatus, module, saltos, monkeypatch):
    """A flyaway drawn with k saltos is a k-salto dismount by the rules (hang to stand) in the ground truth."""
    import importlib

    monkeypatch.setattr(importlib.import_module(f"gymtrack.simulate.skills.{module}"), "flyaway_saltos", lambda c: saltos)
    _, _, _, doc = _routine(apparatus, 4, 20.0)
    last = [e for e in doc["elements"] if e["kind"] == "flight"][-1]
    assert abs(last["saltos"]) == saltos


def test_flyaway_distribution_is_the_rules():
    """The double salto is the common flyaway; the triple is rare and never on uneven bars."""
    from gymtrack.simulate.skills.choreography import FLYAWAY_SALTOS

    for name, (k, p) in FLYAWAY_SALTOS.items():
        p = dict(zip(k, p))
        assert max(p, key=p.get) == 2 and p.get(3, 0.0) <= 0.1 and sum(p.values()) == pytest.approx(1.0)
    assert 3 not in FLYAWAY_SALTOS["uneven_bars"][0]


def test_held_handstand_is_still_and_inverted():
    """A handstand held still is held; a giant passing its handstand at 180 deg/s is not; nor a still stand."""
    from gymtrack.simulate.elements import held_handstand

    n = 30
    still = np.tile([0.0, 0.0, -1.0], (n, 1))  # A->S pointing down: inverted, not turning
    assert held_handstand(still, np.full(n, 180.0), FPS)[3:-3].all()
    ang = np.radians(180.0 + 6.0 * (np.arange(n) - n // 2))  # 6 deg a frame: 180 deg/s through the top
    turning = np.column_stack([np.sin(ang), np.zeros(n), np.cos(ang)])
    incl = np.degrees(np.arccos(turning[:, 2]))
    assert not held_handstand(turning, incl, FPS).any()
    assert not held_handstand(-still, np.zeros(n), FPS).any()  # upright and still: not a handstand


@pytest.mark.parametrize("seed", [3, 7, 11])
def test_pommel_dismount_counts_from_the_handstand(seed):
    """The pommel horse's dismount leaves from a held handstand over the horse: its count starts at
    that handstand (half a revolution to the stand), not at the circles' tilt before it."""
    motion, _, kp, doc = _routine("pommel_horse", seed, 25.0)
    dismount = [e for e in doc["elements"] if e["kind"] == "flight"][-1]
    pre, post = dismount["upright_frames"]
    assert abs(dismount["saltos"]) == 0.5
    assert body_angles(kp)["inclination"][pre - 1] >= 150  # the handstand
    # the pitch turned between the handstand and the stand: half a revolution (the simulator's own state)
    assert abs(motion.pitch[post - 1] - motion.pitch[pre - 1]) == pytest.approx(np.pi, abs=np.radians(20))


def test_two_half_pivots_back_to_back_are_one_full_turn():
    """Turn records that follow each other the same way with no frame of rest are one turn; a rest
    frame between, or a turn back, keeps them apart (the analysis reads turns from rest to rest)."""
    from gymtrack.simulate.elements import _joined_turns

    rec = lambda s, e, d: {"kind": "turn", "start": s, "end": e, "degrees": d}  # noqa: E731
    got = _joined_turns([rec(40, 69, 180.0), rec(10, 39, 180.0), rec(71, 90, 180.0), rec(91, 110, -180.0)])
    assert [(r["start"], r["end"], r["degrees"]) for r in got] == [(10, 69, 360.0), (71, 90, 180.0), (91, 110, -180.0)]
