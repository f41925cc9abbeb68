"""The benchmark: every method on every routine of a suite, evaluated against ground truth.

Paper: Section IV (Tables 3, 5, 6 and Fig. 6). Methods:

* ``cascade``, ``triangulation``, ``plane``: the tracker's modes (Table 6's ablation);
* ``mvpt``: the frame-by-frame baseline of :mod:`gymtrack.eval.mvpt`;
* ``oracle``: the ground-truth association (detections labelled by :func:`gymtrack.eval.gt.with_gt_ids`)
  fed to the cascade's 3D estimation (``association="oracle"``): the limit better association
  could reach, not a method.

Each routine is one task (:func:`run_routine`) of the runner :func:`run_suite` is given -- the
batch machinery's Dask workers (:func:`gymtrack.batch.engine.dask_runner`: a LocalCluster or a
scheduler) or this process: the task reads the routine folder and its ground truth, runs every
method, and returns one row per method with the additive parts of every metric
(:mod:`gymtrack.eval.aggregate` pools and tabulates them). Speed is the tracker call alone, timed
with ``time.perf_counter`` around it (file reading, GT matching and evaluation excluded), in the
worker process -- so with several workers the methods of one routine share a core with other
routines' work, equally for every method.
"""

from __future__ import annotations

import json
import os
import time
import traceback
import zlib
from concurrent.futures import ProcessPoolExecutor, as_completed
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Sequence

import numpy as np

from ..detections import Detections
from ..errors import InputError, RoutineError
from ..scene import Scene
from ..geometry.camera import Rig
from ..formats.ground_truth import GroundTruth, load_ground_truth
from .gt import with_gt_ids
from .metrics import (
    average_euclidean_distance,
    coverage,
    failure_rate,
    in_box,
    mot_metrics,
    target_id_switches,
)
from .aggregate import METHODS
from .explain import CAUSES, explain_failures

#: Apparatus whose n_cam = 2 routine is drawn like the paper's Fig. 6.
FIG6_APPARATUS: tuple[str, ...] = ("balance_beam", "uneven_bars", "parallel_bars")


@dataclass(frozen=True)
class RoutineSpec:
    """One routine of a suite: its folder and what it is."""

    name: str
    path: str
    apparatus: str
    n_cam: int
    seed: int = 0


# ----------------------------------------------------------------------------- methods
def method_name(method) -> str:
    """A method's name in the rows: the name itself, or a recipe's (:class:`gymtrack.modes.Method`) name."""
    return method if isinstance(method, str) else method.name


def run_method(method, rig: Rig, scene: Scene, det: Detections, gt: GroundTruth | None = None):
    """Run one method (a name, or a tracker recipe :class:`gymtrack.modes.Method`); returns
    ``(TrackResult, tracker seconds, extra summary dict)``.

    The oracle needs ``gt``: its GT matching happens before the clock starts.
    """
    from ..tracking.offline import track_detections
    from ..modes import MODES, Method

    extra: dict = {}
    if isinstance(method, Method) or method in MODES:
        t0 = time.perf_counter()
        res = track_detections(rig, scene, det, mode=method)
    elif method == "mvpt":
        from .mvpt import track_mvpt

        t0 = time.perf_counter()
        res = track_mvpt(rig, scene, det)
    elif method == "oracle":
        if gt is None:
            raise InputError("the oracle needs the routine's ground truth (gt/)", field="oracle")
        det, m = with_gt_ids(det, gt)
        extra = {"oracle_matched": m.matched, "oracle_unmatched": m.unmatched}
        t0 = time.perf_counter()
        res = track_detections(rig, scene, det, mode="cascade", association="oracle")
    else:
        raise InputError(f"unknown method {method!r}; choose from {', '.join(METHODS)}", field="methods")
    return res, time.perf_counter() - t0, extra


