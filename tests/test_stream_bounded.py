"""Time and memory follow the frames that carry boxes, not the frame range.

A pause in the stream is jumped over (tracker and target stage), no output frame lies beyond the
input's last frame, the summary counts frames with boxes, and an absurd frame number is an error
naming the line -- checked in a subprocess for its peak memory.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
import textwrap
import time
import tracemalloc
from pathlib import Path

import numpy as np

from conftest import as_raw, make_detections, ring_rig, simple_scene

from gymtrack.detections import Detections
from gymtrack.errors import DetectionFormatError
from gymtrack.formats.motchallenge import MAX_FRAME, read_detections
from gymtrack.tracking import Tracker, TrackerOutput, track_detections
from gymtrack.tracking.target import TargetStage

REPO = Path(__file__).resolve().parents[1]
EXAMPLE = REPO / "examples" / "balance_beam"


def gymnast_and_coach(T=120, seed=0):
    """A gymnast swinging high in the plane x = 0 and a standing coach, 4 views, raw boxes."""
    rig = ring_rig([0, 80, 180, 260])
    t = np.arange(T)
    target = np.stack([0.05 * np.sin(t / 7), 1.5 * np.sin(t / 15), 1.7 + 0.8 * np.sin(t / 10)], axis=1)
    coach = np.stack([np.full(T, 1.5), np.full(T, -1.0), np.full(T, 0.9)], axis=1)
    det, _ = make_detections(rig, np.stack([target, coach]), noise=1.0, drop=0.0, seed=seed)
    return rig, simple_scene(), as_raw(det)


def shifted(det: Detections, by: int) -> Detections:
    return Detections.from_arrays(det.frame + by, det.camera, det.box, det.camera_names, score=det.score)


def test_no_output_frame_beyond_the_last_input_frame():
    rig, scene, det = gymnast_and_coach(T=120)
    for last in (96, 97, 98, 99, 100, 101):  # every phase of the last window against the input's end
        res = track_detections(rig, scene, det.select(det.frame <= last))
        assert res.tracks.frame.max() == last  # the last frame has points, none after it
        assert res.boxes.frame.max() <= last and res.target.frame.max() <= last
        assert res.target_boxes.frame.max() <= last
        assert res.summary["frames"] == last + 1 and res.summary["last_frame"] == last


def test_summary_counts_frames_with_boxes_not_the_range():
    rig, scene, det = gymnast_and_coach(T=60)
    both = Detections.concat([det, shifted(det, 5_000_000)])
    res = track_detections(rig, scene, both)
    assert res.summary["frames"] == 120  # not 5,000,060
    assert res.summary["first_frame"] == 0 and res.summary["last_frame"] == 5_000_059
    assert res.summary["fps"] < 1e6


def test_a_pause_costs_neither_time_nor_memory_and_changes_nothing_before_it():
    rig, scene, det = gymnast_and_coach(T=100)
    alone = track_detections(rig, scene, det)
    tracemalloc.start()
    t0 = time.perf_counter()
    res = track_detections(rig, scene, Detections.concat([det, shifted(det, 10**9)]))
    seconds = time.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    assert seconds < 20 and peak < 50e6  # a frame range of 10^9 would need gigabytes
    before = res.tracks.frame < 100
    np.testing.assert_array_equal(res.tracks.frame[before], alone.tracks.frame)
    np.testing.assert_array_equal(res.tracks.xyz[before], alone.tracks.xyz)
    # (alone, frames 100-101 are past the input's end; here they are the pause's first, extrapolated
    # frames, so the target's smoothing window of 2 frames differs at 98-99)
    k = np.count_nonzero(alone.target.frame < 98)
    np.testing.assert_array_equal(res.target.xyz[:k], alone.target.xyz[:k])
    # after the pause the same people are tracked again: same points, new ids
    after = res.tracks.frame >= 10**9
    np.testing.assert_allclose(res.tracks.xyz[after], alone.tracks.xyz, atol=1e-9)
    assert res.tracks.track_id[after].min() > alone.tracks.track_id.max()
    assert np.count_nonzero(res.target.frame >= 10**9) == len(alone.target) == 100
    # the pause has rows only in the max_age = 2 frames its edges are extrapolated over
    assert np.count_nonzero(res.target.frame < 10**6) == 100 + 2
    inside = res.tracks.frame[(res.tracks.frame >= 100) & (res.tracks.frame < 10**9)]
    assert set(inside.tolist()) == {100, 101, 10**9 - 2, 10**9 - 1}


def final_tracks(rig, scene, det):
    """The tracker's final 3D points and boxes of ``det``, per call of :meth:`Tracker.update`."""
    trk = Tracker(rig, scene)
    frames, first = np.unique(det.frame, return_index=True)
    bounds = np.r_[first, len(det)]
    outs = [trk.update(f, det.select(slice(bounds[i], bounds[i + 1]))) for i, f in enumerate(frames.tolist())]
    outs.append(trk.finish())
    return TrackerOutput.concat(outs, rig.names)


