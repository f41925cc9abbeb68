"""The command line's shared options, warnings, checks and exit codes (typer's CliRunner).

* an aniposelib calibration in millimetres tracked with ``--units mm`` gives the tracks of the
  same calibration in metres; without ``--units`` the far-camera warning and the "no 3D tracks"
  warning come as one-line ``warning:`` messages (not a Python ``UserWarning``), ``--strict``
  exits 3 and writes nothing;
* the stream checks (silent camera, gaps, boxes outside the image) against hand-worked answers,
  and as reported by ``info``;
* ``info --system``, the first-compile notice, ``benchmark --check``, flags shown as ``--plot``,
  messages without pydantic's wording.
"""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.cli.report import StrictFailure
from gymtrack.detections import Detections
from gymtrack.errors import InputError
from gymtrack.formats.checks import check_detections
from gymtrack.formats.outputs import read_tracks_3d
from gymtrack.formats.routine import load_routine
from gymtrack.geometry import Camera, Rig

runner = CliRunner()
WIDE = {"COLUMNS": "200", "TERMINAL_WIDTH": "200"}


@pytest.fixture(scope="module")
def routine(tmp_path_factory) -> Path:
    from gymtrack.simulate import simulate_routine

    path = tmp_path_factory.mktemp("routine") / "r"
    simulate_routine("still_rings", n_cam=4, seed=1, seconds=10).write(path)
    return path


def _anipose_toml(rig, scale: float) -> str:
    parts = []
    for i, c in enumerate(rig):
        parts.append(
            f"[cam_{i}]\nname = \"{c.name}\"\nsize = [{c.size[0]}, {c.size[1]}]\n"
            f"matrix = {json.dumps(c.K.tolist())}\ndistortions = {json.dumps(c.dist.tolist())}\n"
            f"rotation = {json.dumps(c.rvec.tolist())}\ntranslation = {json.dumps((c.t * scale).tolist())}\n"
        )
    return "\n".join(parts)


def _with_anipose(routine: Path, dest: Path, scale: float) -> Path:
    shutil.copytree(routine, dest)
    rig = load_routine(routine).rig
    (dest / "cameras.yaml").unlink()
    (dest / "calibration.toml").write_text(_anipose_toml(rig, scale))
    return dest


# ------------------------------------------------------------------ calibration options
def test_anipose_in_mm_with_units_gives_the_tracks_in_metres(routine, tmp_path):
    in_m = _with_anipose(routine, tmp_path / "m", 1.0)
    in_mm = _with_anipose(routine, tmp_path / "mm", 1000.0)
    res = runner.invoke(app, ["track", str(in_m), "-o", str(tmp_path / "out_m")])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["track", str(in_mm), "-o", str(tmp_path / "out_mm"), "--units", "mm", "--strict"])
    assert res.exit_code == 0, res.output
    assert "warning" not in res.output
    a, b = read_tracks_3d(tmp_path / "out_m" / "tracks_3d.csv"), read_tracks_3d(tmp_path / "out_mm" / "tracks_3d.csv")
    assert len(a["frame"]) > 100
    for k in ("frame", "track_id", "source", "n_views"):
        assert np.array_equal(a[k], b[k]), k
    np.testing.assert_allclose(a["xyz"], b["xyz"], atol=2e-4)  # 4 decimals written; scaling rounds in the last bit
    ta = (tmp_path / "out_m" / "target_3d.csv").read_text().splitlines()
    tb = (tmp_path / "out_mm" / "target_3d.csv").read_text().splitlines()
    assert len(ta) == len(tb) > 100


def test_mm_without_units_warns_once_through_the_reporter_and_strict_fails(routine, tmp_path):
    in_mm = _with_anipose(routine, tmp_path / "mm", 1000.0)
    res = runner.invoke(app, ["track", str(in_mm), "-o", str(tmp_path / "out")])
    assert res.exit_code == 0, res.output
    warn = [ln for ln in res.output.splitlines() if ln.startswith("warning:")]
    assert any("from the world origin" in w and "--units mm" in w for w in warn), res.output
    assert any(w.startswith("warning: no 3D tracks") and "--units" in w and "world frame" in w for w in warn), res.output
    assert "UserWarning" not in res.output and "warnings.warn" not in res.output
    res = runner.invoke(app, ["track", str(in_mm), "-o", str(tmp_path / "strict"), "--strict"])
    assert isinstance(res.exception, StrictFailure)
    assert "nothing was written" in " ".join(res.exception.__notes__)
    assert not (tmp_path / "strict").exists()
    res = runner.invoke(app, ["info", str(in_mm), "--units", "mm", "--strict"])
    assert res.exit_code == 0, res.output
    assert "translations in mm" in res.output


