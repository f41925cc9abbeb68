"""Small ONNX graphs with the signatures of real detector and pose exports (tests and benchmarks).

Built with ``onnx.helper``; outputs are chosen by the caller so the right boxes and keypoints are
known. Two kinds:

* :func:`affine_graph`: every output is ``C + D * max(x_b)`` (``C``, ``D`` constants of the output's
  shape with batch 1; ``max(x_b)`` the largest input value of batch item b), so a test controls
  what each image of a batch gives by its brightest pixel.
* :func:`lookup_graph`: an "oracle" stand-in -- the output of batch item b is ``table[code_b]``, where
  ``code_b`` is read from the colour of the input's top-left pixel (:func:`code_pixel`; tests draw
  a (camera, frame) code there), so a stand-in detector returns known boxes per frame and view.
* :func:`template_pose_graph`: a SimCC stand-in whose joints sit at fixed places in the crop.
"""

from __future__ import annotations

from pathlib import Path
from typing import Sequence

import numpy as np

onnx = __import__("pytest").importorskip("onnx")
from onnx import TensorProto, helper, numpy_helper  # noqa: E402

OPSET = 17


def _save(path: Path, nodes, inputs, outputs, inits) -> Path:
    g = helper.make_graph(nodes, "standin", inputs, outputs, inits)
    m = helper.make_model(g, opset_imports=[helper.make_operatorsetid("", OPSET)], producer_name="gymtrack-tests")
    m.ir_version = 8
    onnx.checker.check_model(m)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    onnx.save(m, str(path))
    return path


def _vi(name: str, shape: Sequence) -> "onnx.ValueInfoProto":
    return helper.make_tensor_value_info(name, TensorProto.FLOAT, list(shape))


def affine_graph(path, input_shape: Sequence, outputs: Sequence[tuple[str, np.ndarray, np.ndarray]],
                 input_name: str = "images") -> Path:
    """``outputs``: (name, C, D) with C, D float arrays of shape (1, ...); output = C + D * max(x_b).

    ``input_shape[0]`` "batch" makes the batch dimension dynamic (outputs follow it), 1 fixes it.
    """
    nodes = [helper.make_node("ReduceMax", ["x_in"], ["mx"], axes=[1, 2, 3], keepdims=1)]
    inits, outs = [], []
    for name, C, D in outputs:
        C = np.asarray(C, np.float32)
        D = np.asarray(D, np.float32)
        rank = C.ndim
        inits += [numpy_helper.from_array(C, f"{name}_C"), numpy_helper.from_array(D, f"{name}_D"),
                  numpy_helper.from_array(np.array([-1] + [1] * (rank - 1), np.int64), f"{name}_shape")]
        nodes += [helper.make_node("Reshape", ["mx", f"{name}_shape"], [f"{name}_m"]),
                  helper.make_node("Mul", [f"{name}_D", f"{name}_m"], [f"{name}_dm"]),
                  helper.make_node("Add", [f"{name}_C", f"{name}_dm"], [name])]
        outs.append(_vi(name, [input_shape[0], *C.shape[1:]]))
    nodes = [helper.make_node("Identity", [input_name], ["x_in"])] + nodes
    return _save(path, nodes, [_vi(input_name, input_shape)], outs, inits)


QUANTUM, BASE = 16, 16  # a code digit d is drawn as the level 16 d (0..240): H.264 moves it by up to 4


