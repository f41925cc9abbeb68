"""``gymtrack batch --scheduler``: a real ``dask scheduler`` and ``dask worker`` in their own
processes (127.0.0.1 only, bounded waits, always stopped), a small batch through the CLI."""

from __future__ import annotations

import csv
import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

pytest.importorskip("distributed")

REPO = Path(__file__).resolve().parents[1]


def _start(args: list[str], log: Path, env: dict) -> subprocess.Popen:
    return subprocess.Popen([sys.executable, "-m", *args], stdout=open(log, "w"), stderr=subprocess.STDOUT, env=env,
                            start_new_session=True)  # own process group: the worker's nanny child goes with it


def _stop(p: subprocess.Popen) -> None:
    if p.poll() is None:
        os.killpg(p.pid, signal.SIGTERM)
        try:
            p.wait(timeout=15)
        except subprocess.TimeoutExpired:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait(timeout=5)


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from gymtrack.simulate import simulate_suite

    out = tmp_path_factory.mktemp("suite")
    simulate_suite(out, 1, seconds=10.0, seed=7, apparatus=["balance_beam"], n_cams=(2, 3))
    return out


def test_batch_on_a_separate_scheduler_and_worker(suite, tmp_path):
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    sfile = tmp_path / "scheduler.json"
    procs = []
    try:
        procs.append(_start(["distributed.cli.dask_scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                             "--scheduler-file", str(sfile)], tmp_path / "scheduler.log", env))
        deadline = time.monotonic() + 60
        while not sfile.is_file() and time.monotonic() < deadline:
            assert procs[0].poll() is None, (tmp_path / "scheduler.log").read_text()
            time.sleep(0.2)
        time.sleep(0.2)  # the file is written in one go, but give it a moment
        address = json.loads(sfile.read_text())["address"]
        assert address.startswith("tcp://127.0.0.1:")
        procs.append(_start(["distributed.cli.dask_worker", address, "--host", "127.0.0.1", "--nthreads", "1",
                             "--nworkers", "1", "--no-dashboard", "--death-timeout", "60"], tmp_path / "worker.log", env))
        out = tmp_path / "out"
        cmd = [sys.executable, "-c", "from gymtrack.cli import main; main()", "batch", str(suite), "--out", str(out),
               "--steps", "track,eval", "--scheduler", address]
        run = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
        assert run.returncode == 0, run.stdout + run.stderr + (tmp_path / "worker.log").read_text()
        assert "numba cache" in run.stdout
        with open(out / "batch.csv") as fh:
            rows = list(csv.DictReader(fh))
        assert [r["routine"] for r in rows] == ["balance_beam/ncam2/r0", "balance_beam/ncam3/r0"]
        assert all(r["status"] == "ok" and r["frames"] == "300" and r["aed_m"] for r in rows)
        meta = json.loads((out / "batch.json").read_text())
        assert meta["scheduler"] == address and len(meta["workers"]) == 1
        # the worker ran them: the same numbers as a routine run in this process
        from gymtrack.batch.routines import find_routines
        from gymtrack.batch.steps import process_routine

        for r, row in zip(find_routines(suite), rows):
            here = process_routine(r, str(tmp_path / "here"), ("track", "eval"))
            assert here["status"] == "ok" and f"{here['aed_m']:.6g}" == row["aed_m"] and f"{here['fr']:.6g}" == row["fr"]
        # resuming through the scheduler: nothing left to do
        again = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=300)
        assert again.returncode == 0 and "0 ok, 0 failed, 2 skipped" in again.stdout
    finally:
        for p in reversed(procs):
            _stop(p)
