"""``gymtrack eval``: the scores of an output folder equal the benchmark's, hand-built outputs
give hand-worked scores, and missing or malformed files give a clear InputError."""

from __future__ import annotations

import csv
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.errors import InputError, RoutineError
from gymtrack.eval.score import score_output
from gymtrack.formats.motchallenge import write_mot
from gymtrack.modes import DEFAULT_MODE

pytest.importorskip("motmetrics")

ROOT = Path(__file__).resolve().parents[1]
EXAMPLE = ROOT / "examples" / "balance_beam"
CAMS = ("cam0", "cam1", "cam2", "cam3")


def _gt_persons() -> dict[str, np.ndarray]:
    with open(EXAMPLE / "gt" / "persons_3d.csv", newline="") as fh:
        rows = list(csv.DictReader(fh))
    return {
        "frame": np.array([int(r["frame"]) for r in rows]),
        "pid": np.array([int(r["person_id"]) for r in rows]),
        "role": np.array([r["role"] for r in rows]),
        "xyz": np.array([[float(r["x"]), float(r["y"]), float(r["z"])] for r in rows]),
        "phase": np.array([r["phase"] == "1" for r in rows]),
    }


def _gt_boxes(cam: str) -> np.ndarray:
    """(N, 7) frame, pid, left, top, w, h, visible."""
    return np.loadtxt(EXAMPLE / "gt" / "boxes_2d" / f"{cam}.txt", delimiter=",", ndmin=2)[:, :7]


def _performing() -> np.ndarray:
    """The target's performing frames, worked out here from the files: role target, phase 1,
    centre inside scene.yaml's performance space [-4, -1, 0, 4, 1, 4.5]."""
    g = _gt_persons()
    lo, hi = np.array([-4.0, -1.0, 0.0]), np.array([4.0, 1.0, 4.5])
    ok = (g["role"] == "target") & g["phase"] & np.all((g["xyz"] >= lo) & (g["xyz"] <= hi), axis=1)
    return np.unique(g["frame"][ok])


def _write_hand_output(out: Path, shift_x: float = 0.1, drop_cam: str = "cam3", big_cam: str = "cam2") -> dict:
    """An output folder built from the ground truth: the target shifted by ``shift_x`` in x on
    every frame; b_buf squares of side 1.3 max(w, h) around the true boxes, none in ``drop_cam``
    and side 3 max(w, h) (too large) in ``big_cam``; every person inside the tracking space
    ([-5, -2, 0, 5, 2, 4.5]: S_perf grown by the 1 m buffer in x and y) as a 3D track."""
    g = _gt_persons()
    out.mkdir(parents=True)
    t = g["role"] == "target"
    tid = int(g["pid"][t][0])
    with open(out / "target_3d.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frame", "track_id", "x", "y", "z", "source"])
        for f, p in zip(g["frame"][t], g["xyz"][t]):
            w.writerow([f, 7, f"{p[0] + shift_x:.4f}", f"{p[1]:.4f}", f"{p[2]:.4f}", "triangulation"])
    lo, hi = np.array([-5.0, -2.0, 0.0]), np.array([5.0, 2.0, 4.5])
    inside = np.all((g["xyz"] >= lo) & (g["xyz"] <= hi), axis=1)
    with open(out / "tracks_3d.csv", "w", newline="") as fh:
        w = csv.writer(fh)
        w.writerow(["frame", "track_id", "x", "y", "z", "top_z", "bottom_z", "source", "n_views"])
        for f, i, p in zip(g["frame"][inside], g["pid"][inside], g["xyz"][inside]):
            w.writerow([f, 100 + i, f"{p[0]:.4f}", f"{p[1]:.4f}", f"{p[2]:.4f}", "", "", "triangulation", 2])
    perf = _performing()
    counts = {}
    for cam in CAMS:
        b = _gt_boxes(cam)
        b = b[b[:, 1] == tid]
        counts[cam] = int(np.count_nonzero((b[:, 6] == 1) & np.isin(b[:, 0], perf)))
        side = (3.0 if cam == big_cam else 1.3) * np.maximum(b[:, 4], b[:, 5])
        centre = b[:, 2:4] + b[:, 4:6] / 2
        box = np.column_stack([centre, side, side])
        keep = np.zeros(len(b), bool) if cam == drop_cam else np.ones(len(b), bool)
        write_mot(out / "target_2d" / f"{cam}.txt", b[keep, 0], np.full(keep.sum(), 7), box[keep])
        write_mot(out / "tracks_2d" / f"{cam}.txt", b[:0, 0], b[:0, 0], box[:0])
    return {"tid": tid, "visible_perf_boxes": counts}


