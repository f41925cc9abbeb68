"""``gymtrack batch`` on a LocalCluster: the same results as each routine alone, failures isolated,
resuming; the benchmark through the same machinery.

A small simulated suite (uneven bars, n_cam 2, 3, 4, 10 s each) on 2 worker processes.
"""

from __future__ import annotations

import csv
import shutil
from pathlib import Path

import pytest

pytest.importorskip("distributed")

from typer.testing import CliRunner  # noqa: E402

from gymtrack.batch import find_routines, output_complete, parse_steps, run_batch  # noqa: E402
from gymtrack.batch.steps import METRIC_COLUMNS, metrics_of  # noqa: E402
from gymtrack.errors import InputError  # noqa: E402
from gymtrack.modes import DEFAULT_MODE


@pytest.fixture(scope="module")
def suite(tmp_path_factory):
    from gymtrack.simulate import simulate_suite

    out = tmp_path_factory.mktemp("suite")
    simulate_suite(out, 1, seconds=10.0, seed=5, apparatus=["uneven_bars"])
    return out


def _csv(path: Path) -> dict[str, dict]:
    with open(path) as fh:
        return {r["routine"]: r for r in csv.DictReader(fh)}


def test_routines_of_a_folder_and_of_a_list(suite, tmp_path):
    names = [r.name for r in find_routines(suite)]
    assert names == ["uneven_bars/ncam2/r0", "uneven_bars/ncam3/r0", "uneven_bars/ncam4/r0"]
    lst = tmp_path / "list.txt"
    lst.write_text(f"# two of them\n{suite}/uneven_bars/ncam3/r0\n\n{suite}/uneven_bars/ncam2/r0\n")
    assert [Path(r.path) for r in find_routines(lst)] == [suite / "uneven_bars/ncam3/r0", suite / "uneven_bars/ncam2/r0"]
    lst.write_text(f"{suite}/uneven_bars/ncam3/r0\n{suite}/nowhere\n")
    with pytest.raises(InputError, match="line 2.*nowhere"):
        find_routines(lst)
    assert parse_steps("eval, track") == ("track", "eval")
    with pytest.raises(InputError, match="--steps.*unknown step 'detect'"):
        parse_steps("track,detect")


def test_batch_equals_each_routine_alone(suite, tmp_path):
    """2 workers, every step: each routine's files and metrics are those of track, pose, eval run alone."""
    from gymtrack.cli import app
    from gymtrack.eval.score import score_output

    res = run_batch(suite, tmp_path / "batch", workers=2)
    assert [r["status"] for r in res.rows] == ["ok"] * 3 and len(res.workers) == 2
    assert all(w["cache_dir"] for w in res.workers.values())
    rows = _csv(tmp_path / "batch" / "batch.csv")
    by_name = {r["routine"]: r for r in res.rows}
    runner = CliRunner()
    for r in find_routines(suite):
        alone = tmp_path / "alone" / r.name
        assert runner.invoke(app, ["track", r.path, "--out", str(alone)]).exit_code == 0
        assert runner.invoke(app, ["pose", r.path, str(alone), "--simulated-model"]).exit_code == 0
        want = metrics_of(score_output(r.path, alone))
        got = tmp_path / "batch" / r.name
        for f in ("tracks_3d.csv", "target_3d.csv", "poses_3d.csv", "target_2d/cam0.txt", "keypoints/cam0.json"):
            assert (got / f).read_bytes() == (alone / f).read_bytes(), f
        assert {k: by_name[r.name][k] for k in METRIC_COLUMNS} == want  # exactly the same numbers
        row = rows[r.name]
        assert int(row["frames"]) == 300
        for k in METRIC_COLUMNS:
            assert want[k] is not None and float(row[k]) == pytest.approx(want[k], rel=1e-5), k
        assert output_complete(got, ("track", "pose", "eval"), DEFAULT_MODE)


def test_batch_takes_a_derived_recipe_as_track_does(suite, tmp_path):
    """--without / --adding reach the workers: the routine's tracks are those of ``track --without``."""
    from gymtrack.cli import app

    runner = CliRunner()
    r = runner.invoke(app, ["batch", str(suite), "--out", str(tmp_path / "b"), "--steps", "track", "--workers", "1",
                            "--without", "floor", "--adding", "floor", "--without", "ghost_test"])
    assert r.exit_code == 0, r.output
    one = find_routines(suite)[0]
    alone = tmp_path / "alone"
    assert runner.invoke(app, ["track", one.path, "--out", str(alone), "--without", "ghost_test"]).exit_code == 0
    got = tmp_path / "b" / one.name
    assert (got / "tracks_3d.csv").read_bytes() == (alone / "tracks_3d.csv").read_bytes()
    import json
    s = json.loads((got / "summary.json").read_text())
    assert s["mode"] == "cascade+ -floor -ghost_test +floor" and s["recipe"]["ghost_test"] is False
    assert output_complete(got, ("track",), "cascade+ -floor -ghost_test +floor")
    assert not output_complete(got, ("track",), DEFAULT_MODE)  # another recipe's output is redone
    bad = runner.invoke(app, ["batch", str(suite), "--out", str(tmp_path / "bad"), "--without", "flor"])
    assert isinstance(bad.exception, InputError) and "unknown ingredient 'flor'" in str(bad.exception)


