"""ONNX Runtime sessions: execution providers, and the signature of a model file.

Paper: Section III-A (the person detector, YOLOX-S) and III-D (the top-down pose model, HRNet)
are models the paper runs; gymtrack runs user-supplied ONNX exports of such models. This module
opens them: the execution provider asked for (CPU by default, CUDA or TensorRT when installed),
the provider actually used (reported; a fall-back to CPU when a GPU was asked for is a warning,
microsoft/onnxruntime issues 7748, 23372), and a :class:`Signature` -- names, shapes and types of
the inputs and outputs -- which the adapters match against (``gymtrack models check``).
onnxruntime is the optional ``models`` extra and is imported lazily.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Sequence

from ..errors import GymtrackWarning, InputError

__all__ = ["DEVICES", "Tensor", "Signature", "Session", "import_ort", "open_session", "providers_for"]

#: ``--device`` choices -> the ONNX Runtime providers asked for, best first.
DEVICES: dict[str, tuple[str, ...]] = {
    "cpu": ("CPUExecutionProvider",),
    "cuda": ("CUDAExecutionProvider", "CPUExecutionProvider"),
    "tensorrt": ("TensorrtExecutionProvider", "CUDAExecutionProvider", "CPUExecutionProvider"),
    "auto": ("TensorrtExecutionProvider", "CUDAExecutionProvider", "CPUExecutionProvider"),
}

Dim = int | str | None  # a fixed size, or a symbolic/unknown one


@dataclass(frozen=True)
class Tensor:
    """One input or output: ``name``, ``shape`` (ints; a str or None for a dynamic dimension), ``dtype``."""

    name: str
    shape: tuple[Dim, ...]
    dtype: str = "float32"

    def dim(self, i: int) -> int | None:
        """Dimension ``i`` as an int, None when dynamic."""
        d = self.shape[i]
        return d if isinstance(d, int) and d > 0 else None

    def __str__(self) -> str:
        dims = ", ".join(str(d) if isinstance(d, int) and d > 0 else (d or "?") for d in self.shape)
        return f"{self.name} ({dims}) {self.dtype}"


@dataclass(frozen=True)
class Signature:
    """The inputs and outputs of a model, as :func:`open_session` or a test gives them."""

    inputs: tuple[Tensor, ...]
    outputs: tuple[Tensor, ...]

    def output(self, name: str) -> Tensor | None:
        return next((t for t in self.outputs if t.name == name), None)

    def image_input(self, input_size: Sequence[int] | None, path: str | Path) -> tuple[str, tuple[int, int], bool]:
        """The image input ``(N, 3, H, W)``: (name, (H, W), batched). A dynamic H or W takes
        ``input_size`` (models.yaml); ``batched`` is whether N is dynamic (several crops or
        cameras in one run)."""
        x = self.inputs[0]
        size = (x.dim(2), x.dim(3))
        if None in size:
            if input_size is None:
                raise InputError("the model's input size is dynamic: give input_size [H, W] in models.yaml", source=path)
            size = tuple(input_size)
        return x.name, (int(size[0]), int(size[1])), x.dim(0) is None


_ORT_TYPES = {"tensor(float)": "float32", "tensor(float16)": "float16", "tensor(double)": "float64",
              "tensor(int64)": "int64", "tensor(int32)": "int32", "tensor(uint8)": "uint8", "tensor(bool)": "bool"}


def _tensor(arg: Any) -> Tensor:
    shape = tuple(d if isinstance(d, int) else (d if isinstance(d, str) else None) for d in (arg.shape or ()))
    return Tensor(arg.name, shape, _ORT_TYPES.get(arg.type, arg.type))


def import_ort():
    """The ``onnxruntime`` module, or an InputError naming the extra to install."""
    try:
        import onnxruntime
    except ImportError:  # pragma: no cover - the extra is installed in CI
        raise InputError("running ONNX models needs the 'models' extra: pip install 'gymtrack[models]'") from None
    return onnxruntime


def providers_for(device: str, available: Sequence[str]) -> tuple[list[str], list[str]]:
    """(providers to ask for, wanted GPU providers that are not installed) for a ``--device``."""
    if device not in DEVICES:
        raise InputError(f"unknown device {device!r}; choose one of {', '.join(DEVICES)}", field="--device")
    wanted = DEVICES[device]
    use = [p for p in wanted if p in available] or ["CPUExecutionProvider"]
    missing = [p for p in wanted if p not in available and p != "CPUExecutionProvider"]
    if device == "auto":
        missing = []  # auto takes what there is
    return use, missing


@dataclass
class Session:
    """An open model: ``run(feeds)`` -> list of outputs; ``providers`` actually used; ``signature``."""

    path: Path
    session: Any
    signature: Signature
    providers: tuple[str, ...]
    fell_back: bool = False

    def run(self, feeds: dict) -> list:
        return self.session.run(None, feeds)

    @property
    def provider(self) -> str:
        """The provider that runs the model (the first one the session holds)."""
        return self.providers[0] if self.providers else "?"


def open_session(path: str | Path, device: str = "cpu", threads: int = 0) -> Session:
    """Open an ONNX model with ONNX Runtime on ``device`` (cpu | cuda | tensorrt | auto).

    Warns (:class:`~gymtrack.errors.GymtrackWarning`) when a GPU was asked for and the session runs on CPU instead; the
    providers actually used are in :attr:`Session.providers`. Raises InputError for a missing or
    unreadable file.
    """
    ort = import_ort()
    path = Path(path)
    if not path.is_file():
        raise InputError("model file not found (gymtrack downloads no weights: see docs/models.md)", source=path)
    use, missing = providers_for(device, ort.get_available_providers())
    opts = ort.SessionOptions()
    if threads:
        opts.intra_op_num_threads = int(threads)
    opts.log_severity_level = 3
    try:
        sess = ort.InferenceSession(str(path), sess_options=opts, providers=use)
    except Exception as exc:  # onnxruntime raises its own Fail/InvalidGraph/... types
        raise InputError(f"ONNX Runtime cannot load the model: {str(exc).splitlines()[0][:300]}", source=path) from None
    got = tuple(sess.get_providers())
    gpu_asked = device in ("cuda", "tensorrt")
    fell_back = gpu_asked and got[:1] == ("CPUExecutionProvider",)
    if missing or fell_back:
        warnings.warn(f"{path.name}: asked for {device} but {', '.join(missing) or 'the GPU provider'} is not available; "
                      f"running on {got[0] if got else 'CPU'} (install onnxruntime-gpu alone, not beside onnxruntime)",
                      GymtrackWarning, stacklevel=2)
    sig = Signature(tuple(_tensor(a) for a in sess.get_inputs()), tuple(_tensor(a) for a in sess.get_outputs()))
    return Session(path, sess, sig, got, fell_back or bool(missing))
