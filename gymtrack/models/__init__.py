"""Model adapters on ONNX Runtime: person detectors and top-down pose models.

Paper: Section III-A (a person detector -- YOLOX-S in the paper -- on every frame of every view)
and Section III-D (a top-down pose model -- HRNet -- on high-resolution crops of ``b_buf``).
gymtrack runs ONNX exports the user supplies (``docs/models.md``: which public exports fit, no
weights shipped or downloaded):

* :mod:`.runtime`  sessions, execution providers (CPU default, CUDA/TensorRT), model signatures
* :mod:`.image`    letterbox and its inverse, affine crops of boxes and their inverse
* :mod:`.detector` YOLOX (raw grid, NMS in the graph), YOLOv8/YOLO11 -> boxes in raw pixels
* :mod:`.pose`     SimCC (RTMPose) and heatmap (HRNet, ViTPose) heads -> :class:`gymtrack.poses.Poses2D`
* :mod:`.config`   ``models.yaml`` and ``gymtrack models check``
* :mod:`.pipeline` the models over a routine's videos

Layer: beside :mod:`gymtrack.pose` (uses formats, geometry and core; the CLI uses it).
onnxruntime (the ``models`` extra) and PyAV (``video``) are imported only when a model or video
is opened.
"""

from .config import ModelCheck, ModelsConfig, check_model, check_signature, load_models_config
from .detector import Detector, DetectorOptions
from .pipeline import detect_videos, pose_videos
from .pose import PoseModel, PoseOptions
from .runtime import Signature, Tensor, open_session

__all__ = ["Detector", "DetectorOptions", "PoseModel", "PoseOptions", "ModelsConfig", "ModelCheck", "Signature",
           "Tensor", "check_model", "check_signature", "load_models_config", "open_session", "detect_videos",
           "pose_videos"]
