"""The analysis stage's elements in ``gymtrack view`` (Rerun, read back with Rerun's reader) and
``gymtrack overlay`` (captions and the projected 3D skeleton, checked at the pixels of a lossless
video), on a simulated routine whose outputs are its ground truth (tests/viewdata.py) and a
hand-written ``analysis/elements.json`` with known frames."""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.eval.element_marks import ElementMarks, element_events, kind_bgr
from gymtrack.formats.elements import write_angles, write_elements

from viewdata import make_routine, write_gt_outputs

pytest.importorskip("av")

FPS = 30.0
DOC = {"track_id": 1, "fps": FPS, "apparatus": "balance_beam", "elements": [
    {"kind": "flight", "start_frame": 120, "end_frame": 140, "duration_s": 0.7, "apex_z": 2.1, "apex_z_sd": 0.02,
     "saltos": 1.0, "twists": 0.5, "shape": "tuck", "somersault_deg": 355.0, "twist_deg": 181.0},
    {"kind": "landing", "frame": 141, "steps": 0, "largest_step": 0.0, "stuck": True},
    {"kind": "hold", "start_frame": 160, "end_frame": 195, "duration_s": 1.2, "position": "handstand",
     "deviation": 6.5, "deviation_sd": 3.0},
    {"kind": "turn", "start_frame": 200, "end_frame": 215, "degrees": 180.0},
    {"kind": "flight", "start_frame": 220, "end_frame": 230, "duration_s": 0.37, "saltos": None, "twists": 0.0,
     "shape": "open", "missing": {"saltos": "somersault not seen"}},
]}
QUIET = 100  # nothing going on


def test_captions_per_frame_and_the_hold_timer():
    m = ElementMarks.from_doc(DOC)
    assert m.at(QUIET) == [] and m.at(119) == []
    assert m.at(125) == [("flight", "flight 1  1 salto · 0.5 twist · tuck  0.20 s")]  # 6 frames into it
    assert m.at(141) == [("landing", "landing 1  stuck")]
    assert m.at(141 + 29) == [("landing", "landing 1  stuck"), ("hold", "hold 1  handstand  0.37 / 1.20 s  dev 6.5 ± 3.0°")]
    assert m.at(171) == [("hold", "hold 1  handstand  0.40 / 1.20 s  dev 6.5 ± 3.0°")]  # the landing shows 1 s
    assert m.at(195)[0][1].startswith("hold 1  handstand  1.20 / 1.20 s") and m.at(196) == []
    assert m.at(205) == [("turn", "turn 1  180°")]
    assert m.at(221) == [("flight", "flight 2  ? saltos · 0 twists · open  0.07 s")]  # null: "?", never a number


def test_timeline_events_mark_each_start_and_end():
    frames, texts, kinds = element_events(DOC)
    assert frames.tolist() == [120, 140, 141, 160, 195, 200, 215, 220, 230]
    assert texts[0] == "flight 1: 1 salto, 0.5 twist, tuck, 0.70 s, apex 2.10 ± 0.02 m"
    assert texts[1] == "flight 1 ends" and texts[2] == "landing 1: stuck"
    assert texts[3] == "hold 1: handstand, 1.20 s, deviation 6.5 ± 3.0°"
    assert texts[7].startswith("flight 2: ? saltos, 0 twists, open") and kinds[5] == "turn"


@pytest.fixture(scope="module")
def demo(tmp_path_factory):
    root = tmp_path_factory.mktemp("elements")
    sim = make_routine(root / "routine")  # no videos: the views are a plain canvas
    out = write_gt_outputs(sim, root / "out")
    shutil.rmtree(out / "keypoints")  # only the projected 3D skeleton is drawn
    write_elements(out / "analysis" / "elements.json", DOC)
    f = sim.frames[sim.performing]
    n = f.size
    cols = {c: np.zeros(n) for c in ("com_x", "com_y", "left_knee", "right_knee", "left_hip", "right_hip", "left_elbow",
                                     "right_elbow", "left_shoulder", "right_shoulder", "split", "inclination", "twist")}
    cols.update(frame=f, track_id=np.full(n, sim.target_id), com_z=np.full(n, 1.0), support=np.full(n, "floor"),
                somersault=np.linspace(0, 360, n))
    cols["somersault"][3] = np.nan
    write_angles(out / "analysis" / "angles.csv", cols)
    return sim, root / "routine", out


def _overlay(routine, out, path, frames):
    from gymtrack.formats.video import VideoReader

    r = CliRunner().invoke(app, ["overlay", str(routine), str(out), "-o", str(path), "--width", "640",
                                 "--start", str(min(frames)), "--stop", str(max(frames))])
    assert r.exit_code == 0, r.output
    with VideoReader(path) as v:
        return {f: v.read(f - min(frames) + 1) for f in frames}  # the reader counts from 1


