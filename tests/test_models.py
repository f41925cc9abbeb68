"""Model adapters on small ONNX graphs with the real exports' signatures: letterbox and inverse,
grid decoding, NMS, class filter, affine crops, SimCC and heatmap decoding back to raw pixels,
batching, execution providers, ``models check``."""

from __future__ import annotations

import warnings

import cv2
import numpy as np
import pytest

pytest.importorskip("onnxruntime")
pytest.importorskip("onnx")

from onnx_standins import affine_graph, code_pixel, lookup_graph, yolox_rows  # noqa: E402

from gymtrack.detections import Detections  # noqa: E402
from gymtrack.errors import GymtrackWarning, InputError  # noqa: E402
from gymtrack.models import Detector, DetectorOptions, PoseModel, PoseOptions, check_model, check_signature  # noqa: E402
from gymtrack.models.config import load_models_config  # noqa: E402
from gymtrack.models.image import affine_crops, box_to_centre_scale, crop_affines, letterbox, undo_affine  # noqa: E402
from gymtrack.models.runtime import Signature, Tensor, open_session, providers_for  # noqa: E402

FRAME = (1080, 1920)


def black(value: int = 0) -> np.ndarray:
    return np.full((*FRAME, 3), value, np.uint8)


# ------------------------------------------------------------------------------- letterbox
def test_letterbox_topleft_and_centre():
    img = np.zeros((1080, 1920, 3), np.uint8)
    img[540, 960] = 255
    c, lb = letterbox(img, (640, 640), "topleft")
    assert lb.scale == pytest.approx(1 / 3) and lb.pad == (0, 0)
    assert c.shape == (640, 640, 3) and (c[360:] == 114).all() and (c[:360] != 114).all()
    c, lb = letterbox(img, (640, 640), "centre")
    assert lb.pad == (0, 140) and (c[:140] == 114).all() and (c[500:] == 114).all() and (c[140:500] == 0).all()
    # inverse: raw (960, 540) -> input (320, 320) -> back
    assert np.allclose(lb.to_input([960, 540]), [320, 320])
    assert np.allclose(lb.to_image(lb.to_input([[1, 2, 3, 4]])), [[1, 2, 3, 4]])


# ------------------------------------------------------------------------------- detectors
def _yolox_model(tmp_path, batch="batch"):
    # raw (960, 540, 300, 600) -> input (320, 180, 100, 200) at r = 1/3 (top-left letterbox)
    boxes = np.array([[320, 180, 100, 200],     # the person, score 0.9 * 0.9
                      [322, 182, 100, 200],     # a duplicate, lower score: NMS removes it
                      [100, 100, 50, 50],       # a car (class 2): class filter removes it
                      [500, 300, 40, 80]])      # a person below the score threshold
    rows = yolox_rows((640, 640), boxes, np.array([0.9, 0.5, 0.95, 0.2]), n_classes=80, classes=np.array([0, 0, 2, 0]))
    rows[:, 4] = np.where(rows[:, 4] > 0, 0.9, 0)
    C = rows[None]
    # batch item b with a bright pixel (max 255) adds a second person at input (480, 400, 64, 128)
    extra = yolox_rows((640, 640), np.array([[480, 400, 64, 128]]), np.array([1.0]), n_classes=80)
    D = (extra / 255.0)[None]
    return affine_graph(tmp_path / "yolox.onnx", [batch, 3, 640, 640], [("output", C, D)])


def test_yolox_raw_grid_nms_class_and_batch(tmp_path):
    det = Detector(_yolox_model(tmp_path))
    assert det.kind == "yolox" and det.batched and det.provider == "CPUExecutionProvider"
    bright = black()
    bright[1000, 1900] = 255  # max 255 -> the second person appears
    (b0, s0), (b1, s1) = det.detect([black(), bright])
    assert np.allclose(b0, [[810, 240, 1110, 840]], atol=1e-3) and np.allclose(s0, [0.81])
    # the dark frame's max is the padding, 114: its second person scores (114/255)^2 = 0.2 < 0.3
    assert len(b1) == 2 and np.allclose(b1[0], [1344, 1008, 1536, 1080], atol=1e-3)  # clipped at the bottom
    assert np.allclose(b1[1], b0[0]) and np.allclose(s1, [1.0, 0.81])  # by decreasing score


def test_yolox_fixed_batch_runs_one_by_one(tmp_path):
    det = Detector(_yolox_model(tmp_path, batch=1))
    assert not det.batched
    out = det.detect([black(), black(), black()])
    assert [len(b) for b, _ in out] == [1, 1, 1]


