"""Where the pose stage's 2D keypoints come from, for one routine.

Paper: Section III-D, last paragraph -- a top-down pose model runs in the target's expanded boxes
``b_buf``. A routine either brings the model's output (``<routine>/keypoints/<camera>.json``,
any model) or, when simulated (``gt/keypoints_3d.csv``), the simulated pose model
(:mod:`gymtrack.simulate.pose_model`) runs on the tracker's boxes. Shared by ``gymtrack pose``
and the batch runner (:mod:`gymtrack.batch`), so both lift the same poses.
"""

from __future__ import annotations

from pathlib import Path

from ..errors import InputError

__all__ = ["simulated_model_poses", "routine_poses"]


def simulated_model_poses(routine, result, all_tracks: bool = False, seed: int = 0):
    """Run the simulated pose model on the track outputs' boxes of a simulated routine.

    routine: a :class:`~gymtrack.formats.routine.Routine`; result: its TrackResult. The target's
    b_buf boxes; with ``all_tracks`` also every track's per-view box where the target has no b_buf
    (same frame, view and track). Returns a Poses2D (track ids set; keypoints (N, 17, 3)).
    """
    from ..formats.gt_keypoints import read_keypoints_3d
    from ..simulate.pose_model import simulate_pose_model
    from .stage import pose_model_boxes

    path = routine.gt.get("keypoints_3d")
    if path is None:
        raise InputError("--simulated-model needs a simulated routine with gt/keypoints_3d.csv",
                         source=Path(routine.path) / "gt" / "keypoints_3d.csv")
    frames, person_id, joints = read_keypoints_3d(path)
    boxes = pose_model_boxes(result, all_tracks)
    return simulate_pose_model(routine.rig, joints, person_id, frames, boxes, seed=seed)


def routine_poses(routine, result, keypoints: str | Path | None = None, simulated_model: bool | None = None,
                  all_tracks: bool = False, seed: int = 0, skeleton=None, report=None):
    """The 2D poses of a routine: from ``keypoints`` (default the routine's ``keypoints/`` or
    Pose2Sim ``pose/`` folder; the poses the routine already read when it made its boxes from them)
    or the simulated model. ``skeleton``: the poses' joint order (default: recognised);
    ``report``: a :class:`~gymtrack.formats.keypoints.KeypointsReport` to fill in.

    simulated_model: True forces the simulated model, False forbids it, None (the batch's choice)
    uses ``<routine>/keypoints/`` when it exists, else the simulated model when the routine has
    ``gt/keypoints_3d.csv``. Raises :class:`InputError` naming the folder when there are no poses.
    """
    from ..formats.keypoints import read_keypoints

    if simulated_model and keypoints is not None:
        raise InputError("give either --keypoints or --simulated-model, not both", field="--keypoints")
    default = getattr(routine, "keypoints_path", None) or Path(routine.path) / "keypoints"
    kdir = Path(keypoints) if keypoints is not None else Path(default)
    if simulated_model is None:
        simulated_model = keypoints is None and not kdir.exists() and routine.gt.get("keypoints_3d") is not None
    if simulated_model:
        return simulated_model_poses(routine, result, all_tracks, seed)
    if not kdir.exists():
        raise InputError("no 2D keypoints: add ROUTINE/keypoints/<camera>.json (or Pose2Sim's pose/), give --keypoints DIR, "
                         "or use --simulated-model on a simulated routine", source=kdir)
    if getattr(routine, "poses", None) is not None and kdir == getattr(routine, "keypoints_path", None) and skeleton is None:
        if report is not None and routine.keypoints_report is not None:
            report.__dict__.update(routine.keypoints_report.__dict__)
        return routine.poses
    from ..formats.routine import apply_frame_offsets

    poses = read_keypoints(kdir, routine.rig.names, skeleton=skeleton, report=report)
    return apply_frame_offsets(poses, routine.scene.frame_offsets, routine.rig.names)[0]
