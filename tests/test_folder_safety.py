"""The output folder as the unit of safety (gymtrack.formats.folder_lock, atomic.check_routine).

One command at a time per output folder (a second one refuses naming the holder, or waits), stale
locks of dead processes taken over, ``pose``/``eval`` of another routine's output refused unless
``--force``, and a full disk said in one line (ENOSPC simulated by patching the write).
"""

from __future__ import annotations

import errno
import json
import os
import subprocess
import sys
import textwrap
import threading
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from gymtrack.cli import app
from gymtrack.errors import InputError
from gymtrack.formats.atomic import MARKER, atomic_update, checksums, read_marker
from gymtrack.formats.folder_lock import DiskFullError, FolderBusy, folder_lock, holder, lock_path

REPO = Path(__file__).resolve().parents[1]
runner = CliRunner()


def _env() -> dict:
    return {**os.environ, "PYTHONPATH": str(REPO) + os.pathsep + os.environ.get("PYTHONPATH", "")}


@pytest.fixture(scope="module")
def routines(tmp_path_factory) -> tuple[Path, Path, Path]:
    """Two short routines and a track output of the first."""
    from gymtrack.simulate import simulate_routine

    base = tmp_path_factory.mktemp("safety")
    a, b = base / "a", base / "b"
    simulate_routine("still_rings", n_cam=3, seed=1, seconds=10).write(a)
    simulate_routine("still_rings", n_cam=3, seed=2, seconds=10).write(b)
    out = base / "out_a"
    res = runner.invoke(app, ["track", str(a), "--out", str(out), "--mode", "plane"])
    assert res.exit_code == 0, res.output
    return a, b, out


def _holder_process(out: Path, command: str) -> subprocess.Popen:
    """Another process holding ``out``'s lock until a line arrives on its stdin (prints 'held' once it holds it)."""
    code = textwrap.dedent(f"""
        import sys
        from gymtrack.formats.folder_lock import folder_lock
        with folder_lock({str(out)!r}, {command!r}):
            print("held", flush=True)
            sys.stdin.readline()
    """)
    p = subprocess.Popen([sys.executable, "-c", code], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=_env())
    assert p.stdout.readline().strip() == "held"
    return p


def _release_later(p: subprocess.Popen, seconds: float) -> threading.Timer:
    def release():
        p.stdin.write("\n")
        p.stdin.flush()

    t = threading.Timer(seconds, release)
    t.start()
    return t


# ------------------------------------------------------------------ the lock
def test_second_holder_refused_naming_the_first_then_waits(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    p = _holder_process(out, "pose")
    try:
        with pytest.raises(FolderBusy) as e:
            with folder_lock(out, "track"):
                pass
        msg = str(e.value)
        assert f"pid {p.pid}" in msg and "gymtrack pose" in msg and "since" in msg and str(out) in msg
        assert holder(out)["pid"] == p.pid
        told = []
        _release_later(p, 1.0)
        with folder_lock(out, "track", wait=60, notify=told.append):  # waits for the holder to end
            assert p.wait(timeout=10) == 0  # it had ended first
            assert holder(out)["command"] == "track" and holder(out)["pid"] == os.getpid()
        assert len(told) == 1 and f"pid {p.pid}" in told[0]
    finally:
        p.kill()
        p.wait()
    assert not lock_path(out).exists()  # the last holder removes the file


def test_readers_share_writers_exclude(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    with folder_lock(out, "eval", shared=True):
        with folder_lock(out, "eval", shared=True):  # re-entrant
            pass
        code = f"from gymtrack.formats.folder_lock import folder_lock\nwith folder_lock({str(out)!r}, 'eval', shared=True): print('ok')"
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env())
        assert r.stdout.strip() == "ok", r.stderr  # a second reader gets in
        code = f"from gymtrack.formats.folder_lock import folder_lock\nwith folder_lock({str(out)!r}, 'track'): print('ok')"
        r = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=_env())
        assert r.returncode != 0 and "FolderBusy" in r.stderr  # a writer does not
    assert not lock_path(out).exists()


def test_stale_lock_of_dead_process_is_taken_over(tmp_path):
    out = tmp_path / "out"
    out.mkdir()
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"], capture_output=True, text=True)
    pid = int(dead.stdout)
    lock_path(out).write_text(json.dumps({"pid": pid, "command": "track", "since": "2026-01-01 00:00:00 UTC"}))
    with folder_lock(out, "pose"):  # nobody holds the flock: a killed run's file is simply taken over
        assert holder(out)["pid"] == os.getpid()
    assert not lock_path(out).exists()


