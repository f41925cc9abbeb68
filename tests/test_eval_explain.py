"""The failure breakdown (gymtrack.eval.explain) on a constructed routine where each frame's
cause is known, and on a simulated routine against the FR it takes apart."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from gymtrack.detections import Detections
from gymtrack.eval.explain import CAUSES, explain_failures, explain_markdown, explain_table
from gymtrack.formats.ground_truth import GroundTruth
from gymtrack.tracking.types import Target, Tracks3D, TrackResult

NAMES = ("c0", "c1")
TRUE = np.array([100.0, 100.0, 50.0, 100.0])  # the gymnast's true box in both views
GOOD = np.array([100.0, 100.0, 160.0, 160.0])  # a b_buf that holds it
BAD = np.array([400.0, 100.0, 160.0, 160.0])  # one that misses it


def _gt(n_frames: int) -> GroundTruth:
    f = np.arange(n_frames)
    bf = np.repeat(f, 2)
    return GroundTruth(
        NAMES, f, np.ones(n_frames, np.int64), np.array(["target"] * n_frames), np.tile([0.0, 0.0, 1.0], (n_frames, 1)),
        np.full(n_frames, 1.8), np.full(n_frames, 0.2), bf, np.tile([0, 1], n_frames).astype(np.int16),
        np.ones(2 * n_frames, np.int64), np.tile(TRUE, (2 * n_frames, 1)), np.ones(2 * n_frames, bool))


def _tracks(rows):  # rows: (frame, track, x)
    rows = sorted(rows)
    f, t, x = (np.array([r[i] for r in rows]) for i in range(3))
    n = len(rows)
    return Tracks3D(f.astype(np.int64), t.astype(np.int64), np.column_stack([x, np.zeros(n), np.ones(n)]).astype(float),
                    np.full(n, 1.8), np.full(n, 0.2), np.zeros(n, np.int8), np.full(n, 2, np.int8))


def _boxes(rows):  # rows: (frame, camera, track, box)
    return Detections.from_arrays([r[0] for r in rows], [r[1] for r in rows], np.array([r[3] for r in rows]).reshape(-1, 4),
                                  NAMES, track_id=np.array([r[2] for r in rows], np.int64))


@pytest.fixture(scope="module")
def case():
    """Frames 0..6 of a gymnast standing at (0, 0, 1), seen by two views; one cause per frame:
    0 fine; 1 no detection; 2 box (the target is at the gymnast, its b_buf misses in view 1);
    3 unclustered; 4 phantom (the gymnast's boxes in track 7, 5 m away, and the target on it);
    5 identification (track 3 at the gymnast, the target on track 9 far away); 6 linking
    (track 3 at the gymnast, no target)."""
    gt = _gt(7)
    det_frames = [0, 2, 3, 4, 5, 6]
    det = _boxes([(f, c, -1, TRUE) for f in det_frames for c in (0, 1)] + [(1, 0, -1, BAD)])  # frame 1: clutter only
    tracks = _tracks([(0, 3, 0.0), (2, 3, 0.05), (4, 7, 5.0), (5, 3, 0.0), (5, 9, 8.0), (6, 3, 0.1)])
    boxes = _boxes([(0, 0, 3, TRUE), (0, 1, 3, TRUE), (2, 0, 3, TRUE), (4, 0, 7, TRUE), (4, 1, 7, TRUE),
                    (5, 0, 3, TRUE), (5, 1, 9, BAD), (6, 0, 3, TRUE)])
    tf = np.array([0, 2, 4, 5])
    target = Target(tf, np.array([3, 3, 7, 9]), np.array([[0, 0, 1], [0.1, 0, 1], [5, 0, 1], [8, 0, 1]], float),
                    np.zeros(4, np.int8))
    tb = _boxes([(0, 0, 3, GOOD), (0, 1, 3, GOOD), (2, 0, 3, GOOD), (2, 1, 3, BAD), (4, 0, 7, BAD), (4, 1, 7, BAD),
                 (5, 0, 9, BAD), (5, 1, 9, BAD)])
    res = TrackResult(tracks, boxes, target, tb, NAMES, "cascade+")
    scene = SimpleNamespace(performance_space=(-2.0, -2.0, 0.0, 2.0, 2.0, 3.0))
    return res, det, gt, scene


def test_each_frame_gets_its_known_cause_and_the_causes_add_up_to_the_failures(case):
    res, det, gt, scene = case
    why = explain_failures(res, det, gt, scene)
    # failed pairs: frame 1 (2 views), 2 (view 1 only), 3, 4, 5, 6 (both views each)
    assert why == {"failures": 11, "evaluated": 14, "no_detection": 2, "box": 1, "unclustered": 2, "phantom": 2,
                   "identification": 2, "linking": 2}
    assert sum(why[c] for c in CAUSES) == why["failures"]


def test_a_near_threshold_moves_a_frame_between_causes(case):
    res, det, gt, scene = case
    # within 6 m, the target on track 7 (5 m off) counts as at the gymnast: frame 4 becomes a box failure
    why = explain_failures(res, det, gt, scene, near=6.0)
    assert why["phantom"] == 0 and why["box"] == 3


def test_table_shares_add_up_to_the_fr_and_the_markdown_names_every_cause(case):
    res, det, gt, scene = case
    why = explain_failures(res, det, gt, scene)
    rows = [{"routine": "r", "apparatus": "vault", "n_cam": 2, "method": m, "fr_evaluated": why["evaluated"], "error": "",
             **{f"why_{c}": why[c] for c in CAUSES}} for m in ("cascade+", "oracle")]
    table = explain_table(rows)
    assert [(r["apparatus"], r["method"]) for r in table] == [("vault", "cascade+"), ("all (mean)", "cascade+"),
                                                             ("vault", "oracle"), ("all (mean)", "oracle")]
    assert table[0]["fr"] == pytest.approx(11 / 14) and table[0]["linking"] == pytest.approx(2 / 14)
    md = explain_markdown(rows)
    assert all(f"{c} %" in md for c in CAUSES) and "| 2 | vault | cascade+ | 78.57 |" in md


@pytest.fixture(scope="module")
def beam(tmp_path_factory):
    from gymtrack.simulate import simulate_routine

    path = tmp_path_factory.mktemp("explain") / "r"
    simulate_routine("balance_beam", n_cam=2, seed=3, seconds=10).write(path)
    return path


def test_on_a_simulated_routine_the_causes_take_apart_the_benchmark_fr(beam):
    from gymtrack.eval.benchmark import evaluate_routine
    from gymtrack.eval.gt import load_ground_truth, with_gt_ids
    from gymtrack.formats.routine import load_routine
    from gymtrack.tracking.offline import track_detections

    r = load_routine(beam)
    gt = load_ground_truth(beam, r.rig.names, image_size=np.array([c.size for c in r.rig], float))
    res = track_detections(r.rig, r.scene, r.detections, mode="cascade")
    why = explain_failures(res, r.detections, gt, r.scene, r.rig)
    row = evaluate_routine(res, gt, r.scene, r.rig, mot=False)
    assert why["failures"] == row["fr_failures"] > 0 and why["evaluated"] == row["fr_evaluated"]
    assert sum(why[c] for c in CAUSES) == row["fr_failures"]
    # the oracle's association never puts the gymnast's boxes in another person's track
    det, _ = with_gt_ids(r.detections, gt)
    orc = track_detections(r.rig, r.scene, det, mode="cascade", association="oracle")
    assert explain_failures(orc, r.detections, gt, r.scene, r.rig)["phantom"] == 0


def test_eval_explain_reads_the_output_folder_back_and_gives_the_same_causes(beam, tmp_path):
    import json

    from typer.testing import CliRunner

    from gymtrack.cli import app

    runner = CliRunner()
    res = runner.invoke(app, ["track", str(beam), "-o", str(tmp_path / "out"), "--mode", "cascade"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["eval", str(beam), str(tmp_path / "out"), "--explain", "--json", "--no-mot"])
    assert res.exit_code == 0, res.output
    s = json.loads(res.output)
    why = s["explain"]
    assert why["failures"] == s["target"]["fr_failures"] and sum(why[c] for c in CAUSES) == why["failures"]
    res = runner.invoke(app, ["eval", str(beam), str(tmp_path / "out"), "--explain", "--no-mot"], env={"COLUMNS": "200"})
    assert res.exit_code == 0 and "by cause" in res.output and "no detection" in res.output
