"""Videos of a routine folder: ``videos/<camera>.<ext>``, read by frame number with PyAV.

Paper: Section III-A and III-D -- the detector runs on every frame of every view and the pose
model on crops of ``b_buf`` taken from the full-resolution frame; both need the frames of the
synchronised cameras by frame number. Frame ``k`` (0-based) of a camera's file is frame
``first_frame + k - offset`` of the routine (``first_frame`` and ``video_offsets`` in
``scene.yaml``; an offset of ``n`` means the camera started recording ``n`` frames earlier).

:class:`VideoReader` is the one reader every command uses (threaded decoding, seeking by frame);
:class:`VideoSet` reads the same frame of all cameras at once (one decoding thread per camera);
:func:`write_video` writes frames (for tests and the simulator). Images are ``(H, W, 3)`` uint8
BGR, as OpenCV has them. PyAV is the optional ``video`` extra and is imported lazily.
"""

from __future__ import annotations

import warnings
from concurrent.futures import ThreadPoolExecutor
from fractions import Fraction
from pathlib import Path
from typing import Iterable, Iterator, Mapping, Sequence

import numpy as np

from ..errors import GymtrackWarning, InputError
from .video_index import TimestampIndex, VideoFaults, index_timestamps

__all__ = ["VIDEO_EXTENSIONS", "VideoReader", "VideoSet", "find_videos", "open_videos", "write_video", "import_av"]

#: Extensions looked for under ``videos/`` (in this order when a camera has several).
VIDEO_EXTENSIONS: tuple[str, ...] = (".mp4", ".mkv", ".avi", ".mov", ".webm", ".m4v", ".mpg", ".ts")

#: Frames a forward read decodes through before seeking instead (seeking costs a key-frame decode).
_SEEK_AHEAD = 48


def import_av():
    """The ``av`` module, or an InputError naming the extra to install."""
    try:
        import av
    except ImportError:  # pragma: no cover - the extra is installed in CI
        raise InputError("reading or writing videos needs the 'video' extra: pip install 'gymtrack[video]'") from None
    return av