# ----------------------------------------------------------------------------- evaluation
def evaluate_routine(result, gt: GroundTruth, scene: Scene, rig: Rig | None = None, mot: bool = True) -> dict:
    """Every metric of one method on one routine, as additive parts (see :mod:`.report`).

    result: a :class:`~gymtrack.tracking.types.TrackResult` (``target``, ``target_boxes``,
    ``tracks``); gt: the routine's ground truth with the same cameras; scene: for ``S_perf`` and
    ``S_track``; rig: for the image sizes (the FR clips boxes to the image); mot: also compute the
    all-people MOT metrics (the slowest part, ~1 ms per frame).
    """
    perf_space = np.asarray(scene.performance_space, dtype=np.float64)
    t = gt.target()
    perf_rows = t.performing(perf_space)
    perf_frames = np.unique(t.frame[perf_rows])
    tg = result.target
    sw = target_id_switches(perf_frames, tg.frame, tg.track_id, tg.xyz, gt.frame, gt.person_id, gt.xyz)
    aed = average_euclidean_distance(t.frame, t.xyz, tg.frame, tg.xyz, frames=perf_frames)
    vis = t.box_visible & np.isin(t.box_frame, perf_frames)
    size = None if rig is None else np.array([c.size for c in rig], dtype=np.float64)
    tb = result.target_boxes
    fr = failure_rate(t.box_frame[vis], t.box_camera[vis], t.box[vis], tb.frame, tb.camera, tb.box, image_size=size)
    cov = coverage(perf_frames, tg.frame)
    row = {
        "idsw": sw.total, "idsw_track": sw.track_id_changes, "idsw_person": sw.person_changes,
        "aed_sum": aed.total, "aed_n": aed.n,
        "fr_failures": fr.failures, "fr_evaluated": fr.evaluated, "fr_missing": fr.missing,
        "fr_outside": fr.outside, "fr_too_small": fr.too_small,
        "cov_covered": cov.covered, "cov_frames": cov.frames,
    }
    if mot:
        tr = result.tracks
        region = in_box(gt.xyz, scene.tracking_space)
        m = mot_metrics(gt.frame, gt.person_id, gt.xyz, tr.frame, tr.track_id, tr.xyz, max_dist=1.0, gt_in_region=region)
        row |= {"mota": m.mota, "idf1": m.idf1, "mot_idsw": m.id_switches, "mot_fp": m.false_positives,
                "mot_fn": m.misses, "mot_objects": m.objects}
    return row


# ----------------------------------------------------------------------------- one routine
def run_routine(spec: RoutineSpec, methods: Sequence[str], keep_trajectories: bool = False, mot: bool = True,
                pose: bool = True) -> dict:
    """Load a routine folder and its GT, run and evaluate every method (a worker task).

    pose: also the target's 3D pose from each method's boxes (:mod:`.pose_bench`), when the
    routine has ``gt/keypoints_3d.csv``.

    Returns ``{"rows": [...], "trajectories": {...} | None, "spec": ...}``; a method that raises
    gives a row with ``error`` set instead of stopping the benchmark.
    """
    from ..formats.routine import load_routine

    r = load_routine(spec.path)
    size = np.array([c.size for c in r.rig], dtype=np.float64)
    gt = load_ground_truth(spec.path, r.rig.names, image_size=size)
    rows, traj = [], {}
    from .pose_bench import PoseGroundTruth, add_common_columns, pose_columns

    base = {"routine": spec.name, "apparatus": spec.apparatus, "n_cam": spec.n_cam, "seed": spec.seed}
    try:  # the pose part must not cost the tracking rows
        pgt = PoseGroundTruth.load(spec.path, gt, r.scene.performance_space) if pose else None
    except Exception as exc:
        pgt, base["pose_error"] = None, f"{type(exc).__name__}: {exc}"
    from .judging import judging_truth

    jt = None if pgt is None else judging_truth(spec.path, r.scene, pgt, base)
    if keep_trajectories:
        t = gt.target()
        traj["GT"] = (t.frame, t.xyz)
        traj["fps"] = float(r.scene.fps)
    from ..tracking import warm_up

    warm_up()  # numba's compile/cache load: once per process, never tracking time
    # the first method on a new rig pays its one-off costs (caches, memory): rotate the order per
    # routine so that no method is always first; rows keep the order of ``methods``
    k = zlib.crc32(spec.name.encode()) % max(len(methods), 1)
    order = list(methods[k:]) + list(methods[:k])
    for method in order:
        try:
            res, sec, extra = run_method(method, r.rig, r.scene, r.detections, gt)
            row = {**base, "method": method_name(method), "frames": int(res.summary.get("frames", 0)), "seconds": sec,
                   **evaluate_routine(res, gt, r.scene, r.rig, mot=mot),
                   "target_switches": int(res.summary.get("target_switches", 0)), "error": "", **extra}
            why = explain_failures(res, r.detections, gt, r.scene, r.rig)  # the FR's failures by cause (.explain)
            row |= {f"why_{c}": why[c] for c in CAUSES}
            if pgt is not None:
                row |= pose_columns(method, res, r.rig, r.scene, pgt, seed=spec.seed, judging=jt)
            if keep_trajectories:
                traj[method_name(method)] = (res.target.frame, res.target.xyz)
        except Exception as exc:  # one failing method must not lose the others' results
            detail = "".join(traceback.format_exception_only(type(exc), exc)).strip()
            row = {**base, "method": method_name(method), "frames": 0, "seconds": 0.0, "error": detail}
        rows.append(row)
    add_common_columns(rows)  # the pose claims' common-frame columns: needs every method's row
    names = [method_name(m) for m in methods]
    rows.sort(key=lambda row: names.index(row["method"]))
    if jt is not None and rows:  # the definitions check, once per routine
        rows[0]["judge_truth_parts"] = json.dumps(jt.truth_parts())
    return {"rows": rows, "trajectories": traj if keep_trajectories else None, "spec": spec.__dict__}


