"""``models.yaml`` (model paths and adapter options) and ``gymtrack models check`` (which adapter fits).

Paper: Section III-A (detector) and III-D (top-down pose model) -- the two models the pipeline
runs. gymtrack ships and downloads no weights: the user names the exports in ``models.yaml`` or
as options; this module validates that file and says which adapter a model file fits, or why none.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Literal, Optional

from pydantic import BaseModel, ConfigDict, Field, ValidationError

from ..errors import InputError
from .detector import DetectorOptions, fit_detector
from .pose import PoseOptions, fit_pose
from .runtime import Signature

__all__ = ["DetectorEntry", "PoseEntry", "ModelsConfig", "load_models_config", "ModelCheck", "check_signature",
           "check_model"]


class _Strict(BaseModel):
    model_config = ConfigDict(extra="forbid")


class DetectorEntry(_Strict):
    path: Optional[Path] = None
    kind: Optional[Literal["yolox", "yolox_nms", "yolov8"]] = None
    input_size: Optional[tuple[int, int]] = None
    letterbox: Optional[Literal["topleft", "centre"]] = None
    rgb: Optional[bool] = None
    scale: Optional[float] = Field(None, gt=0)
    score_threshold: float = Field(0.3, ge=0, le=1)
    nms_threshold: float = Field(0.45, gt=0, le=1)
    person_class: int = Field(0, ge=0)

    def options(self) -> DetectorOptions:
        d = self.model_dump(exclude={"path"})
        return DetectorOptions(**d)


class PoseEntry(_Strict):
    path: Optional[Path] = None
    kind: Optional[Literal["simcc", "heatmap"]] = None
    input_size: Optional[tuple[int, int]] = None
    rgb: bool = True
    mean: tuple[float, float, float] = PoseOptions.mean
    std: tuple[float, float, float] = PoseOptions.std
    padding: float = Field(1.25, ge=1.0)
    split_ratio: Optional[float] = Field(None, gt=0)
    skeleton: Optional[str] = None

    def options(self) -> PoseOptions:
        return PoseOptions(**self.model_dump(exclude={"path"}))


class ModelsConfig(_Strict):
    """What ``models.yaml`` holds: ``detector``, ``pose`` (paths relative to the file), ``device``."""

    detector: DetectorEntry = DetectorEntry()
    pose: PoseEntry = PoseEntry()
    device: Literal["cpu", "cuda", "tensorrt", "auto"] = "cpu"


def load_models_config(path: str | Path | None) -> ModelsConfig:
    """Read ``models.yaml`` (None: the defaults); errors name the file and the field."""
    import yaml

    if path is None:
        return ModelsConfig()
    path = Path(path)
    if not path.is_file():
        raise InputError("models.yaml not found", source=path)
    try:
        data = yaml.safe_load(path.read_text()) or {}
    except yaml.YAMLError as exc:
        raise InputError(f"not valid YAML: {getattr(exc, 'problem', exc)}", source=path) from None
    if not isinstance(data, dict):
        raise InputError("expected a mapping with detector:, pose:, device:", source=path)
    try:
        cfg = ModelsConfig.model_validate(data)
    except ValidationError as exc:
        e = exc.errors()[0]
        raise InputError(e["msg"], source=path, field=".".join(str(p) for p in e["loc"])) from None
    for entry in (cfg.detector, cfg.pose):
        if entry.path is not None and not entry.path.is_absolute():
            entry.path = path.parent / entry.path
    return cfg


@dataclass(frozen=True)
class ModelCheck:
    """What ``gymtrack models check`` reports: the signature, the adapter that fits (role, kind) and why."""

    signature: Signature
    role: str | None     # "detector" | "pose" | None
    kind: str | None
    reason: str
    detector_reason: str
    pose_reason: str

    @property
    def fits(self) -> bool:
        return self.role is not None


def check_signature(sig: Signature) -> ModelCheck:
    """Match a signature against every adapter; the detector adapters first."""
    dk, dwhy = fit_detector(sig)
    pk, pwhy = fit_pose(sig)
    if dk is not None:
        return ModelCheck(sig, "detector", dk, dwhy, dwhy, pwhy)
    if pk is not None:
        return ModelCheck(sig, "pose", pk, pwhy, dwhy, pwhy)
    return ModelCheck(sig, None, None, f"no adapter fits. As a detector: {dwhy}. As a pose model: {pwhy}.", dwhy, pwhy)


def check_model(path: str | Path) -> ModelCheck:
    """Open ``path`` with ONNX Runtime (CPU) and match its signature."""
    from .runtime import open_session

    return check_signature(open_session(path, "cpu").signature)
