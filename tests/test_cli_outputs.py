"""Atomic output folders (gymtrack.formats.atomic) and ``gymtrack track`` into existing folders.

The SIGKILL test runs ``python -m gymtrack.cli track`` in a subprocess into a folder holding a
complete earlier output (another mode, so other contents) and kills it at several moments
from before the staging folder appears to after the run would have ended; the folder must
then hold exactly the old outputs or exactly the new ones (file sets and checksums).
"""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.errors import InputError
from gymtrack.formats.atomic import MARKER, atomic_output, atomic_update, checksums, is_gymtrack_output, read_marker
from gymtrack.modes import DEFAULT_MODE

REPO = Path(__file__).resolve().parents[1]
runner = CliRunner()


@pytest.fixture(scope="module")
def routine(tmp_path_factory) -> Path:
    from gymtrack.simulate import simulate_routine

    path = tmp_path_factory.mktemp("routine") / "r"
    simulate_routine("uneven_bars", n_cam=4, seed=3, seconds=10).write(path)
    return path


def _track(routine: Path, out: Path, *extra: str):
    return runner.invoke(app, ["track", str(routine), "--out", str(out), *extra])


def _env() -> dict:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(REPO) + os.pathsep + env.get("PYTHONPATH", "")
    return env


# ------------------------------------------------------------------ the helper
def test_atomic_output_replaces_whole_folder_and_writes_marker(tmp_path):
    out = tmp_path / "out"
    with atomic_output(out, "test", {"n": 1}) as st:
        (st / "a.txt").write_text("old")
        (st / "cams").mkdir()
        (st / "cams" / "cam9.txt").write_text("stale camera")
    assert is_gymtrack_output(out)
    with atomic_output(out, "test", {"n": 2}) as st:
        (st / "a.txt").write_text("new")
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "a.txt"]  # no stale cams/cam9.txt
    m = read_marker(out)
    assert m["inputs"] == {"n": 2} and m["command"] == "test"
    assert m["files"] == checksums(out) and list(m["files"]) == ["a.txt"]
    assert not [p for p in tmp_path.iterdir() if p.name != "out"]  # no staging folder left


def test_atomic_output_failure_leaves_previous_contents(tmp_path):
    out = tmp_path / "out"
    with atomic_output(out, "test") as st:
        (st / "a.txt").write_text("old")
    before = checksums(out)
    with pytest.raises(RuntimeError) as exc:
        with atomic_output(out, "test") as st:
            (st / "a.txt").write_text("half")
            raise RuntimeError("boom")
    assert checksums(out) == before and (out / "a.txt").read_text() == "old"
    assert any("untouched" in n for n in exc.value.__notes__)
    assert [p.name for p in tmp_path.iterdir()] == ["out"]


def test_non_gymtrack_folder_needs_overwrite(tmp_path):
    out = tmp_path / "mine"
    out.mkdir()
    (out / "thesis.tex").write_text("precious")
    with pytest.raises(InputError, match="--overwrite"):
        with atomic_output(out, "test"):
            pytest.fail("the body must not run")  # checked before any work
    assert (out / "thesis.tex").read_text() == "precious"
    with atomic_output(out, "test", overwrite=True) as st:
        (st / "a.txt").write_text("x")
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "a.txt"]
    empty = tmp_path / "empty"
    empty.mkdir()
    with atomic_output(empty, "test") as st:  # an empty folder needs no --overwrite
        (st / "b.txt").write_text("y")
    assert (empty / "b.txt").exists()


def test_out_is_checked_before_work(tmp_path):
    f = tmp_path / "file"
    f.write_text("x")
    for bad, words in ((f, "not a folder"), (f / "sub", "is a file")):
        with pytest.raises(InputError, match=words):
            with atomic_output(bad, "test"):
                pytest.fail("the body must not run")