def test_yolov8_centred_letterbox(tmp_path):
    N = 8400
    C = np.zeros((1, 84, N), np.float32)
    C[0, :4, 10] = [320, 320, 100, 200]     # person in input pixels: centred letterbox pads 140 at the top
    C[0, 4, 10] = 0.8
    C[0, :4, 11] = [300, 300, 100, 200]     # a dog, filtered
    C[0, 4 + 16, 11] = 0.9
    path = affine_graph(tmp_path / "v8.onnx", [1, 3, 640, 640], [("output0", C, np.zeros_like(C))])
    det = Detector(path)
    assert det.kind == "yolov8" and det.options.letterbox == "centre" and det.options.rgb
    (b, s), = det.detect([black()])
    assert np.allclose(b, [[810, 240, 1110, 840]], atol=1e-3) and np.allclose(s, [0.8])


def test_yolox_with_nms_in_graph(tmp_path):
    dets = np.zeros((1, 100, 5), np.float32)
    labels = np.full((1, 100), -1, np.float32)
    dets[0, 0] = [270, 80, 370, 280, 0.7]
    labels[0, 0] = 0
    dets[0, 1] = [10, 10, 20, 20, 0.9]
    labels[0, 1] = 3
    path = affine_graph(tmp_path / "nms.onnx", ["batch", 3, 640, 640],
                        [("dets", dets, np.zeros_like(dets)), ("labels", labels, np.zeros_like(labels))], input_name="input")
    det = Detector(path)
    assert det.kind == "yolox_nms"
    (b, s), = det.detect([black()])
    assert np.allclose(b, [[810, 240, 1110, 840]], atol=1e-3) and np.allclose(s, [0.7])


def test_dynamic_input_size_must_match_the_grid(tmp_path):
    rows = np.zeros((1, 336, 6), np.float32)  # a 128 x 128 grid
    path = affine_graph(tmp_path / "dyn.onnx", ["batch", 3, "h", "w"], [("output", rows, rows)])
    with pytest.raises(InputError, match="input_size"):
        Detector(path)
    assert len(Detector(path, DetectorOptions(input_size=(128, 128))).detect([black()])[0][0]) == 0
    with pytest.raises(InputError, match="336 rows for a 64x64 input.*84"):
        Detector(path, DetectorOptions(input_size=(64, 64))).detect([black()])


def test_detector_refuses_a_pose_model(tmp_path):
    sx = np.zeros((1, 17, 384), np.float32)
    sy = np.zeros((1, 17, 512), np.float32)
    path = affine_graph(tmp_path / "p.onnx", ["batch", 3, 256, 192], [("simcc_x", sx, sx), ("simcc_y", sy, sy)])
    with pytest.raises(InputError, match="not a detector.*p.onnx|p.onnx.*not a detector"):
        Detector(path)


def test_lookup_standin_reads_the_frame_code(tmp_path):
    table = np.zeros((4, 336, 6), np.float32)
    for f in range(4):
        table[f] = yolox_rows((128, 128), np.array([[20 + 10 * f, 40, 16, 32]]), np.array([1.0]))
    det = Detector(lookup_graph(tmp_path / "l.onnx", ["batch", 3, 128, 128], [("output", table)]))
    imgs = []
    for f in (3, 1):  # frame codes drawn in the top-left corner
        im = black()
        im[:32, :32] = code_pixel(f)
        imgs.append(im)
    (b3, _), (b1, _) = det.detect(imgs)
    r = 128 / 1920
    assert np.allclose(b3, [[(50 - 8) / r, (40 - 16) / r, (50 + 8) / r, (40 + 16) / r]], atol=1e-2)
    assert np.allclose(b1[0, 0], (30 - 8) / r, atol=1e-2)


# ------------------------------------------------------------------------------- crops and pose
def test_affine_crop_matches_a_hand_worked_mapping():
    c, s = box_to_centre_scale(np.array([[800, 300, 150, 400]]), 192 / 256, 1.25)
    assert np.allclose(c, [[875, 500]]) and np.allclose(s, [[375, 500]])
    M = crop_affines(c, s, (256, 192))
    assert np.allclose(M[0], [[0.512, 0, 96 - 0.512 * 875], [0, 0.512, 128 - 0.512 * 500]])
    assert np.allclose(undo_affine(np.array([[[96, 128], [0, 0]]]), M), [[[875, 500], [687.5, 250]]])
    img = np.zeros((1080, 1920, 3), np.uint8)
    img[480:520, 855:895] = (0, 0, 255)  # a red square around the box centre
    crop = affine_crops([img], np.array([0]), M, (256, 192))[0]
    assert tuple(crop[128, 96]) == (0, 0, 255) and tuple(crop[5, 5]) == (0, 0, 0)
    # against OpenCV: the same crop as resizing the (375 x 500) region around the centre
    region = img[250:750, 875 - 187:875 + 188]
    ref = cv2.resize(region, (192, 256), interpolation=cv2.INTER_AREA)
    assert np.abs(crop.astype(int) - ref.astype(int)).mean() < 3