# ----------------------------------------------------------------------------- suites
def read_suite(suite: str | Path) -> list[RoutineSpec]:
    """The routines of a suite folder.

    Reads ``suite.json`` when present: a list of routine entries, or a mapping with a
    ``routines`` list; each entry names its folder (``path``, relative to the suite, or ``name``)
    and gives ``apparatus``, ``n_cam`` and ``seed`` (what is missing is read from the routine's
    scene.yaml / calibration). Without ``suite.json``, every sub-folder holding a ``scene.yaml``
    is a routine.
    """
    suite = Path(suite)
    if not suite.is_dir():
        raise RoutineError("suite folder not found", source=suite)
    index = suite / "suite.json"
    entries: list[dict] = []
    if index.is_file():
        try:
            data = json.loads(index.read_text())
        except json.JSONDecodeError as exc:
            raise RoutineError(f"not valid JSON: {exc.msg}", source=index, line=exc.lineno) from None
        items = data.get("routines", data) if isinstance(data, dict) else data
        if not isinstance(items, list):
            raise RoutineError("expected a list of routines (or {'routines': [...]})", source=index)
        for k, e in enumerate(items):
            if isinstance(e, str):
                e = {"path": e}
            if not isinstance(e, dict) or not (e.get("path") or e.get("name")):
                raise RoutineError("each routine needs a 'path' (or 'name')", source=index, field=f"routines[{k}]")
            entries.append(e)
    else:
        entries = [{"path": p.name} for p in sorted(suite.iterdir()) if (p / "scene.yaml").is_file()]
    if not entries:
        raise RoutineError("the suite has no routines (no suite.json and no sub-folder with a scene.yaml)", source=suite)
    specs = []
    for k, e in enumerate(entries):
        rel = e.get("path") or e.get("name")
        path = Path(rel) if Path(rel).is_absolute() else suite / rel
        if not path.is_dir():
            raise RoutineError(f"routine folder {rel!r} not found", source=index if index.is_file() else suite, field=f"routines[{k}]")
        app, n_cam = e.get("apparatus"), e.get("n_cam")
        if app is None or n_cam is None:
            app, n_cam = _describe(path, app, n_cam)
        specs.append(RoutineSpec(name=str(e.get("name") or Path(rel).as_posix()), path=str(path), apparatus=str(app), n_cam=int(n_cam),
                                 seed=int(e.get("seed", 0))))
    return specs


def _describe(path: Path, app, n_cam) -> tuple[str, int]:
    """Apparatus (scene.yaml) and number of cameras (calibration) of a routine folder."""
    import yaml

    if app is None:
        data = yaml.safe_load((path / "scene.yaml").read_text()) or {}
        app = data.get("apparatus") or "custom"
    if n_cam is None:
        from ..formats.calibration import find_calibration, read_calibration

        rig, _ = read_calibration(find_calibration(path, error=RoutineError))
        n_cam = len(rig)
    return app, n_cam


#: The default suite of ``gymtrack benchmark`` without ``--suite``: routines per apparatus and
#: seconds per routine, sized to run (simulation + benchmark) in under 10 minutes on 2 cores.
#: (With 2 per apparatus the n_cam = 2 FR ratio moved between 0.18 and 0.37 from one suite
#: seed to another: 4 halves that spread's variance.)
DEFAULT_PER_APPARATUS = 4
DEFAULT_SECONDS = 25.0


def _simulate_apparatus(out: str, apparatus: str, per_apparatus: int, seconds: float | None, seed: int) -> list[dict]:
    from ..simulate import simulate_suite

    return simulate_suite(Path(out), per_apparatus, seconds=seconds, seed=seed, apparatus=[apparatus])


