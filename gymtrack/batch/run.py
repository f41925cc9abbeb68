"""A batch: every routine of a folder (or list) through the chosen steps, on Dask; batch.csv and batch.json.

Paper: Sections III-IV run over many performances (the paper's 140; thousands at a World
Championships). The routines are independent tasks (:func:`.steps.process_routine`) on the
workers of :mod:`.engine`; each row depends on its routine only, so the files are the same for
any number of workers or machines (apart from ``seconds``).

``<out>/batch.csv``: one row per routine in routine order, columns
:data:`.steps.BASE_COLUMNS` + :data:`.steps.METRIC_COLUMNS` (empty when not computed);
``<out>/batch.json``: the same rows plus the run (steps, mode, scheduler, each worker's numba
cache, counts, routines per minute, frames per second, what an interrupt left undone).
"""

from __future__ import annotations

import csv
import json
import math
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Mapping

from ..modes import DEFAULT_MODE
from .engine import dask_client, run_tasks, worker_reports
from .routines import STEPS, BatchRoutine, find_routines
from .steps import BASE_COLUMNS, METRIC_COLUMNS, error_text, process_routine, remove_staging

__all__ = ["BatchResult", "run_batch", "write_batch_files", "killed_row"]


@dataclass
class BatchResult:
    """What :func:`run_batch` did. rows: one per routine that finished (ok, failed or skipped), in
    routine order; not_run: routines an interrupt left undone."""

    rows: list[dict]
    routines: list[BatchRoutine]
    seconds: float
    workers: dict = field(default_factory=dict)
    interrupted: bool = False
    not_run: list[str] = field(default_factory=list)
    files: dict = field(default_factory=dict)

    def count(self, status: str) -> int:
        return sum(r["status"] == status for r in self.rows)

    @property
    def frames_done(self) -> int:
        """Frames of the routines processed in this run (skipped ones not counted)."""
        return sum(int(r.get("frames") or 0) for r in self.rows if r["status"] == "ok")


def killed_row(routine: BatchRoutine, exc: BaseException) -> dict:
    """The row of a routine whose task did not return: its worker died (``KilledWorker``) or it was lost."""
    if type(exc).__name__ == "KilledWorker":
        last = getattr(getattr(exc, "last_worker", None), "address", "?")
        error = f"its worker process died while running it (killed, e.g. out of memory, or crashed): KilledWorker, last worker {last}"
    else:
        error = f"the task failed outside the routine's steps: {error_text(exc)}"
    return {"routine": routine.name, "status": "failed", "error": error, "frames": 0, "seconds": 0.0}


def _cell(v) -> str:
    if v is None or (isinstance(v, float) and math.isnan(v)):
        return ""
    if isinstance(v, float):
        return f"{v:.6g}"
    return str(v)