def test_hand_built_output_scores():
    """Every number hand-worked: AED = the 0.1 m shift, one track id and person (0 switches),
    full coverage, FR failures = the dropped view's boxes (missing) + the oversized view's (too
    small), and tracks that are the ground truth give MOTA = IDF1 = 1."""
    import tempfile

    with tempfile.TemporaryDirectory() as d:
        out = Path(d) / "out"
        hand = _write_hand_output(out)
        s = score_output(EXAMPLE, out)
    g, p = s["target"], s["people"]
    n = hand["visible_perf_boxes"]
    perf = _performing()
    assert g["performing_frames"] == perf.size > 100
    assert g["coverage"] == 1.0 and g["covered_frames"] == perf.size
    assert g["aed_m"] == pytest.approx(0.1, abs=2e-4) and g["aed_frames"] == perf.size
    assert g["id_switches"] == 0
    assert g["fr_evaluated"] == sum(n.values())
    assert g["fr_missing"] == n["cam3"] > 0
    assert g["fr_too_small"] == n["cam2"] > 0
    assert g["fr_outside"] == 0
    assert g["fr_failures"] == n["cam3"] + n["cam2"]
    assert p["mota"] == 1.0 and p["idf1"] == 1.0 and p["false_positives"] == 0 and p["misses"] == 0
    assert p["objects"] > 0


def test_eval_equals_benchmark(tmp_path):
    """`gymtrack track` then `gymtrack eval` gives the benchmark's numbers for the same run."""
    from gymtrack.eval.benchmark import RoutineSpec, run_routine

    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["track", str(EXAMPLE), "--out", str(out)])
    assert res.exit_code == 0, res.output
    s = score_output(EXAMPLE, out)
    bench = run_routine(RoutineSpec("bb", str(EXAMPLE), "balance_beam", 4, 7), [DEFAULT_MODE])["rows"][0]
    assert bench["error"] == ""
    row = s["row"]
    assert set(row) <= set(bench)
    for k, v in row.items():
        if k == "aed_sum":  # the file keeps 4 decimals of each coordinate
            assert v == pytest.approx(bench[k], abs=1e-4 * bench["aed_n"])
        else:
            assert v == bench[k], k
    assert s["target"]["aed_frames"] > 0 and s["people"]["objects"] > 0
    assert s["target"]["id_switches"] == bench["idsw"]

    res = CliRunner().invoke(app, ["eval", str(EXAMPLE), str(out), "--json"])
    assert res.exit_code == 0, res.output
    js = json.loads(res.output)
    assert js["target"]["fr_failures"] == bench["fr_failures"] and js["people"]["mota"] == pytest.approx(bench["mota"])
    res = CliRunner().invoke(app, ["eval", str(EXAMPLE), str(out)], terminal_width=160)
    assert res.exit_code == 0 and "target AED" in res.output and "IDF1" in res.output


@pytest.fixture()
def hand_out(tmp_path):
    out = tmp_path / "out"
    _write_hand_output(out)
    return out


def test_missing_files_name_them(hand_out, tmp_path):
    with pytest.raises(InputError, match="output folder not found"):
        score_output(EXAMPLE, tmp_path / "nope", mot=False)
    (hand_out / "target_2d" / "cam2.txt").unlink()
    with pytest.raises(InputError, match=r"target_2d/cam2\.txt: no file for camera 'cam2'"):
        score_output(EXAMPLE, hand_out, mot=False)
    shutil.rmtree(hand_out / "tracks_2d")
    with pytest.raises(InputError, match=r"tracks_2d: folder tracks_2d/ not found"):
        score_output(EXAMPLE, hand_out, mot=False)
    (hand_out / "tracks_3d.csv").unlink()
    with pytest.raises(InputError, match=r"tracks_3d\.csv: file not found"):
        score_output(EXAMPLE, hand_out, mot=False)


