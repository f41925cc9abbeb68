"""``gymtrack view`` (a Rerun recording, read back with Rerun's own reader) and ``gymtrack overlay``
(decoded and checked at known pixels), on a simulated routine whose output folder is made from the
ground truth (tests/viewdata.py), so what must be in them is known."""

from __future__ import annotations

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.errors import InputError
from gymtrack.formats.calibration import read_calibration
from gymtrack.formats.outputs import read_outputs
from gymtrack.skeletons import COCO17

from viewdata import make_routine, write_gt_outputs

pytest.importorskip("av")


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    root = tmp_path_factory.mktemp("view")
    sim = make_routine(root / "routine", video_width=160)
    out = write_gt_outputs(sim, root / "out")
    return sim, root / "routine", out


@pytest.fixture(scope="module")
def recording(demo):
    pytest.importorskip("rerun")
    from gymtrack.eval.viewer import read_recording

    _, routine, out = demo
    rrd = out.parent / "view.rrd"
    r = CliRunner().invoke(app, ["view", str(routine), str(out), "-o", str(rrd)])
    assert r.exit_code == 0, r.output
    return read_recording(rrd)


def _rows(rec, entity, component):
    """{frame: (n, k) array} of a per-frame entity."""
    cols = rec[entity]
    return {f: np.asarray(v, float) for f, v in zip(cols["frame"], cols[component]) if f is not None}


def test_camera_poses_match_the_calibration(demo, recording):
    _, routine, _ = demo
    rig = read_calibration(routine / "cameras.yaml")[0]
    assert recording["/world"]["ViewCoordinates:xyz"]  # z up
    for cam in rig:
        tf = recording[f"/world/cameras/{cam.name}"]
        t = np.asarray(tf["Transform3D:translation"][0], float).reshape(3)
        R = np.asarray(tf["Transform3D:mat3x3"][0], float).reshape(3, 3).T  # Rerun stores columns
        np.testing.assert_allclose(t, cam.t, atol=1e-6)
        np.testing.assert_allclose(R, cam.R, atol=1e-6)
        assert tf["Transform3D:relation"][0] == [2] or tf["Transform3D:relation"][0] == 2  # child from parent
        pin = recording[f"/world/cameras/{cam.name}/image"]
        K = np.asarray(pin["Pinhole:image_from_camera"][0], float).reshape(3, 3).T
        np.testing.assert_allclose(K, cam.K, rtol=1e-6)
        np.testing.assert_allclose(np.asarray(pin["Pinhole:resolution"][0], float).reshape(2), cam.size)


def test_every_3d_track_and_box_is_in_the_recording(demo, recording):
    sim, routine, out = demo
    o = read_outputs(out, sim.rig.names)
    got = _rows(recording, "/world/tracks", "Points3D:positions")
    labels = dict(zip(recording["/world/tracks"]["frame"], recording["/world/tracks"]["Points3D:labels"]))
    assert sum(len(v) for v in got.values()) == len(o.tracks)
    for f in np.unique(o.tracks.frame)[::7]:
        m = o.tracks.frame == f
        want = o.tracks.xyz[m]
        np.testing.assert_allclose(np.sort(got[f], 0), np.sort(want, 0), atol=1e-5)
        assert sorted(labels[f]) == sorted(f"{i} {s}" for i, s in zip(o.tracks.track_id[m], o.tracks.source[m]))
    for c, name in enumerate(sim.rig.names):
        for entity, boxes in (("tracks", o.boxes), ("b_buf", o.target_boxes)):
            b = boxes.for_camera(c)
            centres = _rows(recording, f"/world/cameras/{name}/image/{entity}", "Boxes2D:centers")
            halves = _rows(recording, f"/world/cameras/{name}/image/{entity}", "Boxes2D:half_sizes")
            assert sum(len(v) for v in centres.values()) == len(b) > 0
            for f in np.unique(b.frame)[::5]:
                m = b.frame == f
                got_b = np.hstack([centres[f], 2 * halves[f]])
                np.testing.assert_allclose(np.sort(got_b, 0), np.sort(b.box[m], 0), atol=1e-3)
    assert "/world/cameras/cam0/image/detections" in recording


