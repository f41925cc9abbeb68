"""``gymtrack simulate --video``: the rendered views (gymtrack.simulate.render).

Checked: the simulator's other files are byte-identical with and without videos; the videos decode
to one frame per routine frame at the asked size; the distortion map sends every pixel to where
the pinhole projection of the same world point lies (so the static scene is bent exactly as
``Camera.project`` -- itself checked against ``cv2.projectPoints`` -- bends points); people are
drawn where their true boxes are and nowhere else.
"""

from __future__ import annotations

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.geometry.camera import Camera
from gymtrack.simulate import simulate_routine
from gymtrack.simulate.render import background, render_view, view_canvas

pytest.importorskip("av")


def test_simulate_video_keeps_the_other_files_byte_identical(tmp_path):
    from gymtrack.formats.video import VideoReader

    run = CliRunner()
    a, b = tmp_path / "a", tmp_path / "b"
    args = ["simulate", "-a", "vault", "--seconds", "10", "--seed", "2", "--n-cam", "3"]
    ra = run.invoke(app, args + ["--out", str(a), "--video", "--video-size", "96"])
    assert ra.exit_code == 0, ra.output
    assert run.invoke(app, args + ["--out", str(b)]).exit_code == 0
    files_a = sorted(p.relative_to(a) for p in a.rglob("*") if p.is_file() and p.parts[-2] != "videos")
    files_b = sorted(p.relative_to(b) for p in b.rglob("*") if p.is_file())
    assert files_a == files_b and len(files_a) > 10
    for rel in files_a:
        assert (a / rel).read_bytes() == (b / rel).read_bytes(), rel
    videos = sorted(p.name for p in (a / "videos").iterdir())
    assert videos == ["cam0.mp4", "cam1.mp4", "cam2.mp4", "cam3.mp4"]
    with VideoReader(a / "videos" / "cam2.mp4") as v:
        assert v.size == (96, 54)
        assert v.frame_numbers[0] == 1 and v.frame_numbers[-1] == 300 and len(v) == 300
        assert v.read(300).shape == (54, 96, 3)


def test_bad_video_size_is_an_input_error(tmp_path):
    r = CliRunner().invoke(app, ["simulate", "-a", "vault", "--seconds", "10", "--out", str(tmp_path / "x"),
                                 "--video", "--video-size", "8"])
    assert r.exit_code != 0 and "--video-size" in str(r.exception)
    assert not (tmp_path / "x").exists()


def _strong_lens() -> Camera:
    K = np.array([[700.0, 0, 330], [0, 690, 235], [0, 0, 1]])
    R = cv2.Rodrigues(np.array([1.9, 0.1, 0.05]))[0]
    return Camera("lens", (640, 480), K, R, np.array([0.2, 1.1, 9.0]), np.array([-0.25, 0.08, 0.001, -0.002, 0.0]))


@pytest.mark.parametrize("width", [640, 320])
def test_distortion_map_agrees_with_the_projection(rng, width):
    cam = _strong_lens()
    vc = view_canvas(cam, width)
    s = width / 640
    # world points seen by the camera, at random depths
    uv_raw = rng.uniform([30, 30], [610, 450], (200, 2))
    X = cam.centre + cam.rays(uv_raw) * rng.uniform(3, 30, (200, 1))
    out_px = s * cam.project(X) - 0.5  # pixel index in the output frame
    mx, my = cv2.convertMaps(vc.maps[0], vc.maps[1], cv2.CV_32FC1)
    # bilinear read of the map at the (fractional) output pixel
    mapped = np.stack([cv2.remap(m, out_px[:, 0].astype(np.float32)[None], out_px[:, 1].astype(np.float32)[None],
                                 cv2.INTER_LINEAR)[0] for m in (mx, my)], -1)
    Xc = X @ cam.R.T + cam.t
    pin = (Xc @ vc.K.T)[:, :2] / Xc[:, 2:]  # canvas pixel index of the ideal pinhole
    np.testing.assert_allclose(mapped, pin, atol=0.05)
    # barrel distortion: the canvas is larger than the frame and holds every mapped pixel
    assert vc.canvas[0] > vc.size[0] and vc.canvas[1] > vc.size[1]
    assert mx.min() >= 0 and my.min() >= 0 and mx.max() < vc.canvas[0] and my.max() < vc.canvas[1]


def test_people_are_drawn_inside_their_true_boxes_and_nowhere_else():
    sim = simulate_routine("horizontal_bar", 4, seed=1, seconds=10)
    W = 480
    frames = [20, 80, 140]
    for c, cam in enumerate(sim.rig):
        s = W / cam.size[0]
        vc = view_canvas(cam, W)
        bg = background(vc, sim.app)
        bg = bg if vc.maps is None else cv2.remap(bg, vc.maps[0], vc.maps[1], cv2.INTER_LINEAR)
        gen = render_view(sim, c, W)
        hits = total = 0
        for t, img in enumerate(gen):
            if t not in frames:
                if t > frames[-1]:
                    break
                continue
            drawn = np.any(np.abs(img.astype(int) - bg.astype(int)) > 8, -1)
            allowed = np.zeros_like(drawn)
            live = np.isfinite(sim.true_boxes.depth[c, :, t]) & sim.alive[:, t]
            for p in np.flatnonzero(live):
                x, y, w, h = sim.gt_box[c, p, t] * s
                m = 0.04 * max(w, h) + 3  # capsule radii differ a little from the body's padding
                allowed[max(0, int(y - h / 2 - m)):int(y + h / 2 + m) + 1, max(0, int(x - w / 2 - m)):int(x + w / 2 + m) + 1] = True
                vis = sim.gt_visible[c, p, t] and sim.true_boxes.inside[c, p, t] > 0.99
                if vis and w * h > 150:
                    total += 1
                    hits += drawn[min(int(y), drawn.shape[0] - 1), min(int(x), drawn.shape[1] - 1)] or \
                        drawn[max(0, int(y - h / 4)), min(int(x), drawn.shape[1] - 1)]
            # bars are drawn too: only count pixels away from the apparatus's own pixels
            stray = drawn & ~allowed
            assert stray.mean() < 0.002, (cam.name, t, stray.sum())
        assert total > 5 and hits / total > 0.9, (cam.name, hits, total)
