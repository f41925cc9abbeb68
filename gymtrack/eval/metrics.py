"""The paper's evaluation metrics (Section IV-A) and the MOT metrics of all people.

Every function here is pure and works on numpy columns (one row per box or per 3D point); the
glue that pulls these columns out of a tracker result and a ground truth is
:func:`gymtrack.eval.benchmark.evaluate_routine`.

Target metrics (the paper evaluates the target gymnast only):

* **performing frames** (:func:`performing_frames`): frames where the ground-truth target exists,
  its centre lies inside the performance space ``S_perf`` and, when the simulator gives a phase
  flag, it is in the routine's performance phase. Every target metric is restricted to them:
  before and after the routine the target walks around the hall like anyone else.
* **ID switches** (:func:`target_id_switches`): over the performing frames where the output has a
  target, in frame order, a transition from one such frame to the next counts as **one** switch
  when the output target's track id changes, *or* the ground-truth person the output target
  actually is changes, *or* both (counted once). "Actually is" = the nearest ground-truth person
  in 3D at that frame, if within ``gate`` metres; an output farther than ``gate`` from everybody
  is nobody and neither starts nor ends an identity (the comparison is with the last person it
  was). A tracker that moves from the gymnast to a coach under the same id therefore scores a
  switch, and so does one that keeps following the gymnast under a new id. Gaps (frames without an
  output target) are bridged: a new id after a gap is a switch.
* **AED** (:func:`average_euclidean_distance`): mean 3D distance in metres between the output
  target centre and the ground-truth target centre over the frames where both exist (the
  benchmark passes the performing frames).
* **FR** (:func:`failure_rate`, paper Fig. 5): over every (frame, view) where the ground-truth
  target box is visible while performing, the output's expanded box ``b_buf`` fails when it is
  missing, when the true box is not inside it, or when the true box's length ``max(w, h)`` is less
  than half of ``b_buf``'s side. A box that fails for more than one reason is counted once, under
  the first of missing / outside / too small.
* **coverage** (:func:`coverage`): share of performing frames that have an output target.

All-people metrics (:func:`mot_metrics`): MOTA, IDF1 and ID switches of the 3D tracks against
the ground-truth people with py-motmetrics, on point distances (Euclidean, gated at
``max_dist`` metres; beyond the gate a pair cannot match). Checked here: motmetrics 1.4.0 works
with pandas 3 and numpy 2.2 for point distances -- it is its box-IoU helper
(``mm.distances.iou_matrix``) that breaks on numpy 2 (``np.asfarray``), and we never call it. We
build the Euclidean distance matrix ourselves (NaN beyond the gate, motmetrics' "no match") and
only use ``MOTAccumulator`` and ``metrics.create().compute``; the version is pinned in
``pyproject.toml``'s ``eval`` extra (``motmetrics==1.4.0``). Ground-truth people outside an
evaluation region (e.g. spectators outside the tracking space, which the tracker discards on
purpose) are handled like MOTChallenge distractors: an output matched to one of them is neither a
true nor a false positive, and they are never misses.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from ..scene import in_box  # re-exported: S_perf membership, written once

__all__ = [
    "pairs_by_key",
    "performing_frames",
    "nearest_person",
    "IdSwitches",
    "target_id_switches",
    "Distance",
    "average_euclidean_distance",
    "FailureRate",
    "failure_rate",
    "Coverage",
    "coverage",
    "MotMetrics",
    "mot_metrics",
    "in_box",
]


# ----------------------------------------------------------------------------- helpers
def pairs_by_key(a: np.ndarray, b: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Every pair of rows with equal keys, vectorised (an inner join).

    a: (Na,) integer keys; b: (Nb,) integer keys.
    Returns ``(ia, ib)``, (M,) indices with ``a[ia] == b[ib]``, ordered by ``ia``.
    """
    a = np.asarray(a).reshape(-1)
    b = np.asarray(b).reshape(-1)
    order = np.argsort(b, kind="stable")
    bs = b[order]
    lo = np.searchsorted(bs, a, "left")
    cnt = np.searchsorted(bs, a, "right") - lo
    total = int(cnt.sum())
    ia = np.repeat(np.arange(a.size), cnt)
    within = np.arange(total) - np.repeat(np.cumsum(cnt) - cnt, cnt)
    ib = order[np.repeat(lo, cnt) + within]
    return ia, ib