class VideoReader:
    """One camera's video, read by routine frame number.

    Parameters
    ----------
    path: the video file.
    first_frame: routine frame number of the file's first frame slot (``scene.yaml`` ``first_frame``).
    offset: the camera's ``video_offsets`` entry: slot ``k`` is frame ``first_frame + k - offset``.
    threads: decoder threads (0: FFmpeg chooses).

    Slots come from the presentation timestamps where the container has them
    (:mod:`gymtrack.formats.video_index`): a dropped frame is a gap in :attr:`frame_numbers`, a
    repeated one is skipped; a stretch that cannot be decoded is skipped to the next decodable
    frame. All of it is counted in :attr:`faults`.

    Attributes
    ----------
    frame_numbers: (n,) int64 increasing, the routine frame number of every frame of the file.
    fps: frames per second (the stream's average rate).
    size: (width, height) in pixels.
    faults: :class:`~gymtrack.formats.video_index.VideoFaults` (dropped, repeated, corrupt frames).
    """

    def __init__(self, path: str | Path, first_frame: int = 1, offset: int = 0, threads: int = 0) -> None:
        av = import_av()
        self.path = Path(path)
        if not self.path.is_file():
            raise InputError("video file not found", source=self.path)
        try:
            self._container = av.open(str(self.path))
        except av.error.FFmpegError as exc:
            raise InputError(f"not a video PyAV can open: {exc}", source=self.path) from None
        if not self._container.streams.video:
            self._container.close()
            raise InputError("the file has no video stream", source=self.path)
        self._stream = s = self._container.streams.video[0]
        s.thread_type = "AUTO"  # frame and slice threads
        s.thread_count = int(threads)
        # a damaged frame is an error (then skipped and reported), not a silently concealed image
        s.codec_context.options = {"err_detect": "crccheck+explode"}
        rate = s.average_rate or s.guessed_rate or s.base_rate
        if not rate:
            raise InputError("the video stream has no frame rate", source=self.path)
        self._rate = Fraction(rate)
        self._tb = Fraction(s.time_base)
        self._start = int(s.start_time or 0)
        self.fps = float(self._rate)
        self.size = (int(s.codec_context.width), int(s.codec_context.height))
        self.first_frame = int(first_frame)
        self.offset = int(offset)
        self._base = self.first_frame - self.offset  # routine frame number of slot 0
        self.faults = VideoFaults()
        self._index = self._read_index_of_packets(av)
        self.frame_numbers = self._index.slots + self._base
        self.faults.by_timestamp = self._index.by_timestamp
        self.faults.dropped = (self._index.dropped_slots() + self._base).tolist()
        self.faults.repeated = (self._index.repeated_slots + self._base).tolist()
        self._decoder: Iterator | None = None
        self._next_index = 0  # slot the open decoder yields next

    def _read_index_of_packets(self, av) -> TimestampIndex:
        """Every packet's timestamp (demuxing only, no decoding); a file that cannot be read to its
        end is indexed up to there (:attr:`faults` ``unreadable_after``)."""
        pts: list[int | None] = []
        try:
            for p in self._container.demux(self._stream):
                if p.size:
                    pts.append(p.pts)
        except av.error.FFmpegError:
            self._unreadable = True
        else:
            self._unreadable = False
        self._container.seek(0)
        index = index_timestamps(pts, self._start, self._tb, self._rate)
        # a demuxer that loses its way in a damaged file may just stop: compare with the stated length
        stated = (self._stream.duration * self._tb if self._stream.duration else
                  Fraction(self._container.duration or 0, 1_000_000))
        short = len(index.slots) and float(stated * self._rate) - float(index.slots[-1] + 1) > 1.5
        if (self._unreadable or short) and len(index.slots):
            self.faults.unreadable_after = int(index.slots[-1] + self._base)
        return index

    def __len__(self) -> int:
        return len(self.frame_numbers)

    def __repr__(self) -> str:
        fr = f"frames {self.frame_numbers[0]}..{self.frame_numbers[-1]}" if len(self) else "no frames"
        return f"VideoReader({self.path.name}, {self.size[0]}x{self.size[1]}, {self.fps:g} fps, {fr})"

    def has(self, frame: int) -> bool:
        """True when the file holds routine frame ``frame`` (not dropped, not out of range)."""
        i = int(np.searchsorted(self.frame_numbers, int(frame)))
        return i < len(self) and self.frame_numbers[i] == int(frame)

    def index_of(self, frame: int) -> int:
        """Slot of routine frame ``frame``; InputError when the file lacks it."""
        if not self.has(frame):
            first, last = (self.frame_numbers[0], self.frame_numbers[-1]) if len(self) else ("-", "-")
            what = ("was dropped (no frame of the file has its timestamp)" if len(self) and first < frame < last
                    else "is not in the video")
            raise InputError(f"frame {frame} {what} (it holds frames {first}..{last} with first_frame "
                             f"{self.first_frame}, offset {self.offset})", source=self.path)
        return int(frame) - self._base

    def _slot(self, av_frame) -> int | None:
        """Slot of a decoded frame; None for a repeated one (a timestamp the index skipped)."""
        if not self._index.by_timestamp or av_frame.pts is None:
            return self._next_index
        i = int(np.searchsorted(self._index.pts, av_frame.pts))
        if i < len(self._index.pts) and self._index.pts[i] == av_frame.pts:
            return int(self._index.slots[i])
        return None

    def _seek(self, k: int) -> None:
        i = int(np.searchsorted(self._index.slots, k))
        pts = int(self._index.pts[i]) if self._index.by_timestamp else self._start + int((Fraction(k) / self._rate) / self._tb)
        self._container.seek(pts, stream=self._stream, backward=True, any_frame=False)
        self._decoder = self._frames()
        self._next_index = -1  # unknown until the first frame comes

    def _frames(self) -> Iterator:
        """Decoded frames from the demuxer's position; a packet that does not decode is skipped
        (its frame is then missing in the slots: recorded as corrupt by :meth:`_read_slot`)."""
        av = import_av()
        demux = self._container.demux(self._stream)
        while True:
            try:
                packet = next(demux)
            except StopIteration:
                return
            except av.error.FFmpegError:  # the container itself is damaged from here on
                return
            try:
                yield from packet.decode()
            except av.error.FFmpegError:
                continue

    def _read_slot(self, k: int) -> np.ndarray | None:
        if k + self._base in self.faults.corrupt:
            return None
        if self._decoder is None or not (0 <= k - self._next_index <= _SEEK_AHEAD):
            if k == int(self._index.slots[0]) and self._decoder is None:
                self._decoder = self._frames()
                self._next_index = k
            else:
                self._seek(k)
        last = self._next_index
        for f in self._decoder:
            i = self._slot(f)
            if i is None:  # a repeated frame: skipped (counted when the file was indexed)
                continue
            self._note_corrupt(k if last < 0 and i > k else last, i)
            self._next_index = last = i + 1
            if i >= k:
                if i > k:  # slot k exists in the file but did not decode
                    return None
                return f.to_ndarray(format="bgr24")
        self._decoder = None  # nothing decodable up to the end: the rest of the file is corrupt
        self._note_corrupt(k if last < 0 else last, int(self._index.slots[-1]) + 1)
        return None

    def _note_corrupt(self, lo: int, hi: int) -> None:
        """Slots of the file in ``[lo, hi)`` that the decoder skipped: corrupt (lo < 0: unknown start)."""
        if lo < 0 or hi <= lo:
            return
        a, b = np.searchsorted(self._index.slots, [lo, hi])
        self.faults.corrupt.update((self._index.slots[a:b] + self._base).tolist())

    def try_read(self, frame: int) -> np.ndarray | None:
        """The image of routine frame ``frame``, or None when the file lacks it or it does not decode."""
        if not self.has(frame):
            return None
        return self._read_slot(int(frame) - self._base)

    def read(self, frame: int) -> np.ndarray:
        """The image of routine frame ``frame``: (H, W, 3) uint8 BGR (InputError when dropped or corrupt)."""
        img = self._read_slot(self.index_of(frame))
        if img is None:
            raise InputError(f"frame {frame} cannot be decoded: it lies in a corrupt stretch of the file", source=self.path)
        return img

    def __iter__(self) -> Iterator[tuple[int, np.ndarray]]:
        """Every decodable frame in order: ``(frame number, (H, W, 3) uint8 BGR)``."""
        return self.iter_frames()

    def iter_frames(self, start: int | None = None, stop: int | None = None) -> Iterator[tuple[int, np.ndarray]]:
        """Frames ``start..stop`` (routine numbers, inclusive; default: the whole file) in order,
        leaving out dropped and corrupt ones (see :attr:`faults`)."""
        if not len(self):
            return
        lo = self.frame_numbers[0] if start is None else max(int(start), int(self.frame_numbers[0]))
        hi = self.frame_numbers[-1] if stop is None else min(int(stop), int(self.frame_numbers[-1]))
        for fr in self.frame_numbers[(self.frame_numbers >= lo) & (self.frame_numbers <= hi)]:
            img = self._read_slot(int(fr) - self._base)
            if img is not None:
                yield int(fr), img

    def close(self) -> None:
        self._decoder = None
        self._container.close()

    def __enter__(self) -> "VideoReader":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def find_videos(routine_folder: str | Path, camera_names: Sequence[str]) -> dict[str, Path]:
    """``videos/<camera>.<ext>`` of the cameras that have one (camera name -> path).

    Raises InputError when ``videos/`` holds a video named after no camera (a typo would
    otherwise drop a view silently) or two videos for one camera.
    """
    folder = Path(routine_folder) / "videos"
    if not folder.is_dir():
        return {}
    found: dict[str, Path] = {}
    for p in sorted(folder.iterdir()):
        if not p.is_file() or p.suffix.lower() not in VIDEO_EXTENSIONS:
            continue
        if p.stem not in camera_names:
            raise InputError(f"video of camera {p.stem!r}, which the calibration does not have "
                             f"(its cameras: {', '.join(camera_names)}): rename or remove it", source=p)
        if p.stem in found:
            raise InputError(f"two videos for camera {p.stem!r} ({found[p.stem].name} and {p.name}): keep one", source=p)
        found[p.stem] = p
    return {n: found[n] for n in camera_names if n in found}