def code_pixel(code: int) -> tuple[int, int, int]:
    """The (B, G, R) colour :func:`lookup_graph` reads as ``code`` (0 <= code < 4096)."""
    return tuple(QUANTUM * ((int(code) // BASE ** i) % BASE) for i in range(3))  # type: ignore[return-value]


def lookup_graph(path, input_shape: Sequence, tables: Sequence[tuple[str, np.ndarray]], input_name: str = "images"
                 ) -> Path:
    """``tables``: (name, T) with T (F, ...); output ``name`` of batch item b is ``T[code_b]``."""
    arr = numpy_helper.from_array
    inits = [arr(np.array([0, 0, 0], np.int64), "starts"), arr(np.array([3, 1, 1], np.int64), "ends"),
             arr(np.array([1, 2, 3], np.int64), "axes"), arr(np.array([-1, 3], np.int64), "shape3"),
             arr(np.array([1.0 / QUANTUM] * 3, np.float32), "inv_q"),
             arr(np.array([1.0, BASE, BASE * BASE], np.float32), "weights"), arr(np.array([1], np.int64), "axis1")]
    nodes = [
        helper.make_node("Slice", [input_name, "starts", "ends", "axes"], ["px"]),  # x[:, 0:3, 0:1, 0:1]
        helper.make_node("Reshape", ["px", "shape3"], ["bgr"]),                     # (B, 3)
        helper.make_node("Mul", ["bgr", "inv_q"], ["digits_f"]),
        helper.make_node("Round", ["digits_f"], ["digits"]),
        helper.make_node("Mul", ["digits", "weights"], ["weighted"]),
        helper.make_node("ReduceSum", ["weighted", "axis1"], ["codef"], keepdims=0),  # (B,)
        helper.make_node("Cast", ["codef"], ["code"], to=TensorProto.INT64),
    ]
    outs = []
    for name, T in tables:
        T = np.asarray(T, np.float32)
        inits.append(numpy_helper.from_array(T, f"{name}_T"))
        nodes.append(helper.make_node("Gather", [f"{name}_T", "code"], [name], axis=0))
        outs.append(_vi(name, [input_shape[0], *T.shape[1:]]))
    return _save(path, nodes, [_vi(input_name, input_shape)], outs, inits)


def yolox_rows(size: tuple[int, int], boxes_cxcywh: np.ndarray, scores: np.ndarray, n_classes: int = 1,
               classes: np.ndarray | None = None, strides=(8, 16, 32)) -> np.ndarray:
    """(N, 5 + C) raw-head rows (YOLOX layout) holding ``boxes`` (input pixels) at the anchor of their
    centre (stride 8; the next stride, then any free anchor, when taken: the decoding
    ``(x + gx) s`` reaches any point from any anchor); every other row has score 0."""
    from gymtrack.models.detector import grid_points

    grid, stride = grid_points(size, strides)
    rows = np.zeros((len(grid), 5 + n_classes), np.float32)
    rows[:, 2:4] = 0.0
    taken: set[int] = set()
    offsets = np.cumsum([0] + [(size[0] // s) * (size[1] // s) for s in strides])
    for k, (b, sc) in enumerate(zip(np.asarray(boxes_cxcywh, np.float64), scores)):
        for si, s in enumerate(strides):
            gx, gy = int(b[0] // s), int(b[1] // s)
            gw = size[1] // s
            if not (0 <= gx < gw and 0 <= gy < size[0] // s):
                continue
            i = int(offsets[si] + gy * gw + gx)
            if i not in taken:
                break
        else:
            i = next(j for j in range(len(grid)) if j not in taken)
            gx, gy, s = int(grid[i, 0]), int(grid[i, 1]), float(stride[i])
        taken.add(i)
        rows[i, 0:2] = b[:2] / s - (gx, gy)
        rows[i, 2:4] = np.log(np.maximum(b[2:4], 1e-3) / s)
        rows[i, 4] = 1.0
        rows[i, 5 + (0 if classes is None else int(classes[k]))] = sc
    return rows


def template_pose_graph(path, n_joints: int = 17, size=(256, 192), ratio: float = 2.0,
                        template: np.ndarray | None = None) -> Path:
    """A SimCC stand-in (``simcc_x`` (N, K, W r), ``simcc_y`` (N, K, H r), dynamic batch): joint k at
    ``template[k]`` (crop pixels; default a standing figure filling the middle of the crop)."""
    H, W = size
    if template is None:
        t = np.linspace(0.2, 0.8, n_joints)
        template = np.column_stack([W * (0.45 + 0.1 * (np.arange(n_joints) % 2)), H * t])
    sx = np.zeros((1, n_joints, int(W * ratio)), np.float32)
    sy = np.zeros((1, n_joints, int(H * ratio)), np.float32)
    for k, (x, y) in enumerate(template):
        sx[0, k, int(round(x * ratio))] = 0.9
        sy[0, k, int(round(y * ratio))] = 0.8
    z = np.zeros_like
    return affine_graph(path, ["batch", 3, H, W], [("simcc_x", sx, z(sx)), ("simcc_y", sy, z(sy))], input_name="input")
