"""Videos: frame numbering with first_frame and offsets, seeking, find_videos, VideoSet, scene keys."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("av")

from gymtrack.errors import GymtrackWarning, InputError  # noqa: E402
from gymtrack.formats.scene import scene_from_dict  # noqa: E402
from gymtrack.formats.video import VideoReader, find_videos, open_videos, write_video  # noqa: E402


def numbered(n: int, h: int = 48, w: int = 64, base: int = 0, gray: bool = False, step: int = 2):
    """Frame i: a flat image whose blue channel (all channels with ``gray``) is (base + i) * step,
    and a red square at its top-left."""
    for i in range(n):
        img = np.zeros((h, w, 3), np.uint8)
        img[..., slice(None) if gray else 0] = ((base + i) * step) % 256
        img[:8, :8] = (0, 0, 255)
        yield img


def frame_code(img: np.ndarray) -> int:
    return int(round(float(img[20:, 20:, 0].mean()) / 2))


@pytest.fixture
def mkv(tmp_path):
    p = tmp_path / "cam0.mkv"
    assert write_video(p, numbered(40), fps=25) == 40
    return p


def test_numbering_and_random_seeks(mkv):
    r = VideoReader(mkv, first_frame=10, offset=3)
    assert len(r) == 40 and r.size == (64, 48) and r.fps == 25
    assert r.frame_numbers[0] == 7 and r.frame_numbers[-1] == 46
    for fr in (7, 30, 8, 46, 45, 12, 12, 40, 7):  # backwards, forwards, repeats
        img = r.read(fr)
        assert img.shape == (48, 64, 3) and img.dtype == np.uint8
        assert frame_code(img) == fr - 7
    assert tuple(r.read(7)[2, 2]) == (0, 0, 255)  # BGR order: red is the last channel
    with pytest.raises(InputError, match="frame 47 is not in the video"):
        r.read(47)
    with pytest.raises(InputError, match="frame 6 "):
        r.read(6)


def test_iteration_in_order(mkv):
    with VideoReader(mkv) as r:
        got = [(f, frame_code(im)) for f, im in r]
        assert got == [(k + 1, k) for k in range(40)]
        assert [f for f, _ in r.iter_frames(38, 100)] == [38, 39, 40]


def test_mp4_lossy_still_numbered(tmp_path):
    p = tmp_path / "cam1.mp4"
    write_video(p, numbered(30, base=3, gray=True, step=7), fps=30)
    r = VideoReader(p)
    assert len(r) == 30
    for fr in (1, 29, 3, 17, 16):  # H.264 with B-frames: seeks land on key frames and decode forward
        level = float(r.read(fr)[20:, 20:].mean())  # lossy and colour-converted: within 3 levels
        assert abs(level - 7 * (fr + 2)) < 3.5  # neighbours are 7 levels apart


def test_find_videos_and_offsets(tmp_path):
    (tmp_path / "videos").mkdir()
    write_video(tmp_path / "videos" / "a.mkv", numbered(10), 30)
    write_video(tmp_path / "videos" / "b.mkv", numbered(10, base=50), 30)
    (tmp_path / "videos" / "notes.txt").write_text("ignored: not a video extension")
    assert list(find_videos(tmp_path, ["b", "a", "c"])) == ["b", "a"]
    with open_videos(tmp_path, ["a", "b", "c"], first_frame=1, video_offsets={"b": 2}, required=False) as vs:
        assert list(vs.frame_numbers) == list(range(-1, 11))
        imgs = vs.read(1)
        assert frame_code(imgs[0]) == 0 and frame_code(imgs[1]) == 52 and imgs[2] is None
        assert vs.read(10)[1] is None and vs.read(-1)[0] is None
        seen = [(f, [None if i is None else frame_code(i) for i in ims]) for f, ims in vs.iter_frames([3, 4])]
        assert seen == [(3, [2, 54, None]), (4, [3, 55, None])]
    with pytest.raises(InputError, match="no video for camera.*c"):
        open_videos(tmp_path, ["a", "b", "c"])
    with pytest.raises(InputError, match="video_offsets.zz"):
        open_videos(tmp_path, ["a", "b"], video_offsets={"zz": 1})
    write_video(tmp_path / "videos" / "typo.mkv", numbered(2), 30)
    with pytest.raises(InputError, match="typo.*calibration does not have"):
        find_videos(tmp_path, ["a", "b"])


def test_not_a_video(tmp_path):
    p = tmp_path / "x.mp4"
    p.write_text("not a video")
    with pytest.raises(InputError, match="x.mp4"):
        VideoReader(p)
    with pytest.raises(InputError, match="not found"):
        VideoReader(tmp_path / "missing.mp4")


def test_scene_video_keys():
    s = scene_from_dict({"apparatus": "vault"})
    assert s.first_frame == 1 and s.video_offsets == {}
    assert "first_frame" not in s.to_yaml_dict()
    s = scene_from_dict({"apparatus": "vault", "first_frame": 0, "video_offsets": {"cam1": -4}})
    assert s.video_offsets == {"cam1": -4} and s.to_yaml_dict()["first_frame"] == 0
    with pytest.raises(InputError, match="video_offsets"):
        scene_from_dict({"apparatus": "vault", "video_offsets": {"cam1": "x"}})


def test_open_videos_scales_a_smaller_video_of_the_same_aspect(tmp_path):
    (tmp_path / "videos").mkdir()
    write_video(tmp_path / "videos" / "a.mkv", numbered(3, h=48, w=64), 30)
    with pytest.warns(GymtrackWarning, match=r"camera 'a': the video is 64x48 but the calibration says 256x192; "
                                             r"its pixels are scaled by 4.0000 .*move by up to 192 px"):
        with open_videos(tmp_path, ["a"], sizes=[(256, 192)]) as vs:
            assert vs.pixel_scale.tolist() == [4.0]
    # Pose2Sim's demo: calibrated 1088 wide (a codec's multiple of 16), the video 1080: never silent
    write_video(tmp_path / "videos" / "b.mkv", numbered(3, h=48, w=136), 30)
    with pytest.warns(GymtrackWarning, match=r"'b': the video is 136x48 but the calibration says 137x48.*1.0074 \(x\) "
                                             r"and 1.0000"):
        open_videos(tmp_path, ["a", "b"], sizes=[(64, 48), (137, 48)]).close()
    with pytest.raises(InputError, match=r"136x48 but the calibration says 137x48.*\(--strict\)"):
        open_videos(tmp_path, ["a", "b"], sizes=[(64, 48), (137, 48)], strict=True)
    (tmp_path / "videos" / "b.mkv").unlink()
    with open_videos(tmp_path, ["a"]) as vs:
        assert vs.pixel_scale.tolist() == [1.0]
    with pytest.raises(InputError, match="64x48 but camera 'a' is calibrated at 256x144 .another aspect"):
        open_videos(tmp_path, ["a"], sizes=[(256, 144)])


def test_frames_numbered_by_timestamp_dropped_and_repeated(tmp_path):
    """Timestamps 0-4, 7-9, 9.3 (a repeat), 10-19: slots 5-6 dropped (a gap), the repeat skipped."""
    p = tmp_path / "cam0.mkv"
    ts = [0, 1, 2, 3, 4, 7, 8, 9, 9.3, *range(10, 20)]
    write_video(p, numbered(len(ts)), fps=25, timestamps=ts)
    r = VideoReader(p, first_frame=1)
    assert r.frame_numbers.tolist() == [1, 2, 3, 4, 5, 8, 9, 10, *range(11, 21)]
    code = {int(round(t)) + 1: i for i, t in enumerate(ts) if t != 9.3}  # frame -> index of the image written
    assert [(f, frame_code(im)) for f, im in r] == sorted(code.items())
    for fr in (20, 8, 11, 5, 10, 15):  # seeks by timestamp
        assert frame_code(r.read(fr)) == code[fr]
    assert r.faults.dropped == [6, 7] and r.faults.repeated == [10] and not r.faults.corrupt
    assert r.faults.summary() == "2 dropped (frames 6-7), 1 repeated skipped (at frame 10)"
    with pytest.raises(InputError, match="frame 6 was dropped"):
        r.read(6)
    assert r.try_read(7) is None


def _damage(path, first: int, n: int = 2):
    """Zero the middle half of ``n`` packets from the ``first``-th key frame on; returns the key frames' indices."""
    import av

    with av.open(str(path)) as f:
        packets = [(p.pos, p.size, p.is_keyframe) for p in f.demux(f.streams.video[0]) if p.size]
    keys = [i for i, p in enumerate(packets) if p[2]]
    data = bytearray(path.read_bytes())
    for pos, size, _ in packets[keys[first]:keys[first] + n]:
        data[pos + size // 4: pos + 3 * size // 4] = bytes(3 * size // 4 - size // 4)
    path.write_bytes(bytes(data))
    return keys


def test_corrupt_stretch_skipped_to_next_decodable_frame(tmp_path):
    p = tmp_path / "cam0.mkv"
    write_video(p, numbered(40), fps=25, options={"g": "8"})
    keys = _damage(p, 1)  # key frames every 8: file frames 8-15 do not decode
    assert keys[:3] == [0, 8, 16]
    with VideoReader(p) as r:
        got = [(f, frame_code(im)) for f, im in r]
        assert got == [(k + 1, k) for k in range(40) if not 8 <= k < 16]  # the rest stays on its frame
        assert sorted(r.faults.corrupt) == list(range(9, 17))
        assert r.faults.summary() == "8 corrupt skipped (frames 9-16)"
    with VideoReader(p) as r:  # random access: a seek into the stretch, then around it
        assert r.try_read(12) is None and frame_code(r.read(30)) == 29 and frame_code(r.read(17)) == 16
        assert frame_code(r.read(8)) == 7
        with pytest.raises(InputError, match="frame 10 cannot be decoded"):
            r.read(10)


def test_damaged_container_frames_after_it_keep_their_numbers(tmp_path):
    """A Matroska file with a block header overwritten: the demuxer resumes at the next cluster; the
    frames lost in between are a reported gap, and the frames after it keep their numbers."""
    import av

    p = tmp_path / "cam0.mkv"
    write_video(p, numbered(40), fps=25)
    with av.open(str(p)) as f:
        packets = [(q.pos, q.size) for q in f.demux(f.streams.video[0]) if q.size]
    data = bytearray(p.read_bytes())
    pos = packets[20][0]
    data[pos:pos + 12] = bytes(12)
    p.write_bytes(bytes(data))
    with VideoReader(p) as r:
        got = dict((f, frame_code(im)) for f, im in r)
        lost = sorted(set(range(1, 41)) - set(got))
        assert lost and lost[0] == 21 and all(got[f] == f - 1 for f in got)  # counting would shift 37-40 onto 21-24
        assert max(got) == 40 and r.faults.dropped == lost
        assert f"{len(lost)} dropped (frames 21-{lost[-1]})" in r.faults.summary()
