"""``gymtrack detect``, ``gymtrack pose --model``, ``gymtrack run`` and ``gymtrack models check`` on a
routine rendered by ``gymtrack simulate --video`` (480 pixels wide for 1920-pixel cameras) whose
frames the test stamps with a (camera, frame) code that an "oracle" stand-in detector
(tests/onnx_standins.py) turns back into the simulator's boxes. So the boxes ``detect`` writes
must equal the routine's own detections -- through decoding, frame numbering with a camera
offset, letterbox, grid decoding, the inverse letterbox and the video-to-calibration scale -- and
``run`` must write every output of docs/formats.md, which ``gymtrack eval`` scores.
"""

from __future__ import annotations

import shutil

import numpy as np
import pytest
from typer.testing import CliRunner

pytest.importorskip("av")
pytest.importorskip("onnxruntime")
pytest.importorskip("onnx")

from onnx_standins import code_pixel, lookup_graph, template_pose_graph, yolox_rows  # noqa: E402

from gymtrack.cli import app  # noqa: E402
from gymtrack.detections import Detections  # noqa: E402
from gymtrack.formats.motchallenge import read_detections  # noqa: E402
from gymtrack.formats.scene import load_scene, save_scene  # noqa: E402
from gymtrack.formats.calibration import read_native  # noqa: E402
from gymtrack.formats.video import VideoReader, write_video  # noqa: E402

SIZE = (128, 128)  # the stand-in detector's input: 336 anchors, a small table
OFFSET = 3         # cam1 started recording 3 frames early

pytestmark = pytest.mark.slow


WIDTH = 480       # rendered preview width: 4 calibration pixels per video pixel


def invoke(*args):
    res = CliRunner().invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output + repr(res.exception)
    return res.output


def stamp(path, codes, leading: int = 0):
    """Re-encode ``path`` with ``codes[k]`` drawn in the top-left corner of frame k; ``leading``
    extra frames (copies of the first) before the video, as a camera that started early."""
    with VideoReader(path) as r:
        frames = [im for _, im in r]
    frames = [frames[0]] * leading + frames
    for im, code in zip(frames, codes):
        im[:16, :16] = code_pixel(code)
    tmp = path.with_name("stamped.mp4")
    write_video(tmp, frames, 30, options={"preset": "ultrafast", "crf": "12"})
    tmp.replace(path)
    return len(frames)


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    """A rendered routine (``simulate --video``) whose frames carry a (camera, frame) code, its
    detections moved aside, cam1's video 3 frames early; the oracle detector and a pose stand-in."""
    root = tmp_path_factory.mktemp("video_routine")
    routine = root / "routine"
    invoke("simulate", "--apparatus", "balance_beam", "--n-cam", 4, "--seed", 5, "--seconds", 10, "--video",
           "--video-size", WIDTH, "--out", routine)
    shutil.move(str(routine / "detections"), str(root / "truth_detections"))
    scene = load_scene(routine / "scene.yaml")
    save_scene(scene.model_copy(update={"video_offsets": {"cam1": OFFSET}}), routine / "scene.yaml")
    names = tuple(p.stem for p in sorted((root / "truth_detections").glob("*.txt")))
    det = Detections.concat([read_detections(root / "truth_detections" / f"{n}.txt", c, names)[0]
                             for c, n in enumerate(names)])
    rig = read_native(routine / "cameras.yaml")
    assert rig.names == names and all(tuple(cam.size) == (1920, 1080) for cam in rig)
    with VideoReader(routine / "videos" / "cam0.mp4") as v:
        T = len(v)
        assert v.size == (WIDTH, 270) and T == 300
    stride = T + OFFSET + 1
    table = np.zeros((len(names) * stride, 336, 6), np.float32)
    r = SIZE[1] / 1920  # calibration pixels -> detector input (video at WIDTH, letterboxed to 128)
    for c, name in enumerate(names):
        leading = OFFSET if name == "cam1" else 0
        n = stamp(routine / "videos" / f"{name}.mp4", [c * stride + f + OFFSET for f in range(1 - leading, T + 1)], leading)
        assert n == T + leading
        for f in range(1, T + 1):
            rows = det.select((det.camera == c) & (det.frame == f))
            table[c * stride + f + OFFSET] = yolox_rows(SIZE, rows.box * r, rows.score.astype(np.float64))
    models = root / "models"
    lookup_graph(models / "det.onnx", ["batch", 3, *SIZE], [("output", table)])
    template_pose_graph(models / "pose.onnx")
    (models / "models.yaml").write_text("detector:\n  path: det.onnx\n  score_threshold: 0.0\n  nms_threshold: 1.0\n"
                                        "pose:\n  path: pose.onnx\n")
    return {"routine": routine, "models": models, "names": names, "truth": root / "truth_detections", "root": root}