def simulate_default_suite(out: str | Path, per_apparatus: int = DEFAULT_PER_APPARATUS, seconds: float | None = DEFAULT_SECONDS,
                           seed: int = 0, jobs: int | None = None, progress: Callable[[int, int, str], None] | None = None) -> Path:
    """Simulate the suite (7 apparatus x ``per_apparatus`` x n_cam 2, 3, 4) into ``out``, apparatus in parallel.

    The same routines and seeds as ``gymtrack simulate-suite --per-apparatus K --seconds S``
    (:func:`gymtrack.simulate.simulate_suite`, one call per apparatus in a process pool); the
    ``suite.json`` index is written once at the end with every apparatus' entries.
    """
    from ..apparatus import APPARATUS_NAMES

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    jobs = max(1, int(jobs or os.cpu_count() or 1))
    entries: dict[str, list[dict]] = {}
    with ProcessPoolExecutor(max_workers=min(jobs, len(APPARATUS_NAMES))) as pool:
        futs = {pool.submit(_simulate_apparatus, str(out), a, per_apparatus, seconds, seed): a for a in APPARATUS_NAMES}
        for k, fut in enumerate(as_completed(futs)):
            entries[futs[fut]] = fut.result()
            if progress:
                progress(k + 1, len(APPARATUS_NAMES), futs[fut])
    index = {"base_seed": int(seed), "per_apparatus": int(per_apparatus), "seconds": seconds, "n_cams": [2, 3, 4],
             "layout": "<apparatus>/ncam<n>/r<k>", "routines": [e for a in APPARATUS_NAMES for e in entries[a]]}
    (out / "suite.json").write_text(json.dumps(index, indent=1) + "\n")
    return out


def seeded_suites(out: str | Path, seeds: Sequence[int], per_apparatus: int = DEFAULT_PER_APPARATUS,
                   seconds: float | None = DEFAULT_SECONDS, jobs: int | None = None,
                   progress: Callable[[int, int, str], None] | None = None) -> list[RoutineSpec]:
    """The routines of one default suite per base seed, ``<out>/suite-s<seed>`` (simulated unless
    its ``suite.json`` exists), named ``s<seed>/<routine>`` so that names stay unique when the
    suites are pooled (:mod:`.pooled`)."""
    from dataclasses import replace

    specs: list[RoutineSpec] = []
    for seed in seeds:
        folder = Path(out) / f"suite-s{int(seed)}"
        if not (folder / "suite.json").is_file():
            simulate_default_suite(folder, per_apparatus, seconds, seed=int(seed), jobs=jobs, progress=progress)
        specs += [replace(s, name=f"s{int(seed)}/{s.name}") for s in read_suite(folder)]
    return specs


@dataclass
class BenchmarkRun:
    """What :func:`run_suite` produced."""

    rows: list[dict]
    trajectories: dict[str, dict] = field(default_factory=dict)  #: routine -> series for Fig. 6
    specs: list[RoutineSpec] = field(default_factory=list)
    seconds: float = 0.0
    jobs: int = 1


def fig6_routines(specs: Sequence[RoutineSpec]) -> set[str]:
    """The first n_cam = 2 routine of each Fig. 6 apparatus (balance beam, uneven bars, parallel bars)."""
    out: dict[str, str] = {}
    for s in specs:
        if s.n_cam == 2 and s.apparatus in FIG6_APPARATUS and s.apparatus not in out:
            out[s.apparatus] = s.name
    return set(out.values())


def _failed_routine(spec: RoutineSpec, methods: Sequence[str], exc: BaseException) -> dict:
    """The rows of a routine that could not be run at all (unreadable folder, worker died)."""
    msg = " ".join("".join(traceback.format_exception_only(type(exc), exc)).split())
    return {"rows": [{"routine": spec.name, "apparatus": spec.apparatus, "n_cam": spec.n_cam, "seed": spec.seed,
                      "method": method_name(m), "frames": 0, "seconds": 0.0, "error": msg} for m in methods],
            "trajectories": None}