def _simcc(tmp_path, batch="batch"):
    sx = np.zeros((1, 17, 384), np.float32)
    sy = np.zeros((1, 17, 512), np.float32)
    sx[0, :, 192], sy[0, :, 256] = 0.9, 0.7          # every joint at the crop centre (96, 128)
    sx[0, 0, 192], sx[0, 0, 0], sy[0, 0, 0] = 0, 0.95, 0.95  # the nose at the crop's top-left (0, 0)
    dx = np.zeros_like(sx)
    dx[0, 1, 200] = 1.0  # a bright input moves the left eye to x bin 200 (crop x 100)
    return affine_graph(tmp_path / "rtm.onnx", [batch, 3, 256, 192], [("simcc_x", sx, dx), ("simcc_y", sy, np.zeros_like(sy))],
                        input_name="input")


def test_simcc_decoding_back_to_raw_pixels_batched(tmp_path):
    pm = PoseModel(_simcc(tmp_path), PoseOptions(rgb=False))
    assert pm.kind == "simcc" and pm.skeleton.name == "coco17" and pm.batched
    bright = black()
    bright[500, 875] = 255
    boxes = Detections.from_arrays([7, 7], [0, 1], np.array([[875, 500, 150, 400], [875, 500, 150, 400]]), ("a", "b"),
                                   track_id=[3, 3])
    p = pm.estimate(7, [black(), bright], boxes)
    assert p.frame.tolist() == [7, 7] and p.track_id.tolist() == [3, 3]
    k = p.keypoints
    assert np.allclose(k[:, 5:, :2], [875, 500]) and np.allclose(k[:, 5:, 2], 0.7)  # min of the two maxima
    assert np.allclose(k[:, 0], [[687.5, 250, 0.95]] * 2)
    # the largest normalised input value: bright (255 - 123.675) / 58.395 = 2.25 > 0.9, so bin 200 wins;
    # black -103.53 / 57.375 = -1.8
    assert np.allclose(k[0, 1, 0], 875) and np.allclose(k[1, 1, 0], 875 + 4 / 0.512)
    assert np.allclose(p.bbox, [[800, 300, 150, 400]] * 2)


def test_heatmap_subpixel_refinement(tmp_path):
    hm = np.zeros((1, 17, 64, 48), np.float32)
    hm[0, :, 32, 24] = 1.0
    hm[0, :, 32, 25] = 0.5   # right neighbour higher than the left: +1/4 heatmap pixel
    hm[0, :, 31, 24] = 0.3   # upper neighbour higher than the lower: -1/4
    path = affine_graph(tmp_path / "hrnet.onnx", [1, 3, 256, 192], [("output", hm, np.zeros_like(hm))], input_name="input")
    pm = PoseModel(path)
    assert pm.kind == "heatmap" and not pm.batched
    boxes = Detections.from_arrays([1, 1], [0, 0], np.array([[875, 500, 150, 400], [100, 100, 30, 40]]), ("a",))
    k = pm.estimate(1, [black()], boxes).keypoints
    # crop (24.25 * 4, 31.75 * 4) = (97, 127) -> raw 875 + 1 / 0.512, 500 - 1 / 0.512
    assert np.allclose(k[0, :, :2], [875 + 1 / 0.512, 500 - 1 / 0.512]) and np.allclose(k[0, :, 2], 1.0)
    assert np.allclose(k[1, 0, :2], [100 + 1 / (192 / 37.5), 100 - 1 / (192 / 37.5)])


# ------------------------------------------------------------------------------- signatures, providers, config
def sig(inputs, outputs) -> Signature:
    return Signature(tuple(Tensor(n, tuple(s)) for n, s in inputs), tuple(Tensor(n, tuple(s)) for n, s in outputs))


PUBLIC = {  # the exports docs/models.md lists, by their published signatures
    "yolox_s (Megvii, 640)": (sig([("images", [1, 3, 640, 640])], [("output", [1, 8400, 85])]), "detector", "yolox"),
    "yolox_m rtmlib humanart (640)": (sig([("input", [1, 3, 640, 640])], [("dets", [1, "N", 5]), ("labels", [1, "N"])]),
                                      "detector", "yolox_nms"),
    "yolov8n / yolo11n (ultralytics, 640)": (sig([("images", [1, 3, 640, 640])], [("output0", [1, 84, 8400])]),
                                              "detector", "yolov8"),
    "yolox_s at 608": (sig([("images", [1, 3, 608, 608])], [("output", [1, 7581, 85])]), "detector", "yolox"),
    "rtmpose-m body7 (256x192)": (sig([("input", ["batch", 3, 256, 192])], [("simcc_x", ["batch", 17, 384]),
                                                                            ("simcc_y", ["batch", 17, 512])]), "pose", "simcc"),
    "hrnet-w32 / vitpose-b (256x192)": (sig([("input", [1, 3, 256, 192])], [("output", [1, 17, 64, 48])]), "pose", "heatmap"),
}


