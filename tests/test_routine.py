"""Routine folders: a small routine written in the test is read and cross-checked; inconsistent
folders raise RoutineError naming the file or camera; ``gymtrack info`` shows and checks it."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from conftest import look_at
from gymtrack.cli import app, main
from gymtrack.errors import CalibrationError, DetectionFormatError, RoutineError
from gymtrack.formats.calibration import write_native
from gymtrack.formats.motchallenge import write_mot, write_mot_gt
from gymtrack.formats.routine import load_routine
from gymtrack.geometry import Camera, Rig

CENTRE = np.array([0.0, 0.0, 2.25])  # the scene's focus (written into scene.yaml below)


def _rig() -> Rig:
    """north and south face each other through CENTRE (180 deg); east sees it at 90 deg to both."""
    K = np.array([[1500.0, 0, 960], [0, 1500.0, 540], [0, 0, 1]])
    cams = []
    for name, c in (("north", [0, 10, 2.25]), ("south", [0, -10, 2.25]), ("east", [12, 0, 4.0])):
        R, t = look_at(np.array(c, float), CENTRE)
        cams.append(Camera(name, (1920, 1080), K, R, t))
    return Rig(cams)


def _write_routine(root: Path, rng, frames: int = 12, empty: str | None = None) -> tuple[Rig, dict[str, int]]:
    """cameras.yaml, scene.yaml and detections/: two people walking, boxes projected per view."""
    rig = _rig()
    root.mkdir(parents=True, exist_ok=True)
    write_native(rig, root / "cameras.yaml")
    (root / "scene.yaml").write_text("apparatus: balance_beam\nfps: 30\nfocus: [0, 0, 2.25]\n")
    (root / "detections").mkdir()
    counts = {}
    t = np.arange(1, frames + 1)
    people = [np.column_stack([np.linspace(-3, 3, frames), np.zeros(frames), np.full(frames, 1.5)]),
              np.column_stack([np.full(frames, 2.0), np.linspace(-1, 1, frames), np.full(frames, 0.9)])]
    for cam in rig:
        fr, box = [], []
        for X in people:
            uv = cam.project(X)
            h = 1500.0 * 1.7 / cam.depth(X)
            fr.append(t)
            box.append(np.column_stack([uv, 0.4 * h, h]))
        fr, box = np.concatenate(fr), np.concatenate(box)
        keep = rng.uniform(size=fr.size) < 0.8  # the detector misses some
        if cam.name == empty:
            keep[:] = False
        counts[cam.name] = int(keep.sum())
        write_mot(root / "detections" / f"{cam.name}.txt", fr[keep], np.full(keep.sum(), -1), box[keep], rng.uniform(0.3, 1, keep.sum()))
    return rig, counts


def test_load_routine_reads_everything_in_rig_order(tmp_path, rng):
    rig, counts = _write_routine(tmp_path / "r", rng, empty="east")
    r = load_routine(tmp_path / "r")
    assert r.rig.names == rig.names == r.camera_names
    assert r.detections.camera_names == rig.names
    assert r.detections.counts_per_camera() == counts and counts["east"] == 0
    assert [rep.camera for rep in r.reports] == list(rig.names)
    assert [rep.boxes for rep in r.reports] == [counts[n] for n in rig.names]
    assert np.all(np.diff(r.detections.frame) >= 0)
    assert r.scene.apparatus == "balance_beam"
    assert r.calibration_report.format == "native" and r.calibration_path.name == "cameras.yaml"
    assert not r.has_gt and r.gt == {}
    # the boxes of a camera are that camera's file
    north = r.detections.for_camera("north")
    assert len(north) == counts["north"] and np.all(north.camera == 0)


def test_routine_with_ground_truth_and_other_calibration(tmp_path, rng):
    rig, _ = _write_routine(tmp_path / "r", rng)
    root = tmp_path / "r"
    (root / "cameras.yaml").unlink()
    lines = []
    for i, c in enumerate(rig):
        lines.append(f'[cam_{i}]\nname = "{c.name}"\nsize = [1920, 1080]\nmatrix = {c.K.tolist()}\n'
                     f"distortions = {c.dist.tolist()}\nrotation = {c.rvec.tolist()}\ntranslation = {(c.t * 1000).tolist()}\n")
    (root / "calibration.toml").write_text("\n".join(lines))
    (root / "gt" / "boxes_2d").mkdir(parents=True)
    write_mot_gt(root / "gt" / "boxes_2d" / "north.txt", [1], [0], [[100, 100, 20, 40]])
    (root / "gt" / "persons_3d.csv").write_text("frame,person_id,role,x,y,z,top_z,bottom_z\n")
    r = load_routine(root, units="mm")
    np.testing.assert_allclose(r.rig.centres, rig.centres, atol=1e-9)
    assert r.has_gt and set(r.gt) == {"boxes_2d", "persons_3d"}
    assert r.gt_boxes_path("north") is not None and r.gt_boxes_path("south") is None


def test_detection_file_for_unknown_camera(tmp_path, rng):
    _write_routine(tmp_path / "r", rng)
    extra = tmp_path / "r" / "detections" / "west.txt"
    extra.write_text("")
    with pytest.raises(RoutineError, match="'west'") as e:
        load_routine(tmp_path / "r")
    assert str(extra) in str(e.value)


def test_camera_without_detection_file(tmp_path, rng):
    _write_routine(tmp_path / "r", rng)
    (tmp_path / "r" / "detections" / "south.txt").unlink()
    (tmp_path / "r" / "detections" / "notes.md").write_text("not a detection file")
    with pytest.raises(RoutineError, match="'south'.*add an empty file") as e:
        load_routine(tmp_path / "r")
    assert e.value.field == "south"
    (tmp_path / "r" / "detections" / "south.txt").write_text("")
    r = load_routine(tmp_path / "r")
    assert r.detections.counts_per_camera()["south"] == 0
    assert [p.name for p in r.ignored] == ["notes.md"]


@pytest.mark.parametrize("remove,match", [("scene.yaml", "missing scene.yaml"), ("cameras.yaml", "no calibration found"),
                                          ("detections", "missing detections/")])
def test_missing_parts(tmp_path, rng, remove, match):
    _write_routine(tmp_path / "r", rng)
    p = tmp_path / "r" / remove
    if p.is_dir():
        for f in p.iterdir():
            f.unlink()
        p.rmdir()
    else:
        p.unlink()
    with pytest.raises(RoutineError, match=match):
        load_routine(tmp_path / "r")


def test_errors_inside_files_keep_their_type(tmp_path, rng):
    _write_routine(tmp_path / "r", rng)
    det = tmp_path / "r" / "detections" / "east.txt"
    det.write_text(det.read_text() + "7,-1,1,2,3\n")
    with pytest.raises(DetectionFormatError, match="east.txt: line"):
        load_routine(tmp_path / "r")
    _write_routine(tmp_path / "s", rng)
    cams = tmp_path / "s" / "cameras.yaml"
    cams.write_text(cams.read_text().replace("units: m", "units: feet"))
    with pytest.raises(CalibrationError, match="unknown units"):
        load_routine(tmp_path / "s")


# ============================================================================ gymtrack info
def _info_args(*args: str) -> list[str]:
    # typer runs a lone command without its name; once the other commands register, 'info' is needed
    single = len(app.registered_commands) + len(app.registered_groups) == 1
    return list(args) if single else ["info", *args]


def test_info_shows_cameras_opposite_pairs_and_counts(tmp_path, rng):
    rig, counts = _write_routine(tmp_path / "r", rng)
    res = CliRunner().invoke(app, _info_args(str(tmp_path / "r")), terminal_width=160)
    assert res.exit_code == 0, res.output
    out = res.output
    for name in rig.names:
        assert name in out
    for name, n in counts.items():
        row = next(line for line in out.splitlines() if f" {name} " in line and "x1080" not in line and "deg" not in line)
        cells = [c.strip() for c in row.split("│")]
        assert cells[1:3] == [name, str(n)], row  # camera, boxes
    opp = [line for line in out.splitlines() if "deg" in line and "north" in line and "south" in line]
    assert len(opp) == 1 and "180.0 deg" in opp[0]
    assert not any("east" in line and "deg" in line and ("north" in line or "south" in line) for line in out.splitlines())
    assert "balance_beam" in out and "opposite_angle_deg=150" in out


def test_info_on_a_bad_folder_exits_2_with_the_message(tmp_path, rng, monkeypatch, capsys):
    _write_routine(tmp_path / "r", rng)
    (tmp_path / "r" / "detections" / "east.txt").unlink()
    monkeypatch.setattr(sys, "argv", ["gymtrack", *_info_args(str(tmp_path / "r"))])
    with pytest.raises(SystemExit) as e:
        main()
    assert e.value.code == 2
    err = capsys.readouterr().err
    assert "error:" in err and "'east'" in err and "empty file" in err