def _caption_band(img, k):
    """The bottom 16 rows, left half, of tile k of the 640 x 360 grid (320 x 180 tiles)."""
    y0, x0 = (k // 2) * 180, (k % 2) * 320
    return img[y0 + 164:y0 + 180, x0:x0 + 160].astype(int)


def test_overlay_shows_the_elements_going_on(demo, tmp_path):
    _, routine, out = demo
    imgs = _overlay(routine, out, tmp_path / "o.mkv", range(QUIET, 231))
    for k in range(4):
        quiet = _caption_band(imgs[QUIET], k)
        for frame, kind in ((125, "flight"), (170, "hold"), (205, "turn"), (225, "flight")):
            band = _caption_band(imgs[frame], k)
            swatch = np.all(band == kind_bgr(kind), -1).sum()
            assert swatch >= 9, (frame, kind, k)  # the kind's swatch
            assert np.all(band == 0, -1).sum() > 200  # the dark backdrop
            assert np.all(band > 200, -1).sum() > 20  # white text
            assert np.all(quiet == kind_bgr(kind), -1).sum() == 0
        assert np.all(quiet == 0, -1).sum() == 0 and np.all(quiet > 200, -1).sum() == 0
        # the hold timer runs: its caption's pixels change while the hold goes on
        assert np.abs(_caption_band(imgs[165], k) - _caption_band(imgs[185], k)).sum() > 0
        # one second after the landing its caption is gone: the hold's alone (one line, not two)
        assert np.all(_caption_band(imgs[165], k) == kind_bgr("landing"), -1).sum() == 0
        y0, x0 = (k // 2) * 180, (k % 2) * 320
        two = imgs[169][y0 + 150:y0 + 164, x0:x0 + 160]
        assert np.all(two == kind_bgr("landing"), -1).sum() >= 9  # the landing's line above the hold's


def test_overlay_draws_the_projected_3d_skeleton(demo, tmp_path):
    from gymtrack.eval.overlay import SKELETON_3D

    sim, routine, out = demo
    bare = tmp_path / "bare"
    shutil.copytree(out, bare)
    (bare / "poses_3d.csv").unlink()
    frame = 110
    t = int(np.flatnonzero(sim.frames == frame)[0])
    with_sk = _overlay(routine, out, tmp_path / "a.mkv", [frame])[frame].astype(int)
    without = _overlay(routine, bare, tmp_path / "b.mkv", [frame])[frame].astype(int)
    red = lambda img: np.abs(img - np.asarray(SKELETON_3D)).max(-1) <= 12  # noqa: E731
    for k, cam in enumerate(sim.rig):
        y0, x0 = (k // 2) * 180, (k % 2) * 320
        tile, bare_tile = with_sk[y0:y0 + 180, x0:x0 + 320], without[y0:y0 + 180, x0:x0 + 320]
        uv = cam.project(sim.keypoints[0, t]) * (320 / 1920)  # the true joints, where the bones must be
        ys, xs = np.nonzero(red(tile))
        assert ys.size >= 15 and red(bare_tile).sum() == 0
        assert xs.min() >= uv[:, 0].min() - 3 and xs.max() <= uv[:, 0].max() + 3
        assert ys.min() >= uv[:, 1].min() - 3 and ys.max() <= uv[:, 1].max() + 3
        # every bone is drawn: its midpoint lies on a red pixel, within 1 px
        for a, b in sim_bones():
            mx, my = (uv[a] + uv[b]) / 2
            win = red(tile[int(my) - 1:int(my) + 2, int(mx) - 1:int(mx) + 2])
            assert win.any(), (k, a, b)


def sim_bones():
    from gymtrack.skeletons import COCO17

    return COCO17.bones.tolist()


def test_the_recording_holds_the_elements(demo, tmp_path):
    pytest.importorskip("rerun")
    from gymtrack.eval.viewer import read_recording, write_recording

    sim, routine, out = demo
    rrd = tmp_path / "v.rrd"
    counts = write_recording(routine, out, rrd, videos=False)
    assert counts["elements"] == len(DOC["elements"])
    rec = read_recording(rrd)
    log = rec["/analysis/elements"]
    one = lambda v: v[0] if isinstance(v, list) else v  # noqa: E731  (a column holds one value a row)
    got = [(f, one(t)) for f, t in zip(log["frame"], log["TextLog:text"]) if f is not None]
    frames, texts, _ = element_events(DOC)
    assert got == list(zip(frames.tolist(), texts))
    now = {f: one(t) for f, t in zip(rec["/analysis/now"]["frame"],
                                                                   rec["/analysis/now"]["TextDocument:text"]) if f is not None}
    assert now[171] == "hold 1  handstand  0.40 / 1.20 s  dev 6.5 ± 3.0°"
    assert now[197] == "" and now[231] == "" and min(now) == 120  # cleared between and after the elements
    assert now[169] == "landing 1  stuck\nhold 1  handstand  0.33 / 1.20 s  dev 6.5 ± 3.0°"
    fl = rec["/world/target/flights"]
    labels = [x for x in fl["LineStrips3D:labels"] if x is not None][0]
    assert labels == ["flight 1  1 salto · 0.5 twist · tuck", "flight 2  ? saltos · 0 twists · open"]
    strips = [x for x in fl["LineStrips3D:strips"] if x is not None][0]
    assert len(strips[0]) == 21 and len(strips[1]) == 11  # the target's positions over each flight
    som = rec["/analysis/somersault"]
    vals = [v for f, v in zip(som["frame"], som["Scalars:scalars"]) if f is not None]
    assert len(vals) == int(sim.performing.sum()) - 1  # the empty cell is not plotted as a value