def run_suite(
    specs: Sequence[RoutineSpec],
    methods: Sequence[str] = METHODS,
    jobs: int | None = None,
    mot: bool = True,
    progress: Callable[[int, int, str], None] | None = None,
    pose: bool = True,
    runner: Callable | None = None,
) -> BenchmarkRun:
    """Run every method on every routine; one routine = one task of ``runner``.

    methods: names of :data:`.aggregate.METHODS`, or tracker recipes (:class:`gymtrack.modes.Method`,
    the rows named by their ``name``: the ablation of :mod:`.ablation`).

    runner: ``runner(fn, args, on_done)`` calls ``fn(*args[i])`` for every i, wherever it likes,
    and ``on_done(i, result_or_exception)`` as each ends -- the batch machinery's
    :func:`gymtrack.batch.engine.dask_runner` (a LocalCluster or a Dask scheduler); None runs the
    routines one after another in this process. The rows do not depend on where they ran.
    jobs: the parallel workers, as recorded in the report (default ``os.cpu_count()`` with a
    runner, 1 without). progress: ``progress(done, total, routine_name)`` after each routine.
    """
    from ..modes import Method

    bad = [m for m in methods if not isinstance(m, Method) and m not in METHODS]
    if bad:
        raise InputError(f"unknown method {bad[0]!r}; choose from {', '.join(METHODS)}", field="methods")
    jobs = max(1, int(jobs or (os.cpu_count() if runner else 1) or 1))
    want = fig6_routines(specs)
    t0 = time.perf_counter()
    args = [(s, list(methods), s.name in want, mot, pose) for s in specs]
    results: list[dict | None] = [None] * len(specs)
    done = 0

    def on_done(i: int, res) -> None:
        nonlocal done
        # a routine that raised (folder unreadable) or whose worker died: every method's row says why
        results[i] = _failed_routine(specs[i], methods, res) if isinstance(res, BaseException) else res
        done += 1
        if progress:
            progress(done, len(specs), specs[i].name)

    if runner is None:
        for i, a in enumerate(args):
            try:
                res = run_routine(*a)
            except Exception as exc:
                res = exc
            on_done(i, res)
    else:
        runner(run_routine, args, on_done)
    ran = [r for r in results if r is not None]
    rows = [row for r in ran for row in r["rows"]]
    traj = {r["rows"][0]["routine"]: r["trajectories"] for r in ran if r.get("trajectories")}
    return BenchmarkRun(rows, traj, list(specs), time.perf_counter() - t0, jobs)


def write_benchmark(run: BenchmarkRun, out: str | Path, meta: dict | None = None, wildtrack: dict | None = None,
                    mvor: dict | None = None, dropout: tuple[str, list[dict]] | None = None,
                    sections: Sequence[str] = (), results: dict[str, list[dict]] | None = None) -> dict[str, Path]:
    """Write the report, tables, JSON and the Fig. 6 plots of a run under ``out`` (with the pose
    section; ``dropout``: the camera drop-out section's markdown and rows, :mod:`.dropout`, also
    written to ``dropout.csv``; ``sections``: more markdown sections, appended; ``results``: more
    record lists, each written to ``<name>.csv`` and results.json)."""
    from .judging import judging_markdown
    from .pose_bench import pose_markdown, pose_tables
    from .render import plot_target_trajectories, write_csv, write_report
    from .wildtrack import wildtrack_markdown

    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    plots = []
    by_name = {s.name: s for s in run.specs}
    for name, series in sorted(run.trajectories.items()):
        s = by_name.get(name)
        keep = {k: v for k, v in series.items() if k in ("GT", "cascade", "triangulation")}
        if s is None or len(keep) < 2:
            continue
        try:
            p = plot_target_trajectories(out / f"fig6_{s.apparatus}.png", f"{s.apparatus} ({name}), n_cam = 2: target centre",
                                         keep, fps=float(series.get("fps", 30.0)))
            plots.append(p.name)
        except ImportError:  # matplotlib is optional (the 'plot' extra)
            break
    from ..version import version

    meta = {"gymtrack version": version(), "routines": len(run.specs), "parallel jobs": run.jobs, "CPUs": os.cpu_count(), "wall seconds": round(run.seconds, 1),
            **(meta or {})}
    extra = "\n\n".join(x for x in (pose_markdown(run.rows, mvor), judging_markdown(run.rows), wildtrack_markdown(wildtrack) if wildtrack else None,
                                     dropout[0] if dropout is not None else None, *sections) if x)
    files = write_report(out, run.rows, meta, plots, extra, wildtrack, results=results)
    files["pose"] = write_csv(out / "pose_fig7.csv", pose_tables(run.rows)["fig7"])
    if dropout is not None and dropout[1]:
        files["dropout"] = write_csv(out / "dropout.csv", dropout[1])
    return files