def test_units_on_a_format_without_units_is_a_clear_error(routine, tmp_path):
    res = runner.invoke(app, ["track", str(routine), "-o", str(tmp_path / "o"), "--units", "mm"])
    assert isinstance(res.exception, InputError)
    assert "'units' does not apply to the native format" in str(res.exception)
    assert not (tmp_path / "o").exists()


# ------------------------------------------------------------------ stream checks
def _rig(n: int = 2) -> Rig:
    K = [[1000, 0, 960], [0, 1000, 540], [0, 0, 1]]
    return Rig([Camera(f"c{i}", (1920, 1080), K, np.eye(3), [0.0, 0.0, 10.0 + i]) for i in range(n)])


def test_check_detections_hand_worked():
    # c0: frames 1..100 and 200..300; c1: frames 1..300 but nothing anywhere in 121..180 besides c0's gap
    f0 = np.r_[1:101, 200:301]
    f1 = np.r_[1:121, 181:301]
    frame = np.r_[f0, f1]
    cam = np.r_[np.zeros(f0.size), np.ones(f1.size)]
    box = np.tile([960.0, 540.0, 50.0, 100.0], (frame.size, 1))
    box[0] = [3000.0, 540.0, 50.0, 100.0]  # wholly right of the 1920-wide image
    box[1] = [1900.0, 540.0, 50.0, 100.0]  # reaches 5 px beyond the border
    d = Detections.from_arrays(frame, cam, box, ("c0", "c1"))
    ch = check_detections(d, _rig(), fps=10.0, silent_seconds=5.0)  # silent: more than 50 frames
    assert ch.frame_range == (1, 300) and ch.frames_with_data == 300 - 60
    assert [(g.first, g.last, g.frames) for g in ch.gaps] == [(121, 180, 60)]
    # c0's 101..199 (99 frames) is not inside the common gap 121..180, so it is reported
    assert [(s.camera, s.first, s.last) for s in ch.silences] == [("c0", 101, 199)]
    assert ch.outside == {"c0": pytest.approx(1 / f0.size), "c1": 0.0}
    assert ch.partly_outside == {"c0": pytest.approx(2 / f0.size), "c1": 0.0}
    msgs = ch.warnings()
    assert any("frames 121..180 (60 frames, 6.0 s)" in m for m in msgs)
    assert any(m.startswith("camera c0 goes silent") and "101..199" in m for m in msgs)
    assert any("wholly outside" in m and "c0" in m for m in msgs)
    quiet = check_detections(d, _rig(), fps=10.0, silent_seconds=10.0)  # 99 frames = 9.9 s, not more than 10 s
    assert quiet.silences == () and quiet.gaps == ()
    none = check_detections(Detections.empty(("c0", "c1")), _rig(), fps=10.0)
    assert none.frame_range is None and none.warnings() == []


def test_info_reports_a_silent_camera_and_strict_fails(routine, tmp_path):
    r = shutil.copytree(routine, tmp_path / "r")
    p = r / "detections" / "cam2.txt"
    lines = p.read_text().splitlines()
    p.write_text("\n".join(ln for ln in lines if int(ln.split(",")[0]) < 100) + "\n")  # silent from frame 100
    res = runner.invoke(app, ["info", str(r)], env=WIDE)
    assert res.exit_code == 0, res.output
    warn = [ln for ln in res.output.splitlines() if ln.startswith("warning:")]
    assert len(warn) == 1 and "camera cam2 goes silent: no detections in frames 100..300" in warn[0], res.output
    assert "silent frames" in res.output and "outside image" in res.output
    res = runner.invoke(app, ["info", str(r), "--strict"])
    assert isinstance(res.exception, StrictFailure)
    res = runner.invoke(app, ["info", str(r), "--silent-seconds", "10", "--strict"])  # 201 frames = 6.7 s
    assert res.exit_code == 0, res.output


