"""Which file or folder holds which camera's data: by name, by a similar name, else by sorted order.

Rule (``shared/formats.md``, keypoints): camera folders are matched to the calibration's cameras
by name, or by sorted order where the names differ (Pose2Sim names its calibration's cameras
``int_cam1_img`` or ``cam_01`` and its pose folders ``cam01_json``: Pose2Sim itself pairs them by
sorted order); the mapping is always shown to the user.

A name is compared as its tokens: runs of letters (lower case) and of digits (as numbers), so
``cam01``, ``cam_01`` and ``Cam1`` are the same name, and ``cam1`` is inside ``int_cam1_img``
(a contiguous run of its tokens) but not inside ``cam10``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from typing import Sequence

__all__ = ["CameraMatch", "name_tokens", "match_cameras"]

_TOKEN = re.compile(r"[a-z]+|\d+")
#: the suffix Pose2Sim and OpenPose users give per-camera pose folders
FOLDER_SUFFIXES = ("_json", "-json", "_keypoints", "_pose")


def name_tokens(name: str) -> tuple:
    """``"Cam_01_json"`` -> ``("cam", 1, "json")``."""
    return tuple(int(t) if t.isdigit() else t for t in _TOKEN.findall(name.lower()))


def strip_suffix(stem: str) -> str:
    """An entry's camera part: ``cam01_json`` -> ``cam01``."""
    low = stem.lower()
    for s in FOLDER_SUFFIXES:
        if low.endswith(s) and len(stem) > len(s):
            return stem[: -len(s)]
    return stem


def _inside(a: tuple, b: tuple) -> bool:
    """``a`` is a contiguous run of ``b``'s tokens."""
    n = len(a)
    return 0 < n <= len(b) and any(b[i:i + n] == a for i in range(len(b) - n + 1))


@dataclass(frozen=True)
class CameraMatch:
    """camera -> entry, and how each was matched (``name`` | ``similar name`` | ``sorted order``);
    ``unmatched_entries``: entries no camera took; ``unmatched_cameras``: cameras without an entry."""

    entries: dict[str, str]
    how: dict[str, str]
    unmatched_entries: tuple[str, ...]
    unmatched_cameras: tuple[str, ...]

    def lines(self) -> list[str]:
        return [f"camera {c} <- {e} (by {self.how[c]})" for c, e in self.entries.items()]

    @property
    def by_order(self) -> bool:
        return "sorted order" in self.how.values()


def _natural(name: str) -> tuple:
    return tuple((0, t, "") if isinstance(t, int) else (1, 0, t) for t in name_tokens(name))


def match_cameras(entries: Sequence[str], cameras: Sequence[str]) -> CameraMatch:
    """Pair ``entries`` (camera parts of file or folder names) with ``cameras``.

    In turn: the same name; the same tokens; one name's tokens a run inside the other's, where
    that pairs exactly one entry with one camera; then, when as many entries as cameras are left,
    both in natural sorted order.
    """
    left_e, left_c = list(dict.fromkeys(entries)), list(cameras)
    out: dict[str, str] = {}
    how: dict[str, str] = {}

    def take(c: str, e: str, why: str) -> None:
        out[c], how[c] = e, why
        left_c.remove(c)
        left_e.remove(e)

    for c in list(left_c):
        if c in left_e:
            take(c, c, "name")
    for c in list(left_c):
        same = [e for e in left_e if name_tokens(e) == name_tokens(c)]
        if len(same) == 1:
            take(c, same[0], "similar name")
    for c in list(left_c):
        tc = name_tokens(c)
        near = [e for e in left_e if _inside(name_tokens(e), tc) or _inside(tc, name_tokens(e))]
        if len(near) == 1 and sum(_inside(name_tokens(near[0]), name_tokens(x)) or _inside(name_tokens(x), name_tokens(near[0]))
                                  for x in left_c) == 1:
            take(c, near[0], "similar name")
    if left_c and len(left_c) == len(left_e):
        for c, e in zip(sorted(left_c, key=_natural), sorted(left_e, key=_natural)):
            take(c, e, "sorted order")
    ordered = {c: out[c] for c in cameras if c in out}
    return CameraMatch(ordered, {c: how[c] for c in ordered}, tuple(left_e), tuple(left_c))
