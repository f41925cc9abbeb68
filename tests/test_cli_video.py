"""``gymtrack detect``, ``gymtrack pose --model``, ``gymtrack run`` and ``gymtrack models check`` on
videos the test writes: a simulated routine whose frames carry a (camera, frame) code that an
"oracle" stand-in detector (tests/onnx_standins.py) turns back into the simulator's boxes. So the
boxes ``detect`` writes must equal the routine's own detections -- through decoding, frame
numbering with a camera offset, letterbox, grid decoding and the inverse letterbox -- and ``run``
must write every output of docs/formats.md, which ``gymtrack eval`` scores.
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
from gymtrack.formats.video import write_video  # noqa: E402

SIZE = (128, 128)  # the stand-in detector's input: 336 anchors, a small table
OFFSET = 3         # cam1 started recording 3 frames early

pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def world(tmp_path_factory):
    from gymtrack.simulate import simulate_routine

    root = tmp_path_factory.mktemp("video_routine")
    sim = simulate_routine("vault", n_cam=4, seed=3, seconds=10)
    routine = sim.write(root / "routine")
    shutil.move(str(routine / "detections"), str(root / "truth_detections"))
    scene = load_scene(routine / "scene.yaml")
    save_scene(scene.model_copy(update={"video_offsets": {"cam1": OFFSET}}), routine / "scene.yaml")
    det = Detections.concat([read_detections(root / "truth_detections" / f"{n}.txt", c, sim.rig.names)[0]
                             for c, n in enumerate(sim.rig.names)])
    T = int(det.frame.max())
    n_codes = len(sim.rig) * (T + OFFSET + 1)
    table = np.zeros((n_codes, 336, 6), np.float32)
    r = SIZE[1] / 1920
    for c, cam in enumerate(sim.rig):
        w, h = cam.size
        leading = OFFSET if cam.name == "cam1" else 0
        frames = np.arange(1 - leading, T + 1)

        def images(c=c, frames=frames, w=w, h=h):
            for f in frames:
                im = np.zeros((h, w, 3), np.uint8)
                im[:32, :32] = code_pixel(c * (T + OFFSET + 1) + f + OFFSET)
                im[100:200, 100:200] = 255  # something for the crops to see
                yield im

        write_video(routine / "videos" / f"{cam.name}.mp4", images(), 30, options={"preset": "ultrafast", "crf": "12"})
        for f in range(1, T + 1):
            rows = det.select((det.camera == c) & (det.frame == f))
            b = rows.box * r  # letterbox top-left at r = 128 / 1920
            table[c * (T + OFFSET + 1) + f + OFFSET] = yolox_rows(SIZE, b, rows.score.astype(np.float64))
    models = root / "models"
    lookup_graph(models / "det.onnx", ["batch", 3, *SIZE], [("output", table)])
    template_pose_graph(models / "pose.onnx")
    (models / "models.yaml").write_text("detector:\n  path: det.onnx\n  score_threshold: 0.0\n  nms_threshold: 1.0\n"
                                        "pose:\n  path: pose.onnx\n")
    return {"routine": routine, "models": models, "sim": sim, "truth": root / "truth_detections", "root": root}


def invoke(*args):
    res = CliRunner().invoke(app, [str(a) for a in args])
    assert res.exit_code == 0, res.output + repr(res.exception)
    return res.output


def test_models_check(world):
    out = invoke("models", "check", world["models"] / "det.onnx")
    assert "yolox" in out and "output" in out
    out = invoke("models", "check", world["models"] / "pose.onnx")
    assert "simcc" in out
    res = CliRunner().invoke(app, ["models", "check", str(world["models"] / "models.yaml")])
    assert res.exit_code != 0


def test_detect_gives_back_the_routine_detections(world):
    routine, sim = world["routine"], world["sim"]
    out = invoke("detect", routine, "--models", world["models"] / "models.yaml")
    assert "3 frames numbered below 1" in out
    for c, name in enumerate(sim.rig.names):
        got, _ = read_detections(routine / "detections" / f"{name}.txt", c, sim.rig.names)
        want, _ = read_detections(world["truth"] / f"{name}.txt", c, sim.rig.names)
        assert len(got) == len(want), name
        g = got.select(np.lexsort((got.box[:, 0], got.frame)))
        w = want.select(np.lexsort((want.box[:, 0], want.frame)))
        assert np.array_equal(g.frame, w.frame)
        assert np.allclose(g.box, w.box, atol=0.02) and np.allclose(g.score, w.score, atol=1e-4)
    res = CliRunner().invoke(app, ["detect", str(routine), "--models", str(world["models"] / "models.yaml")])
    assert res.exit_code != 0 and "--force" in str(res.exception)


def test_run_writes_every_output_and_eval_scores_it(world):
    routine = world["routine"]
    out_dir = world["root"] / "out"
    out = invoke("run", routine, "--out", out_dir, "--detector", world["models"] / "det.onnx",
                 "--pose-model", world["models"] / "pose.onnx", "--models", world["models"] / "models.yaml")
    assert "Time per stage" in out and "lift" in out
    for rel in ("detections/cam0.txt", "tracks_3d.csv", "target_3d.csv", "tracks_2d/cam3.txt", "target_2d/cam0.txt",
                "summary.json", "keypoints/cam0.json", "poses_3d.csv"):
        assert (out_dir / rel).exists(), rel
    assert len((out_dir / "poses_3d.csv").read_text().splitlines()) > 10
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