def run_target(rig, scene, out, runs):
    """TargetStage over the final frames in ``runs`` [(a, b), ...]; returns target rows and boxes."""
    stage = TargetStage(rig, scene)
    t, b = out.tracks, out.boxes
    res = []
    for a, z in runs:
        tsel, bsel = (t.frame >= a) & (t.frame <= z), (b.frame >= a) & (b.frame <= z)
        res.append(stage.update(a, z, t.select(tsel), b.select(bsel), {}))
    res.append(stage.finish())
    return [x for x, _ in res], [y for _, y in res], stage


def test_target_stage_jumps_a_pause_with_the_result_of_deciding_every_frame():
    rig, scene, det = gymnast_and_coach(T=100)
    gap = 2_000
    out = final_tracks(rig, scene, Detections.concat([det, shifted(det, gap)]))
    assert out.tracks.frame.min() == 0 and out.tracks.frame.max() == gap + 99
    # the pause's empty frames are 102 .. gap - 3 (the tracks extrapolate 2 frames into it at each end)
    empty = out.tracks.frame[(out.tracks.frame > 99) & (out.tracks.frame < gap)]
    assert set(empty.tolist()) == {100, 101, gap - 2, gap - 1}
    cuts = sorted({*range(0, gap + 100, 20), 102, gap - 2, gap + 100})
    dense = list(zip(cuts[:-1], [c - 1 for c in cuts[1:]]))  # runs of 20 frames: no jump
    cuts = [c for c in cuts if not 102 < c < gap - 2]
    jumped = list(zip(cuts[:-1], [c - 1 for c in cuts[1:]]))  # one run over the empty frames
    assert TargetStage(rig, scene).settle < gap - 102
    t1, b1, s1 = run_target(rig, scene, out, dense)
    t2, b2, s2 = run_target(rig, scene, out, jumped)
    from gymtrack.tracking.types import Target
    T1, T2 = Target.concat(t1), Target.concat(t2)
    assert len(T1) > 100 and np.any(T1.frame >= gap)
    np.testing.assert_array_equal(T1.frame, T2.frame)
    np.testing.assert_array_equal(T1.track_id, T2.track_id)
    np.testing.assert_array_equal(T1.xyz, T2.xyz)
    B1, B2 = Detections.concat(b1), Detections.concat(b2)
    np.testing.assert_array_equal(B1.box, B2.box)
    assert (s1.switches, s1.identifications) == (s2.switches, s2.identifications)
    # one run over the pause and the points after it (the MvPT baseline's runs): the same again
    cuts = [c for c in cuts if not 102 < c < gap + 30]
    t3, b3, s3 = run_target(rig, scene, out, list(zip(cuts[:-1], [c - 1 for c in cuts[1:]])))
    T3 = Target.concat(t3)
    np.testing.assert_array_equal(T1.frame, T3.frame)
    np.testing.assert_array_equal(T1.xyz, T3.xyz)
    np.testing.assert_array_equal(B1.box, Detections.concat(b3).box)
    # a pause of 10^9 frames: a few numpy calls, nothing of its size
    tracemalloc.start()
    t3, _, _ = run_target(rig, scene, out, [(0, 99), (100, 10**9)])
    assert tracemalloc.get_traced_memory()[1] < 20e6
    tracemalloc.stop()