def test_target_skeleton_keypoints_ground_truth_and_videos(demo, recording):
    sim, _, out = demo
    perf = np.flatnonzero(sim.performing)
    tgt = _rows(recording, "/world/target", "Points3D:positions")
    assert sorted(tgt) == sim.frames[perf].tolist()
    skel = recording["/world/target/skeleton"]
    assert len(skel["frame"]) == perf.size and all(len(s) == len(COCO17.bones) for s in skel["LineStrips3D:strips"])
    kp = _rows(recording, "/world/cameras/cam1/image/keypoints", "Points2D:positions")
    assert len(kp) > 0 and all(len(v) == 17 for v in kp.values())
    gt = _rows(recording, "/world/gt/persons", "Points3D:positions")
    assert sum(len(v) for v in gt.values()) == int(sim.alive.sum())
    assert "/world/performance_space" in recording and "/world/apparatus_plane" in recording
    # videos were rendered at 160 px: a scaled pinhole of their own, one frame reference per frame
    v = recording["/world/cameras/cam3/video"]
    frames = [f for f in v["frame"] if f is not None]
    assert frames == list(range(1, sim.n_frames + 1))
    K = np.asarray([k for k in v["Pinhole:image_from_camera"] if k is not None][0], float).reshape(3, 3).T
    np.testing.assert_allclose(K[0, 0], sim.rig[3].K[0, 0] * 160 / 1920, rtol=1e-6)


def test_view_without_rerun_names_the_extra(demo, monkeypatch, tmp_path):
    import sys

    from gymtrack.eval.viewer import write_recording

    _, routine, out = demo
    monkeypatch.setitem(sys.modules, "rerun", None)
    with pytest.raises(InputError, match=r"gymtrack\[view\]"):
        write_recording(routine, out, tmp_path / "x.rrd")


def _one_box_outputs(sim, folder, box):
    """An output folder with track 7 at ``box`` (centre form, camera pixels) in every view and frame."""
    from gymtrack.formats.motchallenge import write_mot

    folder.mkdir()
    f = sim.frames
    (folder / "tracks_3d.csv").write_text("frame,track_id,x,y,z,top_z,bottom_z,source,n_views\n" +
                                          "".join(f"{k},7,0,0,1,2,0,plane,2\n" for k in f))
    (folder / "target_3d.csv").write_text("frame,track_id,x,y,z,source\n")
    for name in sim.rig.names:
        write_mot(folder / "tracks_2d" / f"{name}.txt", f, np.full(f.size, 7), np.tile(box, (f.size, 1)))
        write_mot(folder / "target_2d" / f"{name}.txt", f[:0], f[:0], np.zeros((0, 4)))
    return folder


@pytest.mark.parametrize("with_video", [True, False])
def test_overlay_draws_the_box_edges_in_the_id_colour(demo, tmp_path, with_video):
    import shutil

    from gymtrack.eval.overlay import CANVAS, id_colours
    from gymtrack.formats.video import VideoReader

    sim, routine, _ = demo
    if not with_video:  # the same routine without its videos: a neutral canvas
        shutil.copytree(routine, tmp_path / "novideo", ignore=shutil.ignore_patterns("videos"))
        routine = tmp_path / "novideo"
    box = np.array([1300.0, 280.0, 300.0, 200.0])  # in the sky of every view, clear of the caption
    out = _one_box_outputs(sim, tmp_path / "out", box)
    video = tmp_path / "grid.mkv"  # lossless, so the pixels can be compared exactly
    r = CliRunner().invoke(app, ["overlay", str(routine), str(out), "-o", str(video), "--width", "640",
                                 "--start", "10", "--stop", "14"])
    assert r.exit_code == 0, r.output
    colour = id_colours([7])[0]
    with VideoReader(video) as v:
        assert v.size == (640, 360) and len(v) == 5
        img = v.read(3)  # the file's frame 3 is routine frame 12 (the reader counts from 1)
    s = 320 / 1920
    for k in range(4):  # 2 x 2 grid of 320 x 180 tiles
        y0, x0 = (k // 2) * 180, (k % 2) * 320
        top, left = round((box[1] - box[3] / 2) * s), round((box[0] - box[2] / 2) * s)
        cx = round(box[0] * s)
        np.testing.assert_array_equal(img[y0 + top, x0 + cx], colour)
        np.testing.assert_array_equal(img[y0 + round(box[1] * s), x0 + left], colour)
        inside = img[y0 + round(box[1] * s), x0 + cx]
        if with_video:
            assert np.abs(inside.astype(int) - CANVAS).max() > 10  # the rendered view shows through
        else:
            np.testing.assert_array_equal(inside, CANVAS)


def test_overlay_one_camera_and_unknown_camera(demo, tmp_path):
    from gymtrack.formats.video import VideoReader

    sim, routine, out = demo
    video = tmp_path / "cam1.mp4"
    r = CliRunner().invoke(app, ["overlay", str(routine), str(out), "--camera", "cam1", "-o", str(video),
                                 "--start", "100", "--stop", "109"])
    assert r.exit_code == 0, r.output
    with VideoReader(video) as v:
        assert v.size == (160, 90) and len(v) == 10  # one view at its video's size
    r = CliRunner().invoke(app, ["overlay", str(routine), str(out), "--camera", "cam9", "-o", str(tmp_path / "x.mp4")])
    assert r.exit_code != 0 and "cam9" in str(r.exception)