def _unique_frame_rows(frame: np.ndarray, what: str) -> None:
    if np.unique(frame).size != np.asarray(frame).size:
        raise ValueError(f"{what} must have at most one row per frame")


def performing_frames(
    target_frame: np.ndarray,
    target_xyz: np.ndarray,
    performance_space: np.ndarray,
    phase: np.ndarray | None = None,
) -> np.ndarray:
    """Frames where the ground-truth target performs.

    target_frame: (T,) frames of the ground-truth target; target_xyz: (T, 3) its centre.
    performance_space: (6,) ``S_perf``. phase: optional (T,) bool, the simulator's "in the
    performance phase" flag; when given, a frame must also have it set.
    Returns (F,) sorted unique frames.
    """
    keep = in_box(target_xyz, performance_space)
    if phase is not None:
        keep &= np.asarray(phase, dtype=bool)
    return np.unique(np.asarray(target_frame)[keep])


def nearest_person(
    frame: np.ndarray,
    xyz: np.ndarray,
    gt_frame: np.ndarray,
    gt_person: np.ndarray,
    gt_xyz: np.ndarray,
    gate: float = np.inf,
) -> tuple[np.ndarray, np.ndarray]:
    """The nearest ground-truth person of each query point at the same frame.

    frame: (N,), xyz: (N, 3) query points; gt_frame: (P,), gt_person: (P,), gt_xyz: (P, 3).
    Returns ``person`` (N,) int64, -1 where no person of that frame is within ``gate`` metres,
    and ``distance`` (N,) metres to the nearest person (inf where the frame has nobody).
    """
    frame = np.asarray(frame)
    n = frame.size
    person = np.full(n, -1, np.int64)
    dist = np.full(n, np.inf)
    ia, ib = pairs_by_key(frame, gt_frame)
    if ia.size:
        d = np.linalg.norm(np.asarray(xyz, dtype=np.float64)[ia] - np.asarray(gt_xyz, dtype=np.float64)[ib], axis=1)
        d = np.where(np.isfinite(d), d, np.inf)
        order = np.lexsort((d, ia))  # by query, then by distance
        first = order[np.r_[True, ia[order][1:] != ia[order][:-1]]]
        dist[ia[first]] = d[first]
        ok = d[first] <= gate
        person[ia[first][ok]] = np.asarray(gt_person, dtype=np.int64)[ib[first][ok]]
    return person, dist


# ----------------------------------------------------------------------------- ID switches
@dataclass(frozen=True)
class IdSwitches:
    """ID switches of the output target; ``total`` counts a transition once if either kind changes."""

    total: int
    track_id_changes: int
    person_changes: int
    transitions: int  #: consecutive pairs of evaluated frames
    frames_not_on_anybody: int  #: evaluated frames whose output target is farther than the gate from everybody

    def as_dict(self) -> dict:
        return asdict(self)


def target_id_switches(
    perf_frames: np.ndarray,
    out_frame: np.ndarray,
    out_track_id: np.ndarray,
    out_xyz: np.ndarray,
    gt_frame: np.ndarray,
    gt_person: np.ndarray,
    gt_xyz: np.ndarray,
    gate: float = 1.0,
) -> IdSwitches:
    """ID switches of the output target over the performing frames (see the module docstring).

    perf_frames: (F,) frames where the ground-truth target performs.
    out_frame: (T,) frames of the output target (one row per frame); out_track_id: (T,) its
    track id; out_xyz: (T, 3) its centre.
    gt_frame, gt_person, gt_xyz: (P,), (P,), (P, 3): every ground-truth person (all roles).
    gate: metres; an output target farther than this from every person is "nobody".
    """
    out_frame = np.asarray(out_frame)
    _unique_frame_rows(out_frame, "the output target")
    keep = np.isin(out_frame, perf_frames)
    order = np.argsort(out_frame[keep], kind="stable")
    f = out_frame[keep][order]
    tid = np.asarray(out_track_id)[keep][order]
    xyz = np.asarray(out_xyz, dtype=np.float64)[keep][order]
    if f.size == 0:
        return IdSwitches(0, 0, 0, 0, 0)
    who, _ = nearest_person(f, xyz, gt_frame, gt_person, gt_xyz, gate)
    id_change = np.r_[False, tid[1:] != tid[:-1]]
    # last known person before each row (forward fill over "nobody")
    known = who >= 0
    idx = np.where(known, np.arange(f.size), -1)
    last = np.maximum.accumulate(idx)
    prev_last = np.r_[-1, last[:-1]]
    person_change = known & (prev_last >= 0) & (who != who[np.maximum(prev_last, 0)])
    switch = id_change | person_change
    return IdSwitches(
        total=int(switch.sum()),
        track_id_changes=int(id_change.sum()),
        person_changes=int(person_change.sum()),
        transitions=int(f.size - 1),
        frames_not_on_anybody=int((~known).sum()),
    )


