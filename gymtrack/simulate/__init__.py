"""Simulated gymnastics routines with ground truth (the paper's data is private).

Paper: Section IV-A (seven apparatus, four cameras, ``n_cam`` = 2, 3, 4 valid views) and the
failure case of Sections I and III-C: long stretches where only two opposite views detect the
gymnast, whose box centres are *different* 3D points, so triangulating them is biased along the
line between the cameras.

Modules: :mod:`.venue` (cameras), :mod:`.body` (COCO-17 skeleton, postures, 3D extent),
:mod:`.motion` (phase builder with exact ballistic flights), :mod:`.skills` (the target's
routine per apparatus), :mod:`.people` (coaches, judges, background), :mod:`.detector` (true
boxes and the detector model), :mod:`.routine` (orchestration and files), :mod:`.suite` (suites
of routines), :mod:`.plot`, :mod:`.pose_model` (a top-down 2D pose model run on a method's
boxes; geometry in :mod:`.pose_view`), :mod:`.render` (every view rendered as video frames),
:mod:`.crowd` (a routine plus a group standing within arm's reach).

Use :func:`simulate_routine` (in memory, optionally written), :func:`simulate_n_cams` (one
performance with n_cam = 2, 3, 4) or :func:`simulate_suite`; the
``gymtrack simulate`` / ``gymtrack simulate-suite`` commands wrap them.
"""

from .detector import DetectorParams
from .pose_model import PoseModelParams, simulate_pose_model, simulate_pose_model_for_routine
from .routine import (
    DEFAULT_SECONDS,
    MIN_SECONDS,
    TARGET_ID,
    SimulatedRoutine,
    simulate_n_cams,
    simulate_routine,
)
from .suite import routine_seed, simulate_suite

__all__ = [
    "DEFAULT_SECONDS",
    "MIN_SECONDS",
    "TARGET_ID",
    "DetectorParams",
    "PoseModelParams",
    "SimulatedRoutine",
    "routine_seed",
    "simulate_n_cams",
    "simulate_pose_model",
    "simulate_pose_model_for_routine",
    "simulate_routine",
    "simulate_suite",
]
