"""The simulator's files: the formats of shared/formats.md, bit-for-bit reproducibility, the suite
layout and the ``gymtrack simulate`` / ``simulate-suite`` commands."""

from __future__ import annotations

import json

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.formats.ground_truth import load_ground_truth, read_persons_3d
from gymtrack.formats.calibration import read_native
from gymtrack.formats.gt_keypoints import read_keypoints_3d
from gymtrack.formats.motchallenge import parse_mot_table, read_gt_boxes
from gymtrack.formats.routine import load_routine
from gymtrack.formats.scene import load_scene
from gymtrack.simulate import body as B
from gymtrack.simulate import routine_seed, simulate_routine, simulate_suite


def _files(folder) -> dict[str, bytes]:
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def written(tmp_path_factory):
    out = tmp_path_factory.mktemp("routine")
    sim = simulate_routine("still_rings", n_cam=3, seed=7, seconds=12.0, out=out)
    return sim, out


def test_seed_reproduces_files_bit_for_bit(written, tmp_path):
    sim, out = written
    simulate_routine("still_rings", n_cam=3, seed=7, seconds=12.0, out=tmp_path / "again")
    a, b = _files(out), _files(tmp_path / "again")
    assert a.keys() == b.keys() and len(a) == 4 + 4 + 4 + 2  # detections, gt boxes, gt csv/csv/json/elements, yaml
    for k in a:
        assert a[k] == b[k], k
    simulate_routine("still_rings", n_cam=3, seed=8, seconds=12.0, out=tmp_path / "other")
    c = _files(tmp_path / "other")
    assert c["detections/cam0.txt"] != a["detections/cam0.txt"]
    assert c["gt/persons_3d.csv"] != a["gt/persons_3d.csv"]
    assert c["cameras.yaml"] != a["cameras.yaml"]


def test_routine_folder_reads_back(written):
    sim, out = written
    r = load_routine(out)  # calibration, scene and one detection file per camera, cross-checked
    assert r.rig.names == ("cam0", "cam1", "cam2", "cam3") and r.has_gt
    rig = read_native(out / "cameras.yaml")
    for a, b in zip(rig, sim.rig):
        assert np.array_equal(a.K, b.K) and np.array_equal(a.R, b.R) and np.array_equal(a.t, b.t) and np.array_equal(a.dist, b.dist)
    scene = load_scene(out / "scene.yaml")
    assert scene.apparatus == "still_rings" and scene.fps == 30.0
    # detections: MOTChallenge det lines, id -1, 1-based frames, the in-memory boxes to 0.01 px
    d = r.detections
    assert len(d) == len(sim.detections) and np.all(d.track_id == -1)
    assert d.frame.min() >= 1 and d.frame.max() <= sim.n_frames
    np.testing.assert_allclose(d.box, sim.detections.box, atol=0.01)
    np.testing.assert_allclose(d.score, sim.detections.score, atol=1e-4)
    table, _, rep = parse_mot_table(out / "detections" / "cam0.txt")
    assert rep.columns == 10 and np.all(table[:, 7:] == -1)
    # ground truth
    p = read_persons_3d(out / "gt" / "persons_3d.csv")
    assert (out / "gt" / "persons_3d.csv").read_text().splitlines()[0] == "frame,person_id,role,x,y,z,top_z,bottom_z,phase"
    assert len(p["frame"]) == int(sim.alive.sum())
    assert set(p["role"]) <= {"target", "coach", "judge", "gymnast", "spectator"}
    tgt = p["person_id"] == 1
    assert np.all(p["role"][tgt] == "target") and np.array_equal(p["frame"][tgt], sim.frames)
    np.testing.assert_allclose(p["xyz"][tgt], sim.target_centre, atol=1e-4)
    assert np.array_equal(p["phase"][tgt], sim.performing)
    assert np.all(p["top_z"] >= p["xyz"][:, 2]) and np.all(p["bottom_z"] <= p["xyz"][:, 2])
    gt = load_ground_truth(out, r.rig.names)
    for c, name in enumerate(r.rig.names):
        boxes, vis, _ = read_gt_boxes(out / "gt" / "boxes_2d" / f"{name}.txt", c, r.rig.names)
        t = boxes.track_id == 1
        np.testing.assert_allclose(boxes.box[t], sim.gt_box[c, 0, boxes.frame[t] - 1], atol=0.01)
        assert np.array_equal(vis[t], sim.gt_visible[c, 0, boxes.frame[t] - 1])
    assert gt.target_id == 1 and len(gt.box_frame) > 0
    # keypoints: the 17 COCO joints of every person, every frame they exist, to the mm
    lines = (out / "gt" / "keypoints_3d.csv").read_text().splitlines()
    assert lines[0] == "frame,person_id,joint,x,y,z" and len(lines) - 1 == 17 * int(sim.alive.sum())
    joints = [ln.split(",")[2] for ln in lines[1:18]]
    assert tuple(joints) == B.COCO_JOINTS
    frames, pid, kp = read_keypoints_3d(out / "gt" / "keypoints_3d.csv")
    assert np.array_equal(frames, sim.frames) and np.array_equal(pid, np.sort(sim.person_id))
    ref = sim.keypoints[np.argsort(sim.person_id)]
    assert np.array_equal(np.isnan(kp), np.isnan(ref)) and np.nanmax(np.abs(kp - ref)) <= 0.0005 + 1e-9
    meta = json.loads((out / "gt" / "simulation.json").read_text())
    assert meta["n_cam"] == 3 and meta["seed"] == 7 and len(meta["target_views"]) == 3