def test_models_check(world):
    out = invoke("models", "check", world["models"] / "det.onnx")
    assert "yolox" in out and "output" in out
    out = invoke("models", "check", world["models"] / "pose.onnx")
    assert "simcc" in out
    res = CliRunner().invoke(app, ["models", "check", str(world["models"] / "models.yaml")])
    assert res.exit_code != 0


def test_detect_gives_back_the_routine_detections(world):
    routine, names = world["routine"], world["names"]
    out = invoke("detect", routine, "--models", world["models"] / "models.yaml")
    assert "3 frames numbered below 1" in out
    for c, name in enumerate(names):
        got, _ = read_detections(routine / "detections" / f"{name}.txt", c, names)
        want, _ = read_detections(world["truth"] / f"{name}.txt", c, names)
        assert len(got) == len(want), name
        g = got.select(np.lexsort((got.box[:, 0], got.frame)))
        w = want.select(np.lexsort((want.box[:, 0], want.frame)))
        assert np.array_equal(g.frame, w.frame)
        # boxes come back in calibration pixels (x4 the video's), clipped to the frame as a detector's are
        tl = np.clip(w.tlwh[:, :2], 0, None)
        br = np.minimum(w.tlwh[:, :2] + w.tlwh[:, 2:], [1920, 1080])
        assert np.allclose(g.tlwh, np.column_stack([tl, br - tl]), atol=0.05) and np.allclose(g.score, w.score, atol=1e-4)
    res = CliRunner().invoke(app, ["detect", str(routine), "--models", str(world["models"] / "models.yaml")])
    assert res.exit_code != 0 and "--force" in str(res.exception)


def test_run_writes_every_output_and_eval_scores_it(world, tmp_path):
    # (its own copy: run needs the videos only; eval and pose read the routine's detections, put
    # back from the truth, whatever other tests of this module did or did not write)
    routine = tmp_path / "routine"
    shutil.copytree(world["routine"], routine, ignore=shutil.ignore_patterns("detections"))
    out_dir = tmp_path / "out"
    out = invoke("run", routine, "--out", out_dir, "--detector", world["models"] / "det.onnx",
                 "--pose-model", world["models"] / "pose.onnx", "--models", world["models"] / "models.yaml")
    assert "Time per stage" in out and "lift" in out
    for rel in ("detections/cam0.txt", "tracks_3d.csv", "target_3d.csv", "tracks_2d/cam3.txt", "target_2d/cam0.txt",
                "summary.json", "keypoints/cam0.json", "poses_3d.csv"):
        assert (out_dir / rel).exists(), rel
    assert len((out_dir / "poses_3d.csv").read_text().splitlines()) > 10
    # the pose stand-in puts its joints inside the crop: back in calibration pixels, near each box
    from gymtrack.formats.keypoints import read_keypoints

    p = read_keypoints(out_dir / "keypoints", world["names"])
    assert len(p) > 100
    centre = p.bbox[:, :2] + p.bbox[:, 2:] / 2
    half = 1.25 * np.maximum(p.bbox[:, 2:], p.bbox[:, 3:] * 0.75) / 2  # the crop: box grown to 3:4, x 1.25
    off = np.abs(p.keypoints[..., :2] - centre[:, None]) / half[:, None]
    assert np.nanmax(off) <= 1.0 and np.nanmax(off) > 0.3
    shutil.copytree(world["truth"], routine / "detections")
    scored = invoke("eval", routine, out_dir)
    assert "AED" in scored or "MOTA" in scored or "target" in scored.lower()
    # the pose stage on its own, from the same track outputs
    out = invoke("pose", routine, out_dir, "--model", world["models"] / "pose.onnx")
    assert "simcc pose model on CPUExecutionProvider" in out