class VideoSet:
    """The videos of several cameras read together, one decoding thread per camera.

    ``readers`` in rig order (None for a camera without a video). :meth:`read` returns one image
    per camera (None where the camera has no video or not that frame). ``pixel_scale`` (C,):
    calibration pixels per video pixel of each camera (1 when the video has the calibrated size;
    e.g. 4 for a 480-pixel-wide preview of a 1920 camera).
    """

    def __init__(self, readers: Sequence[VideoReader | None], camera_names: Sequence[str],
                 pixel_scale: Sequence[float] | None = None) -> None:
        self.readers = list(readers)
        self.camera_names = tuple(camera_names)
        self.pixel_scale = np.ones(len(self.readers)) if pixel_scale is None else np.asarray(pixel_scale, np.float64)
        self._pool = ThreadPoolExecutor(max_workers=max(1, sum(r is not None for r in self.readers)))

    @property
    def frame_numbers(self) -> np.ndarray:
        """(F,) int64, the frames at least one camera's video holds, increasing."""
        parts = [r.frame_numbers for r in self.readers if r is not None]
        return np.unique(np.concatenate(parts)) if parts else np.zeros(0, np.int64)

    def _one(self, r: VideoReader | None, frame: int) -> np.ndarray | None:
        return None if r is None else r.try_read(frame)

    def faults(self) -> dict[str, "VideoFaults"]:
        """Camera name -> what its video lacked or held twice (dropped, repeated, corrupt frames)."""
        return {n: r.faults for n, r in zip(self.camera_names, self.readers) if r is not None}

    def read(self, frame: int) -> list[np.ndarray | None]:
        """Frame ``frame`` of every camera: a list of (H, W, 3) uint8 BGR or None (no video, a frame
        the video lacks, dropped or corrupt), rig order."""
        return list(self._pool.map(lambda r: self._one(r, frame), self.readers))

    def iter_frames(self, frames: Iterable[int] | None = None) -> Iterator[tuple[int, list[np.ndarray | None]]]:
        """``(frame, images)`` for ``frames`` (default: :attr:`frame_numbers`), the next frame
        decoded while the caller works on this one."""
        todo = [int(f) for f in (self.frame_numbers if frames is None else frames)]
        if not todo:
            return
        with ThreadPoolExecutor(max_workers=1) as ahead:
            nxt = ahead.submit(self.read, todo[0])
            for i, fr in enumerate(todo):
                images = nxt.result()
                if i + 1 < len(todo):
                    nxt = ahead.submit(self.read, todo[i + 1])
                yield fr, images

    def close(self) -> None:
        self._pool.shutdown(wait=True)
        for r in self.readers:
            if r is not None:
                r.close()

    def __enter__(self) -> "VideoSet":
        return self

    def __exit__(self, *exc) -> None:
        self.close()