@pytest.mark.parametrize("name", list(PUBLIC))
def test_public_signatures_fit(name):
    s, role, kind = PUBLIC[name]
    c = check_signature(s)
    assert (c.role, c.kind) == (role, kind), c.reason


def test_signatures_that_fit_nothing():
    c = check_signature(sig([("images", [1, 3, 640, 640])], [("output", [1, 1000])]))
    assert not c.fits and "detector" in c.reason and "pose" in c.reason
    c = check_signature(sig([("images", [1, 3, 640, 640])], [("output", [1, 8000, 85])]))
    assert not c.fits and "8400" in c.reason
    c = check_signature(sig([("input", [1, 3, 256, 192])], [("output", [1, 17, 60, 48])]))
    assert not c.fits and "stride" in c.reason


def test_check_model_file(tmp_path):
    c = check_model(_simcc(tmp_path))
    assert c.role == "pose" and c.kind == "simcc" and c.signature.inputs[0].shape == ("batch", 3, 256, 192)
    with pytest.raises(InputError, match="not found"):
        check_model(tmp_path / "none.onnx")
    (tmp_path / "bad.onnx").write_bytes(b"not a model")
    with pytest.raises(InputError, match="bad.onnx.*cannot load"):
        check_model(tmp_path / "bad.onnx")


def test_providers_and_gpu_fallback_warning(tmp_path):
    assert providers_for("cpu", ["CPUExecutionProvider"]) == (["CPUExecutionProvider"], [])
    assert providers_for("cuda", ["CUDAExecutionProvider", "CPUExecutionProvider"])[1] == []
    assert providers_for("cuda", ["CPUExecutionProvider"]) == (["CPUExecutionProvider"], ["CUDAExecutionProvider"])
    assert providers_for("tensorrt", ["CUDAExecutionProvider", "CPUExecutionProvider"]) == (
        ["CUDAExecutionProvider", "CPUExecutionProvider"], ["TensorrtExecutionProvider"])
    assert providers_for("auto", ["CPUExecutionProvider"]) == (["CPUExecutionProvider"], [])
    with pytest.raises(InputError, match="--device"):
        providers_for("tpu", [])
    import onnxruntime

    path = _simcc(tmp_path)
    if "CUDAExecutionProvider" not in onnxruntime.get_available_providers():
        with pytest.warns(GymtrackWarning, match="asked for cuda.*CPU"):
            s = open_session(path, "cuda")
        assert s.provider == "CPUExecutionProvider" and s.fell_back
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert not open_session(path, "cpu").fell_back


def test_models_yaml(tmp_path):
    (tmp_path / "models.yaml").write_text("detector:\n  path: det.onnx\n  score_threshold: 0.5\n"
                                          "pose:\n  path: /abs/pose.onnx\n  rgb: false\ndevice: cuda\n")
    cfg = load_models_config(tmp_path / "models.yaml")
    assert cfg.detector.path == tmp_path / "det.onnx" and str(cfg.pose.path) == "/abs/pose.onnx"
    assert cfg.detector.options().score_threshold == 0.5 and cfg.pose.options().rgb is False and cfg.device == "cuda"
    (tmp_path / "bad.yaml").write_text("detector:\n  nms: 0.5\n")
    with pytest.raises(InputError, match="bad.yaml.*detector.nms"):
        load_models_config(tmp_path / "bad.yaml")


def test_to_blob_normalises_and_swaps_channels():
    from gymtrack.models.image import to_blob

    batch = np.random.default_rng(0).integers(0, 256, (2, 5, 7, 3), dtype=np.uint8)
    mean, std = (123.675, 116.28, 103.53), (58.395, 57.12, 57.375)
    want = ((batch[..., ::-1].astype(np.float64) - mean) / std).transpose(0, 3, 1, 2)
    assert np.allclose(to_blob(batch, rgb=True, mean=mean, std=std), want, atol=1e-5)
    assert np.array_equal(to_blob(batch), batch.transpose(0, 3, 1, 2).astype(np.float32))
    assert np.allclose(to_blob(batch, rgb=True, scale=1 / 255), batch[..., ::-1].transpose(0, 3, 1, 2) / 255, atol=1e-6)


def test_docs_list_the_exports_whose_signatures_are_checked():
    from pathlib import Path

    doc = (Path(__file__).resolve().parents[1] / "docs" / "models.md").read_text()
    for name in ("YOLOX-S", "YOLOX-m Human-Art", "YOLO11", "RTMPose", "HRNet-W32", "ViTPose"):
        assert name in doc, name
    for adapter in ("yolox", "yolox_nms", "yolov8", "simcc", "heatmap"):
        assert f"| `{adapter}` |" in doc, adapter