# ----------------------------------------------------------------------------- AED
@dataclass(frozen=True)
class Distance:
    """Mean Euclidean distance and its parts (so that routines can be pooled exactly)."""

    mean: float  #: NaN when no frame has both
    total: float
    n: int

    def as_dict(self) -> dict:
        return asdict(self)


def average_euclidean_distance(
    gt_frame: np.ndarray,
    gt_xyz: np.ndarray,
    out_frame: np.ndarray,
    out_xyz: np.ndarray,
    frames: np.ndarray | None = None,
) -> Distance:
    """AED: mean ``||X_out - X_gt||`` over the frames where both the output and the GT target exist.

    gt_frame: (G,), gt_xyz: (G, 3): the ground-truth target, one row per frame.
    out_frame: (T,), out_xyz: (T, 3): the output target, one row per frame.
    frames: optional (F,) frames to restrict to (the performing frames).
    """
    _unique_frame_rows(gt_frame, "the ground-truth target")
    _unique_frame_rows(out_frame, "the output target")
    ia, ib = pairs_by_key(out_frame, gt_frame)
    if frames is not None:
        ok = np.isin(np.asarray(out_frame)[ia], frames)
        ia, ib = ia[ok], ib[ok]
    d = np.linalg.norm(np.asarray(out_xyz, dtype=np.float64)[ia] - np.asarray(gt_xyz, dtype=np.float64)[ib], axis=1)
    d = d[np.isfinite(d)]
    return Distance(float(d.mean()) if d.size else float("nan"), float(d.sum()), int(d.size))


# ----------------------------------------------------------------------------- FR
@dataclass(frozen=True)
class FailureRate:
    """Paper Fig. 5 failure rate of the expanded boxes, with its failure kinds."""

    rate: float  #: failures / evaluated; NaN when nothing is evaluated
    failures: int
    evaluated: int  #: (frame, view) pairs with a visible ground-truth target box while performing
    missing: int
    outside: int
    too_small: int

    def as_dict(self) -> dict:
        return asdict(self)