# ------------------------------------------------------------------ system, compile notice
def test_info_system(monkeypatch):
    res = runner.invoke(app, ["info", "--system"], env=WIDE)
    assert res.exit_code == 0, res.output
    for word in ("python", "numpy", "numba", "opencv", "gymtrack", "numba cache", "CPUs"):
        assert word in res.output, word
    res = runner.invoke(app, ["info"])
    assert isinstance(res.exception, InputError) and "--system" in str(res.exception)


def test_compile_notice_when_the_cache_is_cold(monkeypatch, tmp_path):
    from gymtrack.cli.system import compile_notice, numba_cache

    monkeypatch.setenv("NUMBA_CACHE_DIR", str(tmp_path))
    assert not numba_cache().warm
    note = compile_notice()
    assert note is not None and "40-60 s" in note and str(tmp_path) in note
    # numba's layout under NUMBA_CACHE_DIR: <folder name>_<sha1 of the folder's path>/<module>.<function>-<line>.pyXY.nbi
    import hashlib

    import gymtrack.tracking

    d = Path(gymtrack.tracking.__file__).resolve().parent
    sub = tmp_path / f"tracking_{hashlib.sha1(str(d).encode()).hexdigest()}"
    sub.mkdir()
    (sub / "_compiled.kernel-10.py311.nbi").write_bytes(b"")
    assert numba_cache().warm and compile_notice() is None
    assert numba_cache().locations == (sub,)


# ------------------------------------------------------------------ benchmark --check
def test_benchmark_check_exits_1_when_a_claim_fails(monkeypatch, tmp_path):
    import gymtrack.eval.aggregate as aggregate
    import gymtrack.eval.benchmark as bench
    from gymtrack.eval.aggregate import Claim

    class Run:
        rows: list = []
        seconds = 0.0

    suite = tmp_path / "suite"
    suite.mkdir()
    monkeypatch.setattr(bench, "read_suite", lambda s: [])
    monkeypatch.setattr(bench, "run_suite", lambda *a, **k: Run())
    monkeypatch.setattr(bench, "write_benchmark", lambda *a, **k: {"report": tmp_path / "report.md"})
    claims = [Claim("speed", 2000.0, 1000.0, "PASS", ""), Claim("n_cam=2: FR", 0.5, 0.3, "FAIL", "")]
    monkeypatch.setattr(aggregate, "claims", lambda rows, config=None: claims)
    args = ["benchmark", "--suite", str(suite), "--out", str(tmp_path / "b"), "--no-wildtrack", "--no-pose"]
    assert runner.invoke(app, args).exit_code == 0  # without --check: a report, status 0
    res = runner.invoke(app, args + ["--check"], env=WIDE)
    assert res.exit_code == 1 and "1 target(s) failed (n_cam=2: FR)" in res.output, res.output
    claims[1] = Claim("n_cam=2: FR", 0.2, 0.3, "PASS", "")
    res = runner.invoke(app, args + ["--check"])
    assert res.exit_code == 0 and "--check passed" in res.output, res.output


# ------------------------------------------------------------------ wording
def test_flags_show_without_a_type():
    for cmd in (["simulate", "--help"], ["track", "--help"], ["benchmark", "--help"], ["info", "--help"]):
        res = runner.invoke(app, cmd, env=WIDE)
        assert res.exit_code == 0 and "<bool>" not in res.output, res.output
    res = runner.invoke(app, ["simulate", "--help"], env=WIDE)
    assert "--plot" in res.output and "<int>" in res.output  # other options keep their type


def test_messages_in_the_projects_words(routine, tmp_path):
    r = shutil.copytree(routine, tmp_path / "r")
    (r / "cameras.yaml").write_text("")
    res = runner.invoke(app, ["info", str(r)])
    assert isinstance(res.exception, InputError)
    assert "cameras.yaml" in str(res.exception) and "empty file" in str(res.exception) and "NoneType" not in str(res.exception)
    shutil.copy(routine / "cameras.yaml", r / "cameras.yaml")
    (r / "scene.yaml").write_text("apparatus: trampoline\n")
    res = runner.invoke(app, ["info", str(r)])
    msg = str(res.exception)
    assert "scene.yaml" in msg and "unknown apparatus 'trampoline'" in msg and "Value error" not in msg
    (r / "scene.yaml").write_text("apparatus: vault\nfps: fast\n")
    msg = str(runner.invoke(app, ["info", str(r)]).exception)
    assert "field 'fps': must be a number, got the text 'fast'" in msg