def test_an_absurd_frame_number_is_an_error_naming_the_line(tmp_path):
    f = tmp_path / "cam0.txt"
    f.write_text("1,-1,10,10,5,5,0.9\n1000000000,-1,10,10,5,5,0.9\n")
    try:
        read_detections(f)
    except DetectionFormatError as e:
        assert "line 2" in str(e) and "cam0.txt" in str(e) and "1000000000" in str(e)
    else:
        raise AssertionError("frame 10^9 was accepted")
    f.write_text(f"1,-1,10,10,5,5,0.9\n{MAX_FRAME},-1,10,10,5,5,0.9\n7,-1,10,10,5,5,0.9\n")
    det, report = read_detections(f)  # the largest frame accepted: a long gap, reported
    assert report.frames == 3 and report.frame_range == (1, MAX_FRAME)
    assert report.largest_gap == MAX_FRAME - 8 and report.largest_gap_line == 2
    msg = report.gap_warning(fps=30.0)
    assert "line 2" in msg and "cam0.txt" in msg
    assert report.gap_warning(fps=1e9) is None  # at a billion frames per second it is 0.1 s


def run_track_cli(routine: Path, out: Path) -> tuple[int, str, float, float]:
    """``gymtrack track`` in a subprocess: (exit code, output, seconds, peak RSS in bytes)."""
    code = textwrap.dedent(f"""
        import resource, sys
        sys.argv = ["gymtrack", "track", {str(routine)!r}, "--out", {str(out)!r}]
        from gymtrack.cli import main
        try:
            main()
        except SystemExit as e:
            code = e.code
        else:
            code = 0
        # this process's own peak: VmHWM (ru_maxrss keeps the forking pytest's peak across exec on Linux)
        try:
            peak = [int(l.split()[1]) for l in open("/proc/self/status") if l.startswith("VmHWM")][0]
        except OSError:
            peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
        print("MAXRSS", peak)
        sys.exit(code if isinstance(code, int) else 1)
    """)
    t0 = time.perf_counter()
    p = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=600, cwd=REPO,
                       env={"PYTHONPATH": str(REPO), "PATH": "/usr/bin:/bin", "COLUMNS": "200"})
    seconds = time.perf_counter() - t0
    text = p.stdout + p.stderr
    rss = [int(line.split()[1]) * 1024 for line in p.stdout.splitlines() if line.startswith("MAXRSS")]
    return p.returncode, text, seconds, rss[0] if rss else -1


def test_track_with_one_line_at_frame_1e9_fails_quickly_naming_it(tmp_path):
    routine = tmp_path / "r"
    shutil.copytree(EXAMPLE, routine)
    cam = routine / "detections" / "cam2.txt"
    n = len(cam.read_text().splitlines())
    with open(cam, "a") as fh:
        fh.write("1000000000,-1,998.07,540.20,60.02,177.89,0.8867,-1,-1,-1\n")
    rc, text, seconds, rss = run_track_cli(routine, tmp_path / "out")
    assert rc != 0 and not (tmp_path / "out" / "tracks_3d.csv").exists()
    assert "cam2.txt" in text and f"line {n + 1}" in text and "1000000000" in text
    assert seconds < 30 and 0 < rss < 1e9


def test_track_over_a_pause_of_ten_million_frames_stays_small(tmp_path):
    routine = tmp_path / "r"
    shutil.copytree(EXAMPLE, routine)
    cam = routine / "detections" / "cam0.txt"
    n = len(cam.read_text().splitlines())
    with open(cam, "a") as fh:
        fh.write("10000000,-1,998.07,540.20,60.02,177.89,0.8867,-1,-1,-1\n")
    rc, text, seconds, rss = run_track_cli(routine, tmp_path / "out")
    assert rc == 0, text
    assert 0 < rss < 450e6  # ~280 MB (numba and the libraries); 660 MB when memory followed the range
    words = " ".join(text.split())  # (rich may wrap the line)
    assert "warning" in words and f"cam0.txt, line {n + 1}: 9999699 frames without a box" in words  # ~92 h: said
    summary = json.loads((tmp_path / "out" / "summary.json").read_text())
    assert summary["frames"] == 301 and summary["last_frame"] == 10_000_000