def size_scale(camera: str, calibrated: tuple[int, int], video: tuple[int, int], path: Path,
               strict: bool = False) -> float:
    """Calibration pixels per video pixel for a video of ``video`` (w, h) size of a camera calibrated
    at ``calibrated`` (W, H). Another size is never silent: with the same aspect (within 1 %) a
    warning names the camera, both sizes, the scale and how far it moves the far corner (an
    InputError under ``strict``); another aspect is an InputError."""
    (W, H), (w, h) = calibrated, video
    if (W, H) == (w, h):
        return 1.0
    scale = W / w
    if abs(H / h - scale) > 0.01 * scale:
        raise InputError(f"the video is {w}x{h} but camera {camera!r} is calibrated at {W}x{H} "
                         "(another aspect ratio): use the original video or recalibrate", source=path)
    moved = abs(scale - 1) * max(w, h)
    msg = (f"camera {camera!r}: the video is {w}x{h} but the calibration says {W}x{H}; its pixels are scaled by "
           f"{scale:.4f} (x) and {H / h:.4f} would be needed for y, so points near the far edge move by up to "
           f"{moved:.0f} px. If the video was cropped or padded (a codec's multiple of 16) rather than resized, "
           "fix the calibration's size instead")
    if strict:
        raise InputError(msg + " (--strict)", source=path)
    warnings.warn(msg, GymtrackWarning, stacklevel=3)
    return scale