def test_suite_layout_and_index(tmp_path):
    entries = simulate_suite(tmp_path, 1, seconds=10.0, seed=4, apparatus=["pommel_horse"])
    index = json.loads((tmp_path / "suite.json").read_text())
    assert index["routines"] == entries and [e["n_cam"] for e in entries] == [2, 3, 4]
    seed = routine_seed(4, "pommel_horse", 0)
    for e in entries:
        assert e["path"] == f"pommel_horse/ncam{e['n_cam']}/r0" and e["seed"] == seed and e["frames"] == 300
        assert (tmp_path / e["path"] / "detections" / "cam3.txt").is_file()
    # a suite routine is the routine of its seed: simulate reproduces it
    one = simulate_routine("pommel_horse", n_cam=2, seed=seed, seconds=10.0, out=tmp_path / "single")
    assert _files(tmp_path / "single") == _files(tmp_path / entries[0]["path"])
    # the three n_cam folders hold one performance: same people, different detections
    p2, p4 = (tmp_path / entries[0]["path"] / "gt" / "persons_3d.csv"), (tmp_path / entries[2]["path"] / "gt" / "persons_3d.csv")
    assert p2.read_bytes() == p4.read_bytes()
    assert one.n_cam == 2


def test_cli_simulate_with_plots(tmp_path):
    runner = CliRunner()
    out = tmp_path / "r"
    res = runner.invoke(app, ["simulate", "--apparatus", "balance_beam", "--n-cam", "2", "--seed", "3", "--seconds", "10",
                              "--out", str(out), "--plot"])
    assert res.exit_code == 0, res.output
    assert "cam0, cam1" in res.output
    for f in ("cameras.yaml", "scene.yaml", "detections/cam2.txt", "gt/persons_3d.csv", "plot_top.png", "plot_side.png"):
        assert (out / f).is_file(), f
    assert (out / "plot_top.png").stat().st_size > 20_000
    res = runner.invoke(app, ["simulate-suite", "--per-apparatus", "1", "--seconds", "10", "--out", str(tmp_path / "s"),
                              "--apparatus", "vault", "--seed", "1"])
    assert res.exit_code == 0, res.output
    assert len(json.loads((tmp_path / "s" / "suite.json").read_text())["routines"]) == 3


def test_cli_bad_input_is_one_line(tmp_path):
    import subprocess
    import sys

    r = subprocess.run([sys.executable, "-c", "from gymtrack.cli import main; main()", "simulate", "--apparatus", "rings",
                        "--out", str(tmp_path / "x")], capture_output=True, text=True)
    assert r.returncode == 2 and "unknown apparatus 'rings'" in r.stderr and "Traceback" not in r.stderr
