"""Exports: the 3D skeleton and the joint angles in the files biomechanists and animators open.

Rule: ``shared/formats.md``, "Exports" (the paper's 3D pose, Section III-D last paragraph, and the
analysis stage's angles). One module per format -- :mod:`~gymtrack.export.trc` (OpenSim markers),
:mod:`~gymtrack.export.c3d` (C3D points, ``ezc3d``), :mod:`~gymtrack.export.mot` (OpenSim motion of
the angles), :mod:`~gymtrack.export.bvh` (a fixed-bone-length rig) -- the gap rule shared by TRC and
BVH in :mod:`~gymtrack.export.series`, and the command's work in :mod:`~gymtrack.export.output`.
"""

from .output import FORMATS, ExportResult, export_output, resolve_fps

__all__ = ["FORMATS", "ExportResult", "export_output", "resolve_fps"]