def open_videos(routine_folder: str | Path, camera_names: Sequence[str], first_frame: int = 1,
                video_offsets: Mapping[str, int] | None = None, required: bool = True,
                sizes: Sequence[tuple[int, int]] | None = None, strict: bool = False) -> VideoSet:
    """A :class:`VideoSet` of a routine's ``videos/`` (``first_frame``/``video_offsets`` as in scene.yaml).

    ``required``: raise InputError naming the cameras without a video; otherwise they read None.
    An offset for a camera the rig lacks is an error (a typo would silently leave a view unsynchronised).
    ``sizes``: the calibrated (width, height) of every camera; a video of another size with the
    same aspect (within 1 %) gets its :attr:`VideoSet.pixel_scale` and a warning naming the camera,
    both sizes and the scale (an error under ``strict``: :func:`size_scale`); another aspect is an error.
    """
    offsets = dict(video_offsets or {})
    for cam in offsets:
        if cam not in camera_names:
            raise InputError(f"offset for camera {cam!r}, which the calibration does not have", source="scene.yaml",
                             field=f"video_offsets.{cam}")
    paths = find_videos(routine_folder, camera_names)
    missing = [n for n in camera_names if n not in paths]
    if required and missing:
        raise InputError(f"no video for camera(s) {', '.join(missing)}: add videos/<camera>.mp4 (any container "
                         f"PyAV reads: {', '.join(VIDEO_EXTENSIONS)})", source=Path(routine_folder) / "videos")
    readers = [VideoReader(paths[n], first_frame, offsets.get(n, 0)) if n in paths else None for n in camera_names]
    scale = np.ones(len(readers))
    for i, r in enumerate(readers):
        if r is None or sizes is None:
            continue
        try:
            scale[i] = size_scale(camera_names[i], sizes[i], r.size, r.path, strict)
        except InputError:
            for x in readers:
                if x is not None:
                    x.close()
            raise
    return VideoSet(readers, camera_names, scale)


def write_video(path: str | Path, frames: Iterable[np.ndarray], fps: float, codec: str | None = None,
                options: Mapping[str, str] | None = None, timestamps: Sequence[float] | None = None) -> int:
    """Write ``(H, W, 3)`` uint8 BGR ``frames`` as a video; returns the number of frames written.

    codec: default ``libx264`` (yuv420p, crf 18; even sizes) for ``.mp4``/``.mov``, ``ffv1``
    (lossless, bgr0) for ``.mkv``/``.avi`` -- tests that check pixels use ``.mkv``.
    timestamps: each frame's presentation time in frame periods (default 0, 1, 2, ...; increasing,
    to 1/100 of a period): a capture with dropped (a step of 2 or more) or repeated (a step under
    0.5) frames, as a capture card writes them.
    """
    av = import_av()
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    lossless = path.suffix.lower() in (".mkv", ".avi")
    codec = codec or ("ffv1" if lossless else "libx264")
    rate = Fraction(fps).limit_denominator(1001)
    n = 0
    fine = 1 if timestamps is None else 100  # time base: a frame period, or 1/100 of one
    with av.open(str(path), mode="w") as out:
        stream = out.add_stream(codec, rate=rate, options=dict(options or ({"crf": "18"} if codec == "libx264" else {})))
        stream.pix_fmt = "bgr0" if codec == "ffv1" else "yuv420p"
        if fine > 1:
            stream.codec_context.time_base = 1 / (rate * fine)
        for img in frames:
            img = np.ascontiguousarray(img, dtype=np.uint8)
            if img.ndim != 3 or img.shape[2] != 3:
                raise ValueError(f"write_video needs (H, W, 3) uint8 BGR frames, got shape {img.shape}")
            if n == 0:
                stream.width, stream.height = img.shape[1], img.shape[0]
            frame = av.VideoFrame.from_ndarray(img, format="bgr24")
            frame.pts = n if timestamps is None else int(round(float(timestamps[n]) * fine))
            frame.time_base = 1 / (rate * fine)
            for packet in stream.encode(frame):
                out.mux(packet)
            n += 1
        for packet in stream.encode():
            out.mux(packet)
    return n