def test_video_size_must_match_the_calibration(world, tmp_path):
    routine = tmp_path / "r"
    shutil.copytree(world["routine"], routine, ignore=shutil.ignore_patterns("videos", "detections"))
    write_video(routine / "videos" / "cam0.mp4", (np.zeros((64, 64, 3), np.uint8) for _ in range(3)), 30)
    res = CliRunner().invoke(app, ["detect", str(routine), "--model", str(world["models"] / "det.onnx")])
    assert res.exit_code != 0 and "no video for camera" in str(res.exception)
    for n in ("cam1", "cam2", "cam3"):
        shutil.copy(world["routine"] / "videos" / f"{n}.mp4", routine / "videos" / f"{n}.mp4")
    res = CliRunner().invoke(app, ["detect", str(routine), "--model", str(world["models"] / "det.onnx")])
    assert res.exit_code != 0 and "64x64 but camera 'cam0' is calibrated at 1920x1080" in str(res.exception)


def test_detect_keeps_boxes_on_their_frames_through_dropped_repeated_and_corrupt_frames(world, tmp_path):
    """cam2's capture drops routine frames 50-51, repeats one frame (the image of frame 151 again at
    frame 100's time) and has a damaged stretch (a key frame and the next frame overwritten): frame
    numbers come from the timestamps, so every box the oracle finds lands on the frame its image
    shows; the dropped, repeated and corrupt frames are counted and named."""
    import av

    routine = tmp_path / "routine"
    shutil.copytree(world["routine"], routine, ignore=shutil.ignore_patterns("detections"))
    names, c = world["names"], 2
    with VideoReader(routine / "videos" / f"{names[c]}.mp4") as v:
        images = [im for _, im in v]
    (routine / "videos" / f"{names[c]}.mp4").unlink()
    keep = [k for k in range(len(images)) if k not in (49, 50)]  # file frames of routine frames 50, 51 dropped
    frames, stamps = [images[k] for k in keep], [float(k) for k in keep]
    at = stamps.index(99.0) + 1
    frames.insert(at, images[150])  # a repeat, 0.3 frame after frame 100's time
    stamps.insert(at, 99.3)
    path = routine / "videos" / f"{names[c]}.mkv"
    write_video(path, frames, 30, options={"g": "10"}, timestamps=stamps)
    with av.open(str(path)) as f:
        tb = f.streams.video[0].time_base
        packets = [(p.pts, p.pos, p.size, p.is_keyframe) for p in f.demux(f.streams.video[0]) if p.size]
    slot = [int(round(p[0] * tb * 30)) for p in packets]
    key = [i for i, p in enumerate(packets) if p[3] and slot[i] >= 200]
    data = bytearray(path.read_bytes())
    for _, pos, size, _ in packets[key[0]:key[0] + 2]:  # damage a key frame and the frame after it
        data[pos + size // 4: pos + 3 * size // 4] = bytes(3 * size // 4 - size // 4)
    path.write_bytes(bytes(data))
    corrupt = sorted({s + 1 for s in slot[key[0]:key[1]]})  # up to the next key frame: routine frames

    res = CliRunner().invoke(app, ["detect", str(routine), "--models", str(world["models"] / "models.yaml")])
    assert res.exit_code == 0, res.output + repr(res.exception)
    text = " ".join(res.output.split())
    assert (f"video of {names[c]}: 2 dropped (frames 50-51), 1 repeated skipped (at frame 100), "
            f"{len(corrupt)} corrupt skipped (frames {corrupt[0]}-{corrupt[-1]})") in text, text
    assert corrupt[0] > 200 and len(corrupt) >= 10
    lost = {50, 51, *corrupt}
    for cam in (0, c):
        got, _ = read_detections(routine / "detections" / f"{names[cam]}.txt", cam, names)
        want, _ = read_detections(world["truth"] / f"{names[cam]}.txt", cam, names)
        want = want.select(~np.isin(want.frame, list(lost))) if cam == c else want
        g = got.select(np.lexsort((got.box[:, 0], got.frame)))
        w = want.select(np.lexsort((want.box[:, 0], want.frame)))
        assert np.array_equal(g.frame, w.frame), names[cam]  # every box on the frame its image shows
        assert np.allclose(g.score, w.score, atol=1e-4)