def test_atomic_update_adds_and_replaces_files(tmp_path):
    out = tmp_path / "out"
    with atomic_output(out, "track") as st:
        (st / "tracks.csv").write_text("t")
        (st / "keypoints").mkdir()
        (st / "keypoints" / "cam0.json").write_text("old")
        (st / "keypoints" / "cam1.json").write_text("old")
    with atomic_update(out, "pose", {"model": "x"}) as st:
        (st / "poses_3d.csv").write_text("p")
        (st / "keypoints").mkdir()
        (st / "keypoints" / "cam0.json").write_text("new")
    assert (out / "tracks.csv").read_text() == "t" and (out / "poses_3d.csv").read_text() == "p"
    assert sorted(p.name for p in (out / "keypoints").iterdir()) == ["cam0.json"]  # the folder replaced whole
    m = read_marker(out)
    assert m["files"] == checksums(out)
    assert m["updates"][0]["command"] == "pose" and m["updates"][0]["files"] == ["keypoints/cam0.json", "poses_3d.csv"]
    before = checksums(out)
    with pytest.raises(KeyboardInterrupt):
        with atomic_update(out, "pose") as st:
            (st / "poses_3d.csv").write_text("half")
            raise KeyboardInterrupt
    assert checksums(out) == before and read_marker(out)["files"] == before
    assert not [p for p in out.iterdir() if "gymtrack-tmp" in p.name]
    with pytest.raises(InputError, match="track"):
        with atomic_update(tmp_path, "pose"):
            pass


# ------------------------------------------------------------------ the command
def test_track_into_non_output_folder_and_unwritable_out(routine, tmp_path):
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "notes.txt").write_text("keep")
    res = _track(routine, mine)
    assert isinstance(res.exception, InputError) and "--overwrite" in str(res.exception)
    assert [p.name for p in mine.iterdir()] == ["notes.txt"]
    res = _track(routine, routine.parent, "--overwrite")  # would replace the routine itself
    assert isinstance(res.exception, InputError) and "an input of this run" in str(res.exception)
    assert (routine / "scene.yaml").is_file()
    blocker = tmp_path / "blocker"
    blocker.write_text("a file")
    res = _track(routine, blocker / "out")
    assert isinstance(res.exception, InputError) and "is a file" in str(res.exception)


def test_failed_run_says_previous_outputs_untouched(routine, tmp_path):
    out = tmp_path / "out"
    assert _track(routine, out).exit_code == 0
    before = checksums(out)
    proc = subprocess.run([sys.executable, "-m", "gymtrack.cli", "track", str(routine), "-o", str(out), "--units", "mm"],
                          capture_output=True, text=True, env=_env(), timeout=120)
    assert proc.returncode == 2
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 2 and "units" in lines[0] and "previous contents" in lines[1] and "untouched" in lines[1]
    assert "Traceback" not in proc.stderr
    assert checksums(out) == before


def _run_until(cmd: list[str], staging_glob: tuple[Path, str], delay: float, writing: bool = False) -> subprocess.Popen:
    """Start ``cmd``; once a staging folder matching the glob exists (``writing``: and holds a
    file, i.e. the outputs are being written), or the process ended, wait ``delay`` s and SIGKILL it."""
    proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=_env())
    parent, pattern = staging_glob
    t_end = time.monotonic() + 120

    def ready() -> bool:
        found = list(parent.glob(pattern))
        return bool(found) and (not writing or any(True for f in found for _ in f.iterdir()))

    while proc.poll() is None and not ready() and time.monotonic() < t_end:
        time.sleep(0.001)
    time.sleep(delay)
    proc.send_signal(signal.SIGKILL)
    proc.wait(timeout=60)
    return proc