def failure_rate(
    gt_frame: np.ndarray,
    gt_camera: np.ndarray,
    gt_box: np.ndarray,
    out_frame: np.ndarray,
    out_camera: np.ndarray,
    out_box: np.ndarray,
    image_size: np.ndarray | None = None,
    min_ratio: float = 0.5,
    per_pair: bool = False,
) -> FailureRate | tuple[FailureRate, np.ndarray]:
    """Failure rate of the output's expanded boxes ``b_buf`` (paper Fig. 5).

    gt_frame, gt_camera: (G,) the (frame, view) pairs to evaluate (visible ground-truth target
    boxes while performing, one per pair); gt_box: (G, 4) true boxes, centre form ``[x, y, w, h]``.
    out_frame, out_camera: (B,); out_box: (B, 4) the output's expanded boxes, centre form, at most
    one per (frame, view).
    image_size: optional (C, 2) ``(width, height)`` per camera index: when given, both boxes are
    clipped to the image before the "inside" test (a true box that runs off the image only needs
    its visible part covered).
    min_ratio: the true box's ``max(w, h)`` must be at least this share of ``b_buf``'s side.
    per_pair: also return the (G,) bool mask of the failed pairs (:mod:`.explain` sorts them by cause).
    """
    gt_frame = np.asarray(gt_frame, dtype=np.int64)
    gt_camera = np.asarray(gt_camera, dtype=np.int64)
    out_frame = np.asarray(out_frame, dtype=np.int64)
    out_camera = np.asarray(out_camera, dtype=np.int64)
    n_cam = int(max(gt_camera.max(initial=-1), out_camera.max(initial=-1))) + 1
    gkey = gt_frame * n_cam + gt_camera
    okey = out_frame * n_cam + out_camera
    if np.unique(okey).size != okey.size:
        raise ValueError("the output has more than one expanded box for some (frame, view)")
    if np.unique(gkey).size != gkey.size:
        raise ValueError("the ground truth has more than one target box for some (frame, view)")
    g = gkey.size
    if g == 0:
        return (FailureRate(float("nan"), 0, 0, 0, 0, 0), np.zeros(0, bool)) if per_pair else FailureRate(float("nan"), 0, 0, 0, 0, 0)
    ia, ib = pairs_by_key(gkey, okey)
    has = np.zeros(g, bool)
    has[ia] = True
    tb = np.asarray(gt_box, dtype=np.float64)[ia]
    bb = np.asarray(out_box, dtype=np.float64)[ib]
    t_lo, t_hi = tb[:, :2] - tb[:, 2:] / 2, tb[:, :2] + tb[:, 2:] / 2
    b_lo, b_hi = bb[:, :2] - bb[:, 2:] / 2, bb[:, :2] + bb[:, 2:] / 2
    if image_size is not None:
        size = np.asarray(image_size, dtype=np.float64)[gt_camera[ia]]
        t_lo, t_hi = np.clip(t_lo, 0, size), np.clip(t_hi, 0, size)
        b_lo, b_hi = np.clip(b_lo, 0, size), np.clip(b_hi, 0, size)
    inside = np.all((t_lo >= b_lo) & (t_hi <= b_hi), axis=1)
    small = np.max(tb[:, 2:], axis=1) < min_ratio * np.max(bb[:, 2:], axis=1)
    outside = np.zeros(g, bool)
    too_small = np.zeros(g, bool)
    outside[ia] = ~inside
    too_small[ia] = inside & small
    missing = ~has
    fails = missing | outside | too_small
    fr = FailureRate(
        rate=float(fails.mean()),
        failures=int(fails.sum()),
        evaluated=int(g),
        missing=int(missing.sum()),
        outside=int(outside.sum()),
        too_small=int(too_small.sum()),
    )
    return (fr, fails) if per_pair else fr


# ----------------------------------------------------------------------------- coverage
@dataclass(frozen=True)
class Coverage:
    share: float  #: NaN when there is no performing frame
    covered: int
    frames: int

    def as_dict(self) -> dict:
        return asdict(self)


def coverage(perf_frames: np.ndarray, out_frame: np.ndarray) -> Coverage:
    """Share of the performing frames (F,) that have an output target (frames (T,))."""
    perf = np.unique(perf_frames)
    covered = int(np.isin(perf, out_frame).sum())
    return Coverage(covered / perf.size if perf.size else float("nan"), covered, int(perf.size))


# ----------------------------------------------------------------------------- MOT metrics
@dataclass(frozen=True)
class MotMetrics:
    """CLEAR-MOT and identity metrics of all people (py-motmetrics)."""

    mota: float
    idf1: float
    id_switches: int
    false_positives: int
    misses: int
    objects: int  #: ground-truth person-frames evaluated
    matches: int  #: true positives: matched person-frames, switches included
    motp: float  #: mean distance of the matches, metres
    median_distance: float  #: median distance of the matches, metres
    ignored_hypotheses: int  #: outputs matched to people outside the region, left out

    def as_dict(self) -> dict:
        return asdict(self)