def test_malformed_files_and_no_gt(hand_out, tmp_path):
    (hand_out / "target_3d.csv").write_text("frame,track,x,y,z,source\n1,2,0,0,0,plane\n")
    with pytest.raises(InputError, match=r"target_3d\.csv: line 1: expected the header"):
        score_output(EXAMPLE, hand_out, mot=False)
    (hand_out / "target_3d.csv").write_text("frame,track_id,x,y,z,source\n1,2,0,0,plane\n")
    with pytest.raises(InputError, match=r"target_3d\.csv: line 2: expected 6 values, got 5"):
        score_output(EXAMPLE, hand_out, mot=False)
    (hand_out / "target_3d.csv").write_text("frame,track_id,x,y,z,source\n")
    (hand_out / "target_2d" / "cam1.txt").write_text("1,7,10,10,x,5,1,-1,-1,-1\n")
    with pytest.raises(InputError, match=r"target_2d/cam1\.txt: line 1"):
        score_output(EXAMPLE, hand_out, mot=False)
    routine = tmp_path / "r"
    shutil.copytree(EXAMPLE, routine, ignore=shutil.ignore_patterns("gt"))
    with pytest.raises(RoutineError, match="no gt/ folder"):
        score_output(routine, hand_out, mot=False)


def test_empty_target_and_extra_camera(hand_out):
    """No target at all: coverage 0, every box missing, AED undefined (null in JSON); a file of
    a camera the routine lacks is reported, not read."""
    (hand_out / "target_3d.csv").write_text("frame,track_id,x,y,z,source\n")
    for cam in CAMS:
        (hand_out / "target_2d" / f"{cam}.txt").write_text("")
    (hand_out / "target_2d" / "cam9.txt").write_text("1,7,10,10,5,5,1,-1,-1,-1\n")
    res = CliRunner().invoke(app, ["eval", str(EXAMPLE), str(hand_out), "--json", "--no-mot"])
    assert res.exit_code == 0, res.output
    js = json.loads(res.output)
    g = js["target"]
    assert g["aed_m"] is None and g["coverage"] == 0.0 and g["fr"] == 1.0 and g["fr_missing"] == g["fr_evaluated"] > 0
    assert js["people"] is None
    assert any("cam9.txt is not a camera of the routine" in n for n in js["notes"])


def test_poses_scored_or_skipped_with_a_note(hand_out):
    """A poses_3d.csv holding the true joints: MPJPE 0 when the pose metrics are installed,
    else a note saying they are not (never an error)."""
    src = EXAMPLE / "gt" / "keypoints_3d.csv"
    g = _gt_persons()
    tid = int(g["pid"][g["role"] == "target"][0])
    with open(src, newline="") as fh, open(hand_out / "poses_3d.csv", "w", newline="") as out:
        w = csv.writer(out)
        w.writerow(["frame", "track_id", "joint", "x", "y", "z", "score", "n_views", "reproj_px"])
        for r in csv.DictReader(fh):
            if int(r["person_id"]) == tid:
                w.writerow([r["frame"], 7, r["joint"], r["x"], r["y"], r["z"], 1.0, 4, 0.5])
    s = score_output(EXAMPLE, hand_out, mot=False)
    try:
        import gymtrack.eval.pose_metrics  # noqa: F401
    except ImportError:
        assert s["poses"] is None and any("pose metrics are not installed" in n for n in s["notes"])
    else:
        assert s["poses"]["mpjpe_mm"] == pytest.approx(0.0, abs=0.1) and s["poses"]["pck"] == 1.0


def test_cli_error_is_one_line_exit_2(tmp_path):
    p = subprocess.run([sys.executable, "-c", "from gymtrack.cli import main; main()", "eval", str(EXAMPLE), str(tmp_path / "x")],
                       capture_output=True, text=True, cwd=ROOT, timeout=120, env={**os.environ, "COLUMNS": "300"})
    assert p.returncode == 2
    assert "output folder not found" in p.stderr and "Traceback" not in p.stderr