def test_failures_are_isolated_and_a_second_run_redoes_only_them(suite, tmp_path):
    """A corrupt routine and one whose worker dies mid-run are reported; the rest completes."""
    src = tmp_path / "in"
    shutil.copytree(suite, src)
    shutil.copytree(src / "uneven_bars/ncam2/r0", src / "corrupt/r0")
    det = src / "corrupt/r0/detections/cam1.txt"
    lines = det.read_text().splitlines()
    lines[6] = "7,-1,12.0,oops,40.0,80.0,0.9,-1,-1,-1"
    det.write_text("\n".join(lines) + "\n")
    out = tmp_path / "out"
    steps = ("track", "eval")
    res = run_batch(src, out, steps, workers=2, faults={"uneven_bars/ncam3/r0": "exit"})
    st = {r["routine"]: r for r in res.rows}
    assert st["uneven_bars/ncam2/r0"]["status"] == st["uneven_bars/ncam4/r0"]["status"] == "ok"
    assert st["corrupt/r0"]["status"] == "failed" and "cam1.txt" in st["corrupt/r0"]["error"]
    assert "line 7" in st["corrupt/r0"]["error"]
    killed = st["uneven_bars/ncam3/r0"]
    assert killed["status"] == "failed" and "worker process died" in killed["error"]
    assert not (out / "uneven_bars/ncam3/r0").exists() and not (out / "corrupt/r0").exists()
    first = _csv(out / "batch.csv")
    assert first["corrupt/r0"]["status"] == "failed" and first["corrupt/r0"]["error"]

    # the same command again (the worker no longer dies): only the two failed routines run
    res2 = run_batch(src, out, steps, workers=2)
    st2 = {r["routine"]: r["status"] for r in res2.rows}
    assert st2 == {"corrupt/r0": "failed", "uneven_bars/ncam2/r0": "skipped", "uneven_bars/ncam3/r0": "ok",
                   "uneven_bars/ncam4/r0": "skipped"}
    second = _csv(out / "batch.csv")
    for name in ("uneven_bars/ncam2/r0", "uneven_bars/ncam4/r0"):  # skipped rows keep their metrics
        assert {k: second[name][k] for k in ("frames", *METRIC_COLUMNS)} == {k: first[name][k] for k in ("frames", *METRIC_COLUMNS)}
    assert second["uneven_bars/ncam3/r0"]["aed_m"] != ""
    assert not list(out.rglob(".*gymtrack-tmp-*"))  # the dead worker's staging folder was cleaned up


def test_benchmark_through_the_batch_machinery(suite):
    """run_suite on 2 Dask workers gives the rows of the in-process run (tracker seconds aside)."""
    from gymtrack.batch.engine import dask_runner
    from gymtrack.eval.benchmark import read_suite, run_suite

    specs = read_suite(suite)
    methods = ["cascade", "mvpt"]
    here = run_suite(specs, methods, pose=False)
    there = run_suite(specs, methods, pose=False, runner=dask_runner(2), jobs=2)
    drop = lambda rows: [{k: v for k, v in r.items() if k != "seconds"} for r in rows]  # noqa: E731
    assert drop(there.rows) == drop(here.rows) and len(here.rows) == 6
    assert set(there.trajectories) == set(here.trajectories)


def test_ctrl_c_stops_cleanly_keeping_what_finished(suite, tmp_path):
    """SIGINT to the whole process group (a terminal's Ctrl-C) while a routine runs: the batch stops
    within seconds, batch.json lists what finished and what did not run, no staging folder stays."""
    import json
    import os
    import signal
    import subprocess
    import sys
    import time

    out = tmp_path / "out"
    code = ("import sys\nfrom gymtrack.batch import run_batch\nif __name__ == '__main__':\n"
            "    try:\n"
            f"        run_batch({str(suite)!r}, {str(out)!r}, ('track',), workers=1, faults={{'uneven_bars/ncam3/r0': 'hang'}})\n"
            "    except KeyboardInterrupt:\n        sys.exit(130)\n")
    script = tmp_path / "run.py"
    script.write_text(code)
    root = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(root), os.environ.get("PYTHONPATH", "")])}
    p = subprocess.Popen([sys.executable, str(script)], env=env, start_new_session=True,
                         preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    try:
        marker = out / "uneven_bars/ncam2/r0" / ".gymtrack-output.json"
        deadline = time.monotonic() + 120
        while not marker.is_file() and time.monotonic() < deadline and p.poll() is None:
            time.sleep(0.2)
        assert marker.is_file(), "the first routine did not finish"
        time.sleep(1.0)  # the hanging routine is running now
        os.killpg(p.pid, signal.SIGINT)
        t0 = time.monotonic()
        assert p.wait(timeout=60) == 130
        assert time.monotonic() - t0 < 30
    finally:
        if p.poll() is None:
            os.killpg(p.pid, signal.SIGKILL)
            p.wait()
    meta = json.loads((out / "batch.json").read_text())
    assert meta["interrupted"] is True and meta["not_run"] == ["uneven_bars/ncam3/r0", "uneven_bars/ncam4/r0"]
    assert [(r["routine"], r["status"]) for r in meta["rows"]] == [("uneven_bars/ncam2/r0", "ok")]
    assert not (out / "uneven_bars/ncam3/r0").exists() and not list(out.rglob(".*gymtrack-tmp-*"))
