"""Scoring judging measurements against hand-worked answers (IoUs, matches, shares and errors)."""

from __future__ import annotations

import numpy as np
import pytest

from gymtrack.eval.elements import (angle_parts, element_parts, match, summarise_angles, summarise_elements,
                                    temporal_iou)


def _flight(a, b, saltos=1.0, twists=0.0, shape="tuck", apex=None):
    e = {"kind": "flight", "start_frame": a, "end_frame": b, "saltos": saltos, "twists": twists, "shape": shape}
    if apex is not None:
        e["apex_z"] = apex
    return e


def _doc(*els, fps=30):
    return {"track_id": 1, "fps": fps, "apparatus": "balance_beam", "elements": list(els)}


def test_temporal_iou_by_hand():
    # [10, 19] and [15, 24]: frames 15..19 shared (5), 10 + 10 - 5 = 15 in the union
    iou = temporal_iou([[10, 19], [0, 9]], [[15, 24], [20, 29], [0, 9]])
    assert iou[0].tolist() == pytest.approx([1 / 3, 0.0, 0.0])
    assert iou[1].tolist() == pytest.approx([0.0, 0.0, 1.0])


def test_match_is_one_to_one_and_beats_greedy():
    # A [0, 9], B [5, 14]; X [2, 11]: IoU(A, X) = 8/12, IoU(B, X) = 7/13; Y [0, 5]: IoU(A, Y) = 6/10,
    # IoU(B, Y) = 1/15. Greedy takes A-X (0.667) and leaves B with Y (0.067 < 0.3): one match;
    # the assignment takes A-Y + B-X = 1.138: two.
    pairs = match(np.array([[0, 9], [5, 14]]), np.array([[2, 11], [0, 5]]))
    assert sorted((i, j) for i, j, _ in pairs) == [(0, 1), (1, 0)]
    assert sorted(p[2] for p in pairs) == pytest.approx([7 / 13, 0.6])
    # below the 0.3 threshold nothing matches: [10, 19] and [17, 26] share 3 of 17 frames
    assert match(np.array([[10, 19]]), np.array([[17, 26]])) == []


def test_element_scores_by_hand():
    truth = _doc(_flight(100, 129, 1.0, 0.5, "tuck"), _flight(300, 319, 2.0, 0.0, "pike"),
                 _flight(500, 519, 1.0, 0.0, "layout"),
                 {"kind": "landing", "frame": 130, "steps": 0, "stuck": True},
                 {"kind": "hold", "start_frame": 200, "end_frame": 259, "duration_s": 2.0, "position": "handstand",
                  "deviation": 2.0},
                 {"kind": "turn", "start_frame": 400, "end_frame": 429, "degrees": 180.0})
    measured = _doc(_flight(101, 130, 1.0, 0.5, "tuck", apex=3.10),   # everything right, one frame late
                    _flight(302, 319, 1.75, 0.0, "open", apex=2.50),   # a quarter salto short, wrong shape
                    _flight(700, 719),                                 # nothing there: a false flight
                    {"kind": "landing", "frame": 140, "steps": 1, "stuck": False},  # 10 frames late: 50/70 IoU
                    {"kind": "hold", "start_frame": 203, "end_frame": 259, "duration_s": 1.9, "position": "handstand",
                     "deviation": 5.0},
                    {"kind": "turn", "start_frame": 405, "end_frame": 429, "degrees": 90.0})
    # the true apex from the true skeleton's centre of mass (no apex_z in the truth)
    f = np.arange(1, 601)
    com_z = np.where((f >= 100) & (f <= 129), 3.0, 1.0)
    com_z[f == 310] = 2.56
    s = summarise_elements([element_parts(measured, truth, true_com_z=(f, com_z))])
    k = s["kinds"]
    assert (k["flight"]["gt"], k["flight"]["measured"], k["flight"]["matched"]) == (3, 3, 2)
    assert k["flight"]["recall"] == pytest.approx(2 / 3) and k["flight"]["precision"] == pytest.approx(2 / 3)
    assert k["landing"]["recall"] == 1.0 and k["hold"]["recall"] == 1.0 and k["turn"]["precision"] == 1.0
    assert np.isnan(k["circle"]["recall"]) and np.isnan(k["circle"]["precision"])
    fl = s["flight"]
    assert fl["saltos_exact"] == {"share": 0.5, "n": 2} and fl["twists_exact"]["share"] == 1.0
    assert fl["shape"]["share"] == 0.5
    assert fl["start_err_frames"]["median"] == 1.5 and fl["end_err_frames"]["mean"] == 0.5  # starts 1, 2; ends 1, 0
    assert fl["time_err_frames"]["median"] == 1.0  # 1, 2, 1, 0
    assert fl["apex_err_m"]["median"] == pytest.approx((0.10 + 0.06) / 2)
    assert s["hold"]["duration_err_s"]["median"] == pytest.approx(0.1)
    assert s["hold"]["deviation_err_deg"]["median"] == pytest.approx(3.0)
    assert s["landing"]["stuck"]["share"] == 0.0 and s["turn"]["degrees"]["share"] == 0.0