def test_sigkill_leaves_old_or_new_outputs_complete(routine, tmp_path):
    cmd = [sys.executable, "-m", "gymtrack.cli", "track", str(routine)]
    new_ref = tmp_path / "new_ref"
    proc = subprocess.Popen(cmd + ["-o", str(new_ref)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=_env())
    while not list(tmp_path.glob(".new_ref.gymtrack-tmp-*")) and proc.poll() is None:
        time.sleep(0.002)
    t_staging = time.monotonic()
    assert proc.wait(timeout=120) == 0, proc.stderr.read()
    work = time.monotonic() - t_staging  # from the staging folder to the end: reading, tracking, writing
    # summary.json holds timings, so a new run's copy differs; every other file is the same bit for bit
    new = {k: v for k, v in checksums(new_ref).items() if k != "summary.json"}
    out = tmp_path / "out"
    assert _track(routine, out, "--mode", "triangulation").exit_code == 0
    old = checksums(out)
    assert set(old) == set(new) | {"summary.json"} and old["tracks_3d.csv"] != new["tracks_3d.csv"]

    def state() -> str:
        now = checksums(out)
        assert read_marker(out)["files"] == now  # complete: the marker (written last) lists exactly what is there
        if now == old:
            return "old"
        assert {k: v for k, v in now.items() if k != "summary.json"} == new and "summary.json" in now, "a mix"
        json.loads((out / "summary.json").read_text())
        return "new"

    seen = {"old": 0, "new": 0}
    # while reading and tracking; then while the outputs are being written and moved into place
    for delay, writing in ((0.0, False), (0.5 * work, False), (0.0, True), (0.01, True), (0.05, True), (0.3, True)):
        if seen["new"]:  # back to the old outputs, so the next kill can tell
            assert _track(routine, out, "--mode", "triangulation").exit_code == 0
            old = checksums(out)
        _run_until(cmd + ["-o", str(out)], (tmp_path, ".out.gymtrack-tmp-*"), delay, writing)
        seen[state()] += 1
    # left-over staging folders of killed runs are removed by the next run
    assert _track(routine, out).exit_code == 0
    assert sorted(p.name for p in tmp_path.iterdir()) == ["new_ref", "out"]
    assert state() == "new"
    print(f"kills: {seen} (run {work:.2f} s after its staging folder appeared)")


def _mapped(pid: int, name: str) -> bool:
    """True when process ``pid`` has a shared library of ``name`` loaded (Linux)."""
    try:
        return name in Path(f"/proc/{pid}/maps").read_text()
    except OSError:
        return False


def _signal_when(proc: subprocess.Popen, ready, extra: float) -> None:
    """SIGINT to ``proc`` ``extra`` seconds after ``ready()`` first holds (or when the process ended)."""
    while proc.poll() is None and not ready():
        time.sleep(0.002)
    time.sleep(extra)
    proc.send_signal(signal.SIGINT)


#: When the Ctrl-C lands: during the imports (before any output folder exists); while reading the
#: routine or loading the kernels from numba's cache; while numba compiles them into a fresh
#: NUMBA_CACHE_DIR (the moment llvmlite used to swallow it, after the first kernel was cached).
CTRL_C_MOMENTS = ("imports", "default cache", "NUMBA_CACHE_DIR compiling")


@pytest.mark.parametrize("moment", CTRL_C_MOMENTS)
def test_ctrl_c_one_line_exit_130_nothing_half_written(routine, tmp_path, moment):
    """Ctrl-C at any moment: one line, exit 130, the previous outputs untouched, nothing left beside them
    (``tests/loop_ctrl_c.py`` runs this ten times in a row under each setting)."""
    out = tmp_path / "out"
    assert _track(routine, out).exit_code == 0
    before = checksums(out)
    env, cache = _env(), tmp_path.parent / f"{tmp_path.name}-numba"
    if moment.startswith("NUMBA_CACHE_DIR"):
        env["NUMBA_CACHE_DIR"] = str(cache)  # fresh: this run compiles
    proc = subprocess.Popen([sys.executable, "-m", "gymtrack.cli", "track", str(routine), "-o", str(out), "--mode", "plane"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env,
                            # as from a terminal, also when the suite runs in the background (SIGINT ignored)
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    start = time.monotonic()
    if moment == "imports":  # numpy is being loaded: gymtrack's code runs (not Python's own start-up)
        _signal_when(proc, lambda: _mapped(proc.pid, "numpy") or time.monotonic() - start > 20, 0.0)
    elif moment == "default cache":  # reading the routine or loading the cached kernels
        _signal_when(proc, lambda: bool(list(tmp_path.glob(".out.gymtrack-tmp-*"))), 0.05)
    else:  # a first kernel is compiled and cached; the others are being compiled
        _signal_when(proc, lambda: cache.is_dir() and any(cache.rglob("*.nbi")), 0.1)
    stdout, stderr = proc.communicate(timeout=120)
    assert proc.returncode == 130, (proc.returncode, stdout, stderr)
    notice = " ".join(stdout.split())  # the first-compile notice only (wrapped by rich), or nothing
    assert notice == "" or (notice.startswith("first run: compiling") and notice.endswith(")")), stdout
    text = stderr.strip().splitlines()
    assert len(text) == 1 and "interrupted" in text[0], text
    assert "untouched" in text[0] or "no outputs were written" in text[0], text
    assert checksums(out) == before
    assert sorted(p.name for p in tmp_path.iterdir()) == ["out"]  # no staging folder, no lock file
    assert json.loads((out / MARKER).read_text())["inputs"]["mode"] == DEFAULT_MODE
