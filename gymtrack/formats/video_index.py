"""Which frame of the routine each frame of a video file is: by presentation timestamps, and what went wrong.

Paper: Section III-A assumes synchronised views, frame ``k`` of every camera taken at the same
moment. A capture card that drops a frame shifts every later frame of that camera by one if frames
are counted; so where the container stores presentation timestamps (PTS), frame numbers come
from them: slot ``round((pts - start) * time_base * fps)``. A dropped frame leaves a slot without
a frame (a gap in the frame numbers), a repeated frame (a second frame in the same slot) is
skipped; a file without timestamps is numbered by counting. :class:`VideoFaults` keeps the
counts and frame ranges a command reports per camera, with the stretches that could not be
decoded (recorded while reading).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from fractions import Fraction

import numpy as np

__all__ = ["TimestampIndex", "VideoFaults", "index_timestamps", "ranges"]


def ranges(frames) -> list[tuple[int, int]]:
    """Sorted frame numbers -> inclusive runs ``[(first, last), ...]``."""
    f = np.unique(np.asarray(list(frames), np.int64))
    if not len(f):
        return []
    cut = np.flatnonzero(np.diff(f) != 1) + 1
    return [(int(r[0]), int(r[-1])) for r in np.split(f, cut)]


def _fmt(rs: list[tuple[int, int]], limit: int = 4) -> str:
    parts = [f"{a}" if a == b else f"{a}-{b}" for a, b in rs[:limit]]
    return ", ".join(parts) + (f" and {len(rs) - limit} more" if len(rs) > limit else "")


@dataclass
class VideoFaults:
    """What one camera's file lacked or held twice, in routine frame numbers.

    dropped: frames with no frame in the file (a timestamp gap); repeated: extra frames with the
    timestamp of another, skipped; corrupt: frames of the file that could not be decoded, skipped;
    unreadable_after: the file could not be read past this frame (None when it could).
    """

    dropped: list[int] = field(default_factory=list)
    repeated: list[int] = field(default_factory=list)
    corrupt: set[int] = field(default_factory=set)
    unreadable_after: int | None = None
    by_timestamp: bool = True

    def __bool__(self) -> bool:
        return bool(self.dropped or self.repeated or self.corrupt or self.unreadable_after is not None)

    def summary(self) -> str:
        """One line, e.g. ``2 dropped (frames 13-14), 1 repeated skipped (frame 30), 3 corrupt skipped (frames 20-22)``."""
        parts = []
        if self.dropped:
            parts.append(f"{len(self.dropped)} dropped (frame{'s' * (len(self.dropped) > 1)} {_fmt(ranges(self.dropped))})")
        if self.repeated:
            parts.append(f"{len(self.repeated)} repeated skipped (at frame{'s' * (len(self.repeated) > 1)} "
                         f"{_fmt(ranges(self.repeated))})")
        if self.corrupt:
            parts.append(f"{len(self.corrupt)} corrupt skipped (frame{'s' * (len(self.corrupt) > 1)} "
                         f"{_fmt(ranges(sorted(self.corrupt)))})")
        if self.unreadable_after is not None:
            parts.append(f"unreadable after frame {self.unreadable_after}")
        return ", ".join(parts)

    def as_dict(self) -> dict:
        return {"dropped": len(self.dropped), "dropped_ranges": ranges(self.dropped),
                "repeated": len(self.repeated), "repeated_at": ranges(self.repeated),
                "corrupt": len(self.corrupt), "corrupt_ranges": ranges(sorted(self.corrupt)),
                "unreadable_after": self.unreadable_after, "by_timestamp": self.by_timestamp}


@dataclass(frozen=True)
class TimestampIndex:
    """The frames of a file by slot (frame position from its start).

    slots: (n,) int64 increasing, the slot of every kept frame; pts: (n,) its timestamp;
    repeated_slots: (r,) slots that held more than one frame (the extra ones are skipped).
    """

    slots: np.ndarray
    pts: np.ndarray
    repeated_slots: np.ndarray
    by_timestamp: bool

    def dropped_slots(self) -> np.ndarray:
        """(d,) slots between the first and last frame that no frame has."""
        if len(self.slots) < 2:
            return np.zeros(0, np.int64)
        full = np.arange(self.slots[0], self.slots[-1] + 1)
        return full[~np.isin(full, self.slots)]


def slot_of(pts: int, start: int, time_base: Fraction, rate: Fraction) -> int:
    """The slot of a timestamp: whole frame periods from the stream's start, rounded."""
    return int(round((pts - start) * time_base * rate))


def index_timestamps(packet_pts: list[int | None], start: int, time_base: Fraction, rate: Fraction) -> TimestampIndex:
    """A :class:`TimestampIndex` from the presentation timestamps of a stream's packets (demux
    order). Packets without a timestamp make the whole file numbered by counting (by_timestamp False)."""
    n = len(packet_pts)
    if n == 0 or any(p is None for p in packet_pts):
        k = np.arange(n, dtype=np.int64)
        return TimestampIndex(k, k.copy(), np.zeros(0, np.int64), by_timestamp=False)
    pts = np.sort(np.asarray(packet_pts, np.int64))
    scale = float(time_base * rate)
    slots = np.rint((pts - start) * scale).astype(np.int64)  # float rounding is exact enough for hours at any fps
    keep = np.ones(n, bool)
    keep[1:] = slots[1:] != slots[:-1]
    repeated = slots[~keep]
    return TimestampIndex(slots[keep], pts[keep], repeated, by_timestamp=True)
