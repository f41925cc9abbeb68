"""Skeletons: the joint layouts of the 2D pose models the pose stage reads (issue #9).

The paper (Yang et al., Section III) tracks a box per person; the pose stage extends it with
joints inside the target's expanded box ``b_buf`` (Eq. 14). This module names those joints.
Joint names and orders are those of ``shared/formats.md``:

* ``COCO17``  the COCO keypoints (HRNet, RTMPose, mmpose's default)
* ``BODY25``  OpenPose's BODY_25
* ``HALPE26`` Halpe full-body's 26 body joints (AlphaPose, RTMPose-Halpe)

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
    name: ``"coco17"`` | ``"body25"`` | ``"halpe26"`` | ``"custom"``.
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
SKELETONS: dict[str, Skeleton] = {s.name: s for s in (COCO17, BODY25, HALPE26)}


def get_skeleton(name: str) -> Skeleton:
    """The named skeleton (``coco17``, ``body25``, ``halpe26``); :class:`InputError` otherwise."""
    try:
        return SKELETONS[name]
    except (KeyError, TypeError):
        raise InputError(f"unknown skeleton {name!r}; known: {', '.join(SKELETONS)} (or give 'joints')",
                         field="skeleton") from None


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