def mot_metrics(
    gt_frame: np.ndarray,
    gt_id: np.ndarray,
    gt_pts: np.ndarray,
    hyp_frame: np.ndarray,
    hyp_id: np.ndarray,
    hyp_pts: np.ndarray,
    max_dist: float = 1.0,
    gt_in_region: np.ndarray | None = None,
) -> MotMetrics:
    """MOTA, IDF1, ID switches of point tracks with py-motmetrics.

    gt_frame, gt_id: (G,); gt_pts: (G, D) ground-truth points (D = 3 for 3D, 2 for ground-plane).
    hyp_frame, hyp_id: (H,); hyp_pts: (H, D) output points. Rows with a non-finite point are
    ignored.
    max_dist: metres; pairs farther apart cannot match.
    gt_in_region: optional (G,) bool; people outside the region are distractors (see the module
    docstring): an output that the optimal gated assignment pairs with one is left out.
    """
    import motmetrics as mm
    from scipy.optimize import linear_sum_assignment

    gt_frame = np.asarray(gt_frame, dtype=np.int64)
    hyp_frame = np.asarray(hyp_frame, dtype=np.int64)
    gt_pts = np.asarray(gt_pts, dtype=np.float64)
    hyp_pts = np.asarray(hyp_pts, dtype=np.float64)
    gt_id = np.asarray(gt_id, dtype=np.int64)
    hyp_id = np.asarray(hyp_id, dtype=np.int64)
    region = np.ones(gt_frame.size, bool) if gt_in_region is None else np.asarray(gt_in_region, dtype=bool)
    gok = np.all(np.isfinite(gt_pts), axis=1)
    hok = np.all(np.isfinite(hyp_pts), axis=1)
    gt_frame, gt_id, gt_pts, region = gt_frame[gok], gt_id[gok], gt_pts[gok], region[gok]
    hyp_frame, hyp_id, hyp_pts = hyp_frame[hok], hyp_id[hok], hyp_pts[hok]

    go = np.argsort(gt_frame, kind="stable")
    ho = np.argsort(hyp_frame, kind="stable")
    gt_frame, gt_id, gt_pts, region = gt_frame[go], gt_id[go], gt_pts[go], region[go]
    hyp_frame, hyp_id, hyp_pts = hyp_frame[ho], hyp_id[ho], hyp_pts[ho]
    frames = np.union1d(gt_frame, hyp_frame)
    g_lo = np.searchsorted(gt_frame, frames, "left")
    g_hi = np.searchsorted(gt_frame, frames, "right")
    h_lo = np.searchsorted(hyp_frame, frames, "left")
    h_hi = np.searchsorted(hyp_frame, frames, "right")
    max_d2 = max_dist**2
    acc = mm.MOTAccumulator(auto_id=False)
    ignored = 0
    for k, fr in enumerate(frames):
        gs, hs = slice(g_lo[k], g_hi[k]), slice(h_lo[k], h_hi[k])
        gp, hp = gt_pts[gs], hyp_pts[hs]
        gi, hi = gt_id[gs], hyp_id[hs]
        d2 = np.sum((gp[:, None, :] - hp[None, :, :]) ** 2, axis=-1)
        reg = region[gs]
        if not reg.all():
            # distractors: drop them and the outputs they would take
            drop_h = np.zeros(hp.shape[0], bool)
            if d2.size:
                cost = np.where(d2 <= max_d2, d2, 1e12)
                r, c = linear_sum_assignment(cost)
                ok = (cost[r, c] < 1e12) & ~reg[r]
                drop_h[c[ok]] = True
            ignored += int(drop_h.sum())
            d2 = d2[reg][:, ~drop_h]
            gi, hi = gi[reg], hi[~drop_h]
        d = np.where(d2 <= max_d2, np.sqrt(d2), np.nan)  # Euclidean, so motp is a mean distance
        acc.update(gi.tolist(), hi.tolist(), d, frameid=int(fr))
    if frames.size == 0:
        return MotMetrics(float("nan"), float("nan"), 0, 0, 0, 0, 0, float("nan"), float("nan"), 0)
    mh = mm.metrics.create()
    names = ["mota", "idf1", "num_switches", "num_false_positives", "num_misses", "num_objects", "num_matches", "motp"]
    s = mh.compute(acc, metrics=names, name="all").iloc[0]
    motp = float(s["motp"])
    ev = acc.mot_events
    dm = ev.loc[ev["Type"].isin(["MATCH", "SWITCH"]), "D"].to_numpy(dtype=np.float64)
    return MotMetrics(
        mota=float(s["mota"]),
        idf1=float(s["idf1"]),
        id_switches=int(s["num_switches"]),
        false_positives=int(s["num_false_positives"]),
        misses=int(s["num_misses"]),
        objects=int(s["num_objects"]),
        matches=int(s["num_matches"]) + int(s["num_switches"]),  # motmetrics counts switches apart
        motp=motp,
        median_distance=float(np.median(dm)) if dm.size else float("nan"),
        ignored_hypotheses=ignored,
    )
