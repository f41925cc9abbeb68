"""Skeletons: the joint layouts of the 2D pose models the pose stage reads.

The paper (Yang et al., Section III) tracks a box per person; the pose stage extends it with
joints inside the target's expanded box ``b_buf`` (Eq. 14). This module names those joints.
Joint names and orders are those of ``shared/formats.md``:

* ``COCO17``  the COCO keypoints (HRNet, RTMPose, mmpose's default)
* ``BODY25``  OpenPose's BODY_25
* ``HALPE26`` Halpe full-body's 26 body joints (AlphaPose, RTMPose-Halpe)
* ``BODY25B`` OpenPose's experimental BODY_25B (Pose2Sim's default): the COCO-17 joints, then
  ``neck`` (OpenPose's UpperNeck), ``head`` (HeadTop) and the six foot joints. Same joint count as
  BODY_25, another order: which one a 25-joint file holds is decided by
  :mod:`gymtrack.formats.skeleton_fit`, never by the count alone.
* ``COCO_WHOLEBODY`` the body part of COCO-WholeBody's 133 joints (the first 23: COCO-17 and the six
  foot joints); files with 133 joints are read into it, the face and hand joints are counted, not used.
* ``COCO18`` OpenPose's COCO model and rtmlib's ``to_openpose`` body output (18 joints, with a neck).

``ALIASES`` maps the tools' own spellings (``BODY_25B``, ``HALPE_26``, ``COCO_133``...) to these names.

A :class:`Skeleton` carries, besides the names, two arrays derived from them:

* ``flip`` (J,) int64, the index of each joint's mirror (``left_x`` <-> ``right_x``; a central
  joint maps to itself). Used to undo left/right swaps and for mirrored augmentations.
* ``bones`` (B, 2) int64, joint-index pairs of the limb and torso segments present in the
  skeleton (a segment is kept when both its joints are), used for bone-length checks in lifting.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np

from .errors import InputError

COCO17_JOINTS = (
    "nose", "left_eye", "right_eye", "left_ear", "right_ear", "left_shoulder", "right_shoulder",
    "left_elbow", "right_elbow", "left_wrist", "right_wrist", "left_hip", "right_hip", "left_knee", "right_knee",
    "left_ankle", "right_ankle",
)
BODY25_JOINTS = (
    "nose", "neck", "right_shoulder", "right_elbow", "right_wrist", "left_shoulder", "left_elbow",
    "left_wrist", "mid_hip", "right_hip", "right_knee", "right_ankle", "left_hip", "left_knee", "left_ankle",
    "right_eye", "left_eye", "right_ear", "left_ear", "left_big_toe", "left_small_toe", "left_heel",
    "right_big_toe", "right_small_toe", "right_heel",
)
HALPE26_JOINTS = COCO17_JOINTS + (
    "head", "neck", "hip", "left_big_toe", "right_big_toe", "left_small_toe", "right_small_toe",
    "left_heel", "right_heel",
)
_FEET = ("left_big_toe", "left_small_toe", "left_heel", "right_big_toe", "right_small_toe", "right_heel")
# openpose_train/experimental_models: UpperNeck (17) and HeadTop (18) after the COCO joints
BODY25B_JOINTS = COCO17_JOINTS + ("neck", "head") + _FEET
#: the body part of COCO-WholeBody (its joints 0-22); 23-132 are face (68) and hands (2 x 21)
WHOLEBODY_BODY_JOINTS = COCO17_JOINTS + _FEET
WHOLEBODY_JOINT_COUNT = 133
COCO18_JOINTS = (
    "nose", "neck", "right_shoulder", "right_elbow", "right_wrist", "left_shoulder", "left_elbow", "left_wrist",
    "right_hip", "right_knee", "right_ankle", "left_hip", "left_knee", "left_ankle", "right_eye", "left_eye",
    "right_ear", "left_ear",
)

# Segments by name, written for the left side; the right side is derived by mirroring. The face
# links (eye-ear, ear-shoulder) follow COCO's own skeleton so the head joins the body without a
# neck; they are not rigid, so bone-length checks should weight them loosely.
_SIDE_SEGMENTS = (
    ("left_shoulder", "left_elbow"), ("left_elbow", "left_wrist"),
    ("left_hip", "left_knee"), ("left_knee", "left_ankle"),
    ("left_shoulder", "left_hip"),
    ("left_eye", "left_ear"), ("nose", "left_eye"), ("left_ear", "left_shoulder"),
    ("neck", "left_shoulder"), ("mid_hip", "left_hip"), ("hip", "left_hip"),
    ("left_ankle", "left_heel"), ("left_ankle", "left_big_toe"), ("left_big_toe", "left_small_toe"),
)
_CENTRAL_SEGMENTS = (
    ("left_shoulder", "right_shoulder"), ("left_hip", "right_hip"), ("left_eye", "right_eye"),
    ("nose", "neck"), ("head", "neck"), ("neck", "mid_hip"), ("neck", "hip"),
)


def _mirror_name(name: str) -> str:
    if name.startswith("left_"):
        return "right_" + name[5:]
    if name.startswith("right_"):
        return "left_" + name[6:]
    return name


def _all_segments() -> tuple[tuple[str, str], ...]:
    right = tuple((_mirror_name(a), _mirror_name(b)) for a, b in _SIDE_SEGMENTS)
    return _SIDE_SEGMENTS + right + _CENTRAL_SEGMENTS


_SEGMENTS = _all_segments()


@dataclass(frozen=True)
class Skeleton:
    """A named joint layout.

    Attributes
    ----------
    name: a key of :data:`SKELETONS` or ``"custom"``.
    joints: J snake_case joint names in file order.
    flip: (J,) int64, index of each joint's left/right mirror (itself for central joints and for a
        ``left_``/``right_`` joint whose mirror the skeleton lacks).
    bones: (B, 2) int64 joint-index pairs of the segments present in this skeleton.

    Two skeletons are equal when their names and joints are.
    """

    name: str
    joints: tuple[str, ...]
    flip: np.ndarray
    bones: np.ndarray

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Skeleton):
            return NotImplemented
        return self.name == other.name and self.joints == other.joints

    def __hash__(self) -> int:
        return hash((self.name, self.joints))

    def __len__(self) -> int:
        return len(self.joints)

    def index(self, names: Sequence[str]) -> np.ndarray:
        """(len(names),) int64 indices of ``names`` in this skeleton, -1 where absent."""
        pos = {j: i for i, j in enumerate(self.joints)}
        return np.array([pos.get(n, -1) for n in names], dtype=np.int64).reshape(-1)

    def __repr__(self) -> str:
        return f"Skeleton({self.name!r}, {len(self.joints)} joints)"


def _make(name: str, joints: Sequence[str]) -> Skeleton:
    joints = tuple(str(j) for j in joints)
    if len(set(joints)) != len(joints):
        dup = sorted({j for j in joints if joints.count(j) > 1})
        raise InputError(f"joint names must be unique, repeated: {', '.join(dup)}", field="joints")
    pos = {j: i for i, j in enumerate(joints)}
    flip = np.array([pos.get(_mirror_name(j), i) for i, j in enumerate(joints)], dtype=np.int64)
    bones = np.array([(pos[a], pos[b]) for a, b in _SEGMENTS if a in pos and b in pos], dtype=np.int64).reshape(-1, 2)
    flip.setflags(write=False)
    bones.setflags(write=False)
    return Skeleton(name, joints, flip, bones)


COCO17 = _make("coco17", COCO17_JOINTS)
BODY25 = _make("body25", BODY25_JOINTS)
HALPE26 = _make("halpe26", HALPE26_JOINTS)
BODY25B = _make("body25b", BODY25B_JOINTS)
COCO_WHOLEBODY = _make("coco_wholebody", WHOLEBODY_BODY_JOINTS)
COCO18 = _make("coco18", COCO18_JOINTS)
SKELETONS: dict[str, Skeleton] = {s.name: s for s in (COCO17, BODY25, HALPE26, BODY25B, COCO_WHOLEBODY, COCO18)}
#: the tools' spellings -> gymtrack's names (compared after lower-casing and dropping ``_``/``-``)
ALIASES: dict[str, str] = {"body25": "body25", "body25b": "body25b", "halpe26": "halpe26", "halpe": "halpe26",
                           "coco17": "coco17", "coco": "coco17", "coco133": "coco_wholebody",
                           "cocowholebody": "coco_wholebody", "wholebody": "coco_wholebody", "coco18": "coco18",
                           "openposecoco": "coco18"}
#: joints a file of each skeleton holds (COCO-WholeBody: 133, of which the first 23 are read)
FILE_JOINTS: dict[str, int] = {**{n: len(s.joints) for n, s in SKELETONS.items()}, "coco_wholebody": WHOLEBODY_JOINT_COUNT}


def get_skeleton(name: str) -> Skeleton:
    """The named skeleton (``coco17``, ``body25``, ``body25b``, ``halpe26``, ``coco_wholebody``,
    ``coco18``, or a tool's spelling of them such as ``BODY_25B``, ``HALPE_26``, ``COCO_133``);
    :class:`InputError` otherwise."""
    key = name.lower().replace("_", "").replace("-", "") if isinstance(name, str) else None
    if key in ALIASES:
        return SKELETONS[ALIASES[key]]
    raise InputError(f"unknown skeleton {name!r}; known: {', '.join(SKELETONS)} (also spelt BODY_25B, HALPE_26, "
                     "COCO_17, COCO_133; or give the joint names)", field="skeleton")


def custom_skeleton(joints: Sequence[str]) -> Skeleton:
    """A skeleton named ``"custom"`` from joint names; flip and bones derived from the names.

    Raises :class:`InputError` (field ``joints``) for an empty list, non-string or repeated names.
    """
    if isinstance(joints, str) or not isinstance(joints, Sequence) or len(joints) == 0:
        raise InputError("must be a non-empty list of joint names", field="joints")
    for i, j in enumerate(joints):
        if not isinstance(j, str) or not j:
            raise InputError(f"joint name must be a non-empty string, got {j!r}", field=f"joints[{i}]")
    return _make("custom", joints)