def write_batch_files(out: str | Path, result: BatchResult, meta: Mapping) -> dict[str, Path]:
    """Write ``batch.csv`` and ``batch.json`` under ``out``."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    cols = (*BASE_COLUMNS, *METRIC_COLUMNS)
    with open(out / "batch.csv", "w", newline="") as fh:
        w = csv.writer(fh, lineterminator="\n")
        w.writerow(cols)
        for r in result.rows:
            w.writerow([_cell(r.get(c)) for c in cols])
    minutes = result.seconds / 60.0
    done = result.count("ok") + result.count("failed")
    data = {**meta, "seconds": round(result.seconds, 2),
            "counts": {s: result.count(s) for s in ("ok", "failed", "skipped")},
            "routines_per_minute": round(done / minutes, 2) if minutes > 0 else None,
            "frames_per_second": round(result.frames_done / result.seconds, 1) if result.seconds > 0 else None,
            "interrupted": result.interrupted, "not_run": result.not_run, "workers": result.workers,
            "rows": [{c: (None if isinstance(r.get(c), float) and math.isnan(r[c]) else r.get(c)) for c in cols}
                     for r in result.rows]}
    (out / "batch.json").write_text(json.dumps(data, indent=1) + "\n")
    return {"csv": out / "batch.csv", "json": out / "batch.json"}


def run_batch(source: str | Path, out: str | Path, steps: tuple[str, ...] = STEPS, mode: str = DEFAULT_MODE,
              workers: int | None = None, scheduler: str | None = None, force: bool = False, mot: bool = True,
              on_row: Callable[[dict, BatchResult], None] | None = None, log: Callable[[str], None] | None = None,
              faults: Mapping[str, str] | None = None, routine_options: Mapping | None = None) -> BatchResult:
    """Run ``steps`` on every routine of ``source`` into ``out``; write batch.csv / batch.json.

    source: a folder of routines or a list file (:func:`.routines.find_routines`); workers:
    LocalCluster processes (default one per CPU) when no ``scheduler`` address is given;
    force: redo complete routines; on_row: called with each finished row and the result so far;
    log: one line per worker (its numba cache); faults: routine name -> "exit" | "raise" | "hang", the
    test hook of :func:`.steps.process_routine`; routine_options: ``calibration`` / ``keypoints`` for
    every routine (:func:`.steps.run_steps`). Ctrl-C: the queued routines are cancelled, the
    files are written with what finished (``interrupted`` set) and KeyboardInterrupt is re-raised.
    """
    from ..errors import InputError
    from ..modes import method_of

    try:
        method = method_of(mode)
        if method_of(method.name) != method:  # the workers get the recipe by its name
            raise ValueError(f"recipe {method.name!r} is not named by its mode and ingredients; build it with "
                             "gymtrack.modes.recipe")
    except ValueError as e:
        raise InputError(str(e), field="--mode") from None
    mode = method.name
    routines = find_routines(source)
    out = Path(out)
    result = BatchResult([], routines, 0.0)
    by_index: dict[int, dict] = {}
    meta = {"input": str(source), "out": str(out), "steps": list(steps), "mode": mode,
            "scheduler": scheduler or f"LocalCluster({workers or 'one per CPU'} processes, 1 thread each)",
            "routines": len(routines)}
    faults = dict(faults or {})

    def done(o) -> None:
        row = o.result if o.error is None else killed_row(routines[o.index], o.error)
        by_index[o.index] = row
        result.rows = [by_index[i] for i in sorted(by_index)]
        result.seconds = time.perf_counter() - t0
        if on_row:
            on_row(row, result)

    ropts = {k: str(v) for k, v in (routine_options or {}).items() if v is not None}
    args = [(r, str(out), tuple(steps), mode, force, mot, faults.get(r.name), ropts) for r in routines]
    t0 = time.perf_counter()
    finished = False
    try:
        with dask_client(workers, scheduler) as client:
            result.workers = {a: rep for a, rep in sorted(worker_reports(client).items())}
            if log:
                for addr, rep in result.workers.items():
                    log(f"worker {addr} (pid {rep['pid']} on {rep['host']}): numba cache "
                        f"{', '.join(rep['cache_folders']) or rep['cache_dir']}, warm-up {rep['warm_up_seconds']:.2f} s")
            t0 = time.perf_counter()
            finished = run_tasks(client, process_routine, args, done, keys=[r.name.replace("/", "_") for r in routines])
            result.seconds = time.perf_counter() - t0  # the cluster's shutdown is not the routines' time
    except KeyboardInterrupt:  # while the cluster starts or stops: the files still say what finished
        finished = False
    result.interrupted = not finished
    result.not_run = [r.name for i, r in enumerate(routines) if i not in by_index]
    for i, r in enumerate(routines):  # what a killed or stopped worker left half-written
        if i not in by_index or (by_index[i]["status"] == "failed" and "worker process died" in by_index[i]["error"]):
            remove_staging(out / r.name)
    result.files = write_batch_files(out, result, meta)
    if result.interrupted:
        raise KeyboardInterrupt
    return result