def test_truth_outside_the_measured_frames_is_left_out_and_counted():
    truth = _doc(_flight(10, 29), _flight(200, 219), {"kind": "landing", "frame": 30, "steps": 0, "stuck": True})
    measured = _doc(_flight(200, 219))
    p = element_parts(measured, truth, frames=np.arange(150, 400))
    assert p["not_analysed"] == {"flight": 1, "landing": 1, "hold": 0, "circle": 0, "turn": 0}
    s = summarise_elements([p, p])  # two routines pooled
    assert s["kinds"]["flight"]["recall"] == 1.0 and s["kinds"]["flight"]["gt"] == 2
    assert s["not_analysed"]["flight"] == 2


def test_angle_errors_by_hand():
    truth = {"frame": np.array([1, 2, 3]), "left_knee": np.array([180.0, 90.0, 100.0]),
             "com_x": np.zeros(3), "com_y": np.zeros(3), "com_z": np.ones(3)}
    measured = {"frame": np.array([2, 3, 4]), "left_knee": np.array([80.0, 104.0, 0.0]),
                "com_x": np.array([0.03, 0.0, 9.0]), "com_y": np.array([0.04, 0.0, 9.0]), "com_z": np.ones(3)}
    s = summarise_angles([angle_parts(measured, truth)])
    assert s["left_knee"] == {"median": 7.0, "mean": 7.0, "n": 2}  # frames 2 and 3: 10 and 4
    assert s["com"]["median"] == pytest.approx(0.025) and s["com"]["n"] == 2  # 0.05 and 0


def test_eval_scores_an_analysis_folder_and_says_what_is_absent(tmp_path):
    """``gymtrack eval``'s judging part on files: the example's gt/elements.json against a measured
    one with the dismount's salto counted a quarter short and the mount missed."""
    import json
    import shutil
    from pathlib import Path

    from gymtrack.eval.score import judging_scores
    from gymtrack.formats.elements import read_elements, write_elements

    example = Path(__file__).resolve().parents[1] / "examples" / "balance_beam"
    routine, out = tmp_path / "routine", tmp_path / "out"
    (routine / "gt").mkdir(parents=True)
    shutil.copy(example / "gt" / "elements.json", routine / "gt" / "elements.json")
    notes: list[str] = []
    assert judging_scores(routine, out, None, 1, notes) is None
    assert "no " + str(out / "analysis" / "elements.json") in notes[0]
    truth = read_elements(routine / "gt" / "elements.json")
    measured = [dict(e) for e in truth["elements"] if e["kind"] != "flight" or e["saltos"] != 0]
    for e in measured:
        if e["kind"] == "flight":
            e["saltos"] -= 0.25
    write_elements(out / "analysis" / "elements.json", {**truth, "source": "analysis", "elements": measured})
    notes = []
    s = judging_scores(routine, out, None, 1, notes)
    k = s["elements"]["kinds"]
    assert (k["flight"]["gt"], k["flight"]["matched"], k["landing"]["matched"]) == (2, 1, 1)
    assert s["elements"]["flight"]["saltos_exact"]["share"] == 0.0 and s["elements"]["flight"]["shape"]["share"] == 1.0
    assert s["angles"] is None and any("angle and apex errors not scored" in n for n in notes)
    saved = json.loads((out / "analysis" / "scores.json").read_text())
    assert saved["elements"]["kinds"]["flight"]["recall"] == 0.5