def test_track_and_pose_refuse_while_another_command_holds_the_folder(routines):
    a, _, out = routines
    before = checksums(out)
    p = _holder_process(out, "track")
    try:
        for args in (["track", str(a), "--out", str(out)], ["pose", str(a), str(out), "--simulated-model"],
                     ["eval", str(a), str(out), "--no-mot"]):
            res = runner.invoke(app, args)
            assert res.exit_code != 0 and isinstance(res.exception, FolderBusy), (args, res.output)
            assert f"pid {p.pid}" in str(res.exception) and "gymtrack track" in str(res.exception)
    finally:
        p.kill()
        p.wait()
    assert checksums(out) == before


def test_pose_waits_for_a_running_track(routines, tmp_path):
    """A track run replacing the folder holds it from start to swap: pose started meanwhile refuses
    (no poses of the old tracks beside the new tracks); with --wait it runs after it, on the new tracks."""
    a, _, _ = routines
    out = tmp_path / "out"
    assert runner.invoke(app, ["track", str(a), "--out", str(out), "--mode", "plane"]).exit_code == 0
    proc = subprocess.Popen([sys.executable, "-m", "gymtrack.cli", "track", str(a), "-o", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=_env())
    try:
        while proc.poll() is None and not (lock_path(out).exists() and (holder(out) or {}).get("pid") == proc.pid):
            time.sleep(0.005)
        res = runner.invoke(app, ["pose", str(a), str(out), "--simulated-model"])
        assert isinstance(res.exception, FolderBusy) and f"pid {proc.pid}" in str(res.exception), res.output
        res = runner.invoke(app, ["pose", str(a), str(out), "--simulated-model", "--wait", "120"])
        assert res.exit_code == 0, res.output
        assert proc.wait(timeout=120) == 0
    finally:
        proc.kill()
    marker = read_marker(out)
    assert marker["inputs"]["mode"] != "plane"  # pose ran on the new track output, and the marker says so
    assert marker["updates"][-1]["command"] == "pose" and checksums(out) == marker["files"]


# ------------------------------------------------------------------ which routine
def test_pose_and_eval_refuse_another_routines_output(routines):
    a, b, out = routines
    before = checksums(out)
    for args in (["pose", str(b), str(out), "--simulated-model"], ["eval", str(b), str(out), "--no-mot", "--json"]):
        res = runner.invoke(app, args)
        assert isinstance(res.exception, InputError), (args, res.output)
        msg = str(res.exception)
        assert str(a.resolve()) in msg and str(b.resolve()) in msg and "--force" in msg
    assert checksums(out) == before
    res = runner.invoke(app, ["eval", str(a), str(out), "--no-mot", "--json"])  # its own routine
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, ["eval", str(b), str(out), "--no-mot", "--json", "--force"])
    assert res.exit_code == 0, res.output
    assert json.loads(res.output)["routine"] == str(b)


# ------------------------------------------------------------------ a full disk
_FULL_DISK = """
import errno, sys
import gymtrack.formats.outputs as o
real = o.write_outputs
def write_outputs(result, folder):
    real(result, folder)  # written, then the disk fills on the next file
    with open(folder / "more.bin", "wb") as fh:
        fh.write(b"x" * 300000)
    raise OSError(errno.ENOSPC, "No space left on device")
o.write_outputs = write_outputs
sys.argv = ["gymtrack"] + sys.argv[1:]
from gymtrack.cli import main
main()
"""


def test_full_disk_is_one_line_naming_folder_and_space(routines):
    a, _, out = routines
    before = checksums(out)
    r = subprocess.run([sys.executable, "-c", _FULL_DISK, "track", str(a), "-o", str(out), "--mode", "plane"],
                       capture_output=True, text=True, env=_env(), timeout=300)
    assert r.returncode == 2, (r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1, r.stderr
    assert str(out) in lines[0] and "no space left" in lines[0] and "MB" in lines[0] and "free" in lines[0]
    assert "untouched" in lines[0]
    assert checksums(out) == before
    assert not [p for p in out.parent.iterdir() if "gymtrack-tmp" in p.name or "gymtrack-lock" in p.name]


def test_full_disk_while_adding_to_a_folder(tmp_path, monkeypatch):
    out = tmp_path / "out"
    from gymtrack.formats.atomic import atomic_output

    with atomic_output(out, "test") as st:
        (st / "a.txt").write_text("a")
    before, marker = checksums(out), read_marker(out)
    with pytest.raises(DiskFullError) as e:
        with atomic_update(out, "pose") as st:
            (st / "poses_3d.csv").write_text("x" * 2000)
            raise OSError(errno.EDQUOT, "Disk quota exceeded")
    assert str(out) in str(e.value) and "2 kB written" in str(e.value)
    assert checksums(out) == before and read_marker(out) == marker
    assert sorted(p.name for p in out.iterdir()) == [MARKER, "a.txt"]
