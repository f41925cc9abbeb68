"""The pose part of the benchmark: the paper's Fig. 7 as a table, and a lifting ablation.

Paper: Fig. 7 shows how a track biased by two opposite views misdirects the 3D pose; Section
III-D says the expanded boxes ``b_buf`` are what the pose model sees. Here that is measured: for
every method whose boxes the pose model can run on (:data:`POSE_METHODS`: cascade,
triangulation, mvpt, oracle, and cascade+, the default mode, beyond the paper), the simulated top-down pose model
(:func:`gymtrack.simulate.pose_model.simulate_pose_model`) runs on the method's ``b_buf`` boxes,
the pose stage lifts the target (``robust``), and the result is compared with the simulator's
``gt/keypoints_3d.csv`` (:mod:`gymtrack.eval.pose_metrics`, the target's performing frames). On
the cascade's boxes the same keypoints are also lifted with ``dlt`` (paper Eq. 3 per joint) and
with ``robust`` without the plane anchoring (:data:`LIFTS`): the ablation.

Rows: :func:`pose_columns` adds the additive parts of the metrics to a method's benchmark row as
``pose_<lift>_<part>`` columns (parts: :data:`PARTS`), so that pooling routines is exact, like
the tracking metrics of :mod:`gymtrack.eval.aggregate`. :func:`pose_tables` pools them per
(apparatus, n_cam, method, lift) and averages over apparatus; :func:`pose_claims` checks the
issue's targets; :func:`pose_markdown` writes the report section.

The claims compare two outputs (:data:`COMPARISONS`) on their **common frames**: the MPJPE of
each over the (frame, joint) pairs both estimated (``posecmp_<comparison>_<part>`` columns on
the cascade's row, :func:`add_common_columns`). Each output's own MPJPE averages over its own
frames -- a method that finds a pose on fewer frames averages over easier ones -- so it is
reported beside, with the pose share and PCK@150 over all performing frames (a frame or joint
without an estimate is a miss), but not used for the ratios. The limits are
:class:`gymtrack.eval.config.BenchmarkConfig`'s. The pose model's seed is the
routine's, the same for every method, so the methods differ by their boxes only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields
from pathlib import Path
from typing import Sequence

import numpy as np

from ..apparatus import ABBREVIATIONS, APPARATUS_NAMES
from .pose_metrics import CommonError, PoseError, common_error, joint_errors, target_pose_error
from .aggregate import Claim
from .config import DEFAULT_CONFIG, BenchmarkConfig
from .render import markdown_table

__all__ = ["POSE_METHODS", "LIFTS", "PARTS", "COMPARISONS", "PoseGroundTruth", "pose_columns", "add_common_columns",
           "pooled_common", "pose_tables", "pose_claims", "pose_markdown"]

POSE_METHODS: tuple[str, ...] = ("cascade", "triangulation", "mvpt", "oracle", "cascade+")
#: lifting variants: column name -> (lift method, plane anchoring)
LIFTS: dict[str, tuple[str, bool]] = {"robust": ("robust", True), "dlt": ("dlt", False), "noplane": ("robust", False)}
LIFT_LABELS = {"robust": "robust", "dlt": "dlt (Eq. 3)", "noplane": "robust, no plane anchoring"}
ABLATION_METHOD = "cascade"
PARTS: tuple[str, ...] = tuple(f.name for f in fields(PoseError))
N_CAMS = (2, 3, 4)
#: compared outputs: name -> ((method, lift) a, (method, lift) b); columns on method a's row
COMPARISONS: dict[str, tuple[tuple[str, str], tuple[str, str]]] = {
    "cascade_triangulation": (("cascade", "robust"), ("triangulation", "robust")),
    "cascade_oracle": (("cascade", "robust"), ("oracle", "robust")),
    "robust_dlt": (("cascade", "robust"), ("cascade", "dlt")),
    "robust_noplane": (("cascade", "robust"), ("cascade", "noplane")),
}
COMMON_PARTS: tuple[str, ...] = tuple(f.name for f in fields(CommonError))
_ERR = "_pose_joint_errors"  # per-row scratch: {lift: (F, G) mm}, removed by add_common_columns


@dataclass(frozen=True, eq=False)
class PoseGroundTruth:
    """The simulator's joints of one routine and the target's performing frames.

    frames (T,), person_id (P,), joints (P, T, 17, 3) COCO-17 metres (NaN absent);
    target (the target's person id); perf_frames: the target's performing frames.
    """

    frames: np.ndarray
    person_id: np.ndarray
    joints: np.ndarray
    target: int
    perf_frames: np.ndarray

    @classmethod
    def load(cls, routine_path: str | Path, gt, performance_space) -> "PoseGroundTruth | None":
        """From ``gt/keypoints_3d.csv`` and the routine's GroundTruth; None when the file is absent."""
        from ..formats.gt_keypoints import read_keypoints_3d

        path = Path(routine_path) / "gt" / "keypoints_3d.csv"
        if not path.is_file():
            return None
        frames, pid, joints = read_keypoints_3d(path)
        t = gt.target()
        perf = np.unique(t.frame[t.performing(np.asarray(performance_space, np.float64))])
        return cls(frames, pid, joints, gt.target_id, perf)

    def target_joints(self) -> np.ndarray:
        """(T, 17, 3) the target's joints."""
        k = np.flatnonzero(self.person_id == self.target)
        if not k.size:
            raise ValueError(f"gt/keypoints_3d.csv has no joints of the target (person {self.target})")
        return self.joints[k[0]]


def pose_columns(method: str, result, rig, scene, pgt: PoseGroundTruth, seed: int = 0, judging=None) -> dict:
    """``pose_<lift>_<part>`` columns of one method's run (empty for methods without pose).

    result: the method's TrackResult; the pose model runs on its ``target_boxes`` (b_buf).
    judging: the routine's :class:`~gymtrack.eval.judging.JudgingTruth`: the robust lift is also
    analysed and scored (``judge_parts``, :func:`gymtrack.eval.judging.judging_columns`).
    """
    if method not in POSE_METHODS:
        return {}
    import time

    t0 = time.perf_counter()
    try:
        return _pose_columns(method, result, rig, scene, pgt, seed, t0, judging)
    except Exception as exc:  # a pose failure must not lose the method's tracking row
        return {"pose_error": f"{type(exc).__name__}: {exc}"}


def _pose_columns(method, result, rig, scene, pgt, seed, t0, judging=None) -> dict:
    import time

    from ..pose.stage import lift_poses
    from ..simulate.pose_model import simulate_pose_model
    from ..skeletons import COCO17

    poses = simulate_pose_model(rig, pgt.joints, pgt.person_id, pgt.frames, result.target_boxes, seed=seed)
    gt_xyz = pgt.target_joints()
    out: dict = {}
    lifts = LIFTS if method == ABLATION_METHOD else {"robust": LIFTS["robust"]}
    for name, (how, plane) in lifts.items():
        res = lift_poses(result, rig, scene, poses, method=how, plane=plane)
        p = res.poses3d
        e = target_pose_error(p.frame, p.xyz, p.skeleton.joints, pgt.frames, gt_xyz, COCO17.joints, pgt.perf_frames)
        out |= {f"pose_{name}_{k}": v for k, v in e.as_dict().items()}
        out.setdefault(_ERR, {})[name] = joint_errors(p.frame, p.xyz, p.skeleton.joints, pgt.frames, gt_xyz,
                                                      COCO17.joints, pgt.perf_frames)
        if name == "robust":
            from .judging import judging_columns

            out |= judging_columns(method, p, scene, judging)
            out["pose_poses_2d"] = len(poses)
            out["pose_unassigned"] = res.counts.get("unassigned", 0) + res.counts.get("rejected", 0)
    out["pose_seconds"] = time.perf_counter() - t0
    return out


def add_common_columns(rows: list[dict]) -> list[dict]:
    """Add the ``posecmp_<comparison>_<part>`` columns to the rows of one routine (one row per
    method, as :func:`pose_columns` left them) and drop the per-joint scratch; in place."""
    err = {r.get("method"): r.pop(_ERR, None) or {} for r in rows}
    for r in rows:
        for name, ((ma, la), (mb, lb)) in COMPARISONS.items():
            if r.get("method") != ma or la not in err[ma] or lb not in err.get(mb, {}):
                continue
            c = common_error(err[ma][la], err[mb][lb])
            r |= {f"posecmp_{name}_{k}": v for k, v in c.as_dict().items()}
    return rows


def pooled_common(rows: Sequence[dict]) -> dict[tuple, CommonError]:
    """``{(apparatus, n_cam, comparison): pooled CommonError}`` over routines."""
    out: dict[tuple, CommonError] = {}
    for r in rows:
        if r.get("error"):
            continue
        for name in COMPARISONS:
            if r.get(f"posecmp_{name}_n") in ("", None):
                continue
            c = CommonError(**{k: (int if k in ("n", "frames") else float)(_num(r[f"posecmp_{name}_{k}"])) for k in COMMON_PARTS})
            key = (r["apparatus"], int(r["n_cam"]), name)
            out[key] = out[key] + c if key in out else c
    return out


# ----------------------------------------------------------------------------- tables
def _num(v) -> float:
    try:
        f = float(v)
    except (TypeError, ValueError):
        return 0.0
    return 0.0 if math.isnan(f) else f


def pooled_pose(rows: Sequence[dict]) -> dict[tuple, PoseError]:
    """``{(apparatus, n_cam, method, lift): pooled PoseError}`` over routines."""
    out: dict[tuple, PoseError] = {}
    for r in rows:
        if r.get("error"):
            continue
        for lift in LIFTS:
            if f"pose_{lift}_frames" not in r or r.get(f"pose_{lift}_frames") in ("", None):
                continue
            e = PoseError(**{k: (int if isinstance(getattr(PoseError(), k), int) else float)(_num(r[f"pose_{lift}_{k}"])) for k in PARTS})
            key = (r["apparatus"], int(r["n_cam"]), r["method"], lift)
            out[key] = out[key] + e if key in out else e
    return out


def _mean(v: list[float]) -> float:
    a = np.asarray([x for x in v if np.isfinite(x)], np.float64)
    return float(a.mean()) if a.size else float("nan")


def pose_tables(rows: Sequence[dict]) -> dict[str, list[dict]]:
    """``{"fig7": per (apparatus, n_cam, method) robust metrics, "averaged": per (method, lift, n_cam)
    apparatus-averaged MPJPE / PA-MPJPE / PCK / pose share}``."""
    p = pooled_pose(rows)
    fig7 = [{"apparatus": a, "n_cam": n, "method": m, "lift": lift, "mpjpe_mm": e.mpjpe, "pa_mpjpe_mm": e.pa_mpjpe,
             "pck150": e.pck, "pck150_all": e.pck_all, "pose_share": e.pose_share} for (a, n, m, lift), e in sorted(
                 p.items(), key=lambda kv: (_order(kv[0][0], APPARATUS_NAMES), kv[0][1], _order(kv[0][2], POSE_METHODS),
                                            _order(kv[0][3], tuple(LIFTS))))]
    acc: dict[tuple, dict[str, list]] = {}
    for r in fig7:
        d = acc.setdefault((r["method"], r["lift"], r["n_cam"]), {k: [] for k in ("mpjpe_mm", "pa_mpjpe_mm", "pck150", "pck150_all", "pose_share")})
        for k in d:
            d[k].append(r[k])
    averaged = [{"method": m, "lift": lift, "n_cam": n, **{k: _mean(v) for k, v in d.items()}}
                for (m, lift, n), d in sorted(acc.items(), key=lambda kv: (_order(kv[0][0], POSE_METHODS), _order(kv[0][1], tuple(LIFTS)), kv[0][2]))]
    return {"fig7": fig7, "averaged": averaged}


def _order(x, seq: Sequence) -> int:
    return list(seq).index(x) if x in seq else len(seq)


def _claim(name: str, value: float, limit: float, ok: bool | None, detail: str) -> Claim:
    status = "n/a" if ok is None or not np.isfinite(value) else ("PASS" if ok else "FAIL")
    return Claim(name, float(value), float(limit), status, detail)


def pose_claims(rows: Sequence[dict], config: BenchmarkConfig = DEFAULT_CONFIG) -> list[Claim]:
    """The issue's pose targets, PASS / FAIL / n/a, limits from ``config``.

    Each compares two outputs (:data:`COMPARISONS`) on their common frames: per apparatus, the
    MPJPE of each over the (frame, joint) pairs both estimated; the ratio of their means over the
    apparatus where both have a pose. The detail gives each output's own MPJPE, pose share and
    PCK@150 over all performing frames beside it.

    1. n_cam = 2: cascade <= 0.7 x triangulation (robust lifting on each method's boxes);
    2. n_cam = 2: robust <= 0.85 x dlt (cascade's boxes, same keypoints);
    3. n_cam = 4: robust no worse than dlt (ratio <= 1);
    4. every n_cam: cascade <= 1.3 x oracle.
    """
    p = pooled_pose(rows)
    pc = pooled_common(rows)
    out = []

    def own(key_mean, n, m, lift, attr):
        return _mean([getattr(p[(a, n, m, lift)], attr) for a in key_mean if (a, n, m, lift) in p])

    def ratio(name, comparison, n, limit):
        (ma, la), (mb, lb) = COMPARISONS[comparison]
        apps = [a for a in sorted({k[0] for k in pc}, key=lambda a: _order(a, APPARATUS_NAMES))
                if (a, n, comparison) in pc and pc[(a, n, comparison)].n > 0]
        if not apps:
            out.append(_claim(name, float("nan"), limit, None, f"needs {ma}/{la} and {mb}/{lb} at n_cam = {n}"))
            return
        x = _mean([pc[(a, n, comparison)].a for a in apps])
        y = _mean([pc[(a, n, comparison)].b for a in apps])
        r = x / y if y > 0 else float("nan")
        detail = (f"common frames: {ma} {la} {x:.0f} mm vs {mb} {lb} {y:.0f} mm ({len(apps)} apparatus); own MPJPE "
                  f"{own(apps, n, ma, la, 'mpjpe'):.0f} vs {own(apps, n, mb, lb, 'mpjpe'):.0f} mm, pose share "
                  f"{100 * own(apps, n, ma, la, 'pose_share'):.0f}% vs {100 * own(apps, n, mb, lb, 'pose_share'):.0f}%, "
                  f"PCK@150 all frames {100 * own(apps, n, ma, la, 'pck_all'):.0f}% vs {100 * own(apps, n, mb, lb, 'pck_all'):.0f}%")
        out.append(_claim(name, r, limit, r <= limit, detail))

    c = config
    ratio(f"pose n_cam=2: MPJPE cascade <= {c.pose_cascade_over_triangulation_2:g} x triangulation",
          "cascade_triangulation", 2, c.pose_cascade_over_triangulation_2)
    ratio(f"pose n_cam=2: MPJPE robust <= {c.pose_robust_over_dlt_2:g} x dlt", "robust_dlt", 2, c.pose_robust_over_dlt_2)
    ratio("pose n_cam=4: MPJPE robust <= dlt (no worse)" if c.pose_robust_over_dlt_4 == 1 else
          f"pose n_cam=4: MPJPE robust <= {c.pose_robust_over_dlt_4:g} x dlt", "robust_dlt", 4, c.pose_robust_over_dlt_4)
    ns = sorted({k[1] for k in p}) or list(N_CAMS)
    for n in ns:
        ratio(f"pose n_cam={n}: MPJPE cascade <= {c.pose_cascade_over_oracle:g} x oracle", "cascade_oracle", n,
              c.pose_cascade_over_oracle)
    return out


def _f(v: float, kind: str = "mm") -> str:
    if v is None or not np.isfinite(v):
        return "-"
    return f"{v:.0f}" if kind == "mm" else (f"{100 * v:.1f}%" if kind == "pct" else f"{v:.2f}")


def pose_markdown(rows: Sequence[dict], mvor: dict | None = None, config: BenchmarkConfig = DEFAULT_CONFIG) -> str:
    """The report section: Fig. 7 table, apparatus averages, ablation, ratios, claims, MVOR."""
    t = pose_tables(rows)
    if not t["fig7"]:
        parts = ["## Pose (Fig. 7): not measured", "",
                 "No routine had gt/keypoints_3d.csv (or pose evaluation was switched off)."]
        return "\n".join(parts + ([_mvor_md(mvor)] if mvor else []))
    ns = sorted({r["n_cam"] for r in t["fig7"]})
    apps = [a for a in APPARATUS_NAMES if any(r["apparatus"] == a for r in t["fig7"])]
    methods = [m for m in POSE_METHODS if any(r["method"] == m for r in t["fig7"])]
    cell = {(r["apparatus"], r["n_cam"], r["method"], r["lift"]): r for r in t["fig7"]}
    parts = [
        "## Pose of the target (the paper's Fig. 7 as a table)", "",
        "The simulated top-down pose model runs on each method's expanded boxes b_buf (same seed for every "
        "method, so they differ by their boxes only); the pose stage lifts the target with `robust` lifting; "
        "errors against gt/keypoints_3d.csv (COCO-17) on the target's performing frames. MPJPE and PA-MPJPE "
        "(Procrustes with scale, per frame) in mm pooled over joints; PCK at 150 mm over the ground-truth joints "
        "of frames with a pose (a joint not estimated is a miss), and over every performing frame (PCK all: a frame "
        "without a pose is all misses); pose share = performing frames with a pose. "
        "Averages over apparatus are plain means of the per-apparatus values. **The ratios and the targets use the "
        "common-frame MPJPE**: each of the two compared outputs over the frames and joints both estimated; each "
        "output's own MPJPE averages over its own frames (fewer frames can be easier ones) and is shown beside.", "",
        "**MPJPE (mm) per apparatus and n_cam, robust lifting**", "",
    ]
    header = ["method"] + [f"{ABBREVIATIONS.get(a, a)} {n}" for a in apps for n in ns]
    parts.append(markdown_table(header, [[m] + [_f(cell[(a, n, m, "robust")]["mpjpe_mm"]) if (a, n, m, "robust") in cell else "-"
                                                for a in apps for n in ns] for m in methods]))
    av = {(r["method"], r["lift"], r["n_cam"]): r for r in t["averaged"]}

    def summary(k):
        r = av[k]
        return " \\| ".join((_f(r["mpjpe_mm"]), _f(r["pa_mpjpe_mm"]), _f(r["pck150"], "pct"), _f(r["pck150_all"], "pct"),
                              _f(r["pose_share"], "pct")))

    parts += ["", "**Averaged over apparatus, robust lifting (own frames): MPJPE | PA-MPJPE (mm) | PCK@150 | "
              "PCK@150 all frames | pose share**", ""]
    parts.append(markdown_table(["method"] + [f"n_cam={n}" for n in ns], [
        [m] + [summary((m, "robust", n)) if (m, "robust", n) in av else "-" for n in ns] for m in methods]))
    parts += ["", f"**Lifting ablation on the {ABLATION_METHOD}'s boxes (same 2D keypoints), own frames: MPJPE | PA-MPJPE (mm) "
              "| PCK@150 | PCK@150 all frames | pose share, averaged over apparatus**", ""]
    parts.append(markdown_table(["lifting"] + [f"n_cam={n}" for n in ns], [
        [LIFT_LABELS[lift]] + [summary(k) if (k := (ABLATION_METHOD, lift, n)) in av else "-" for n in ns] for lift in LIFTS]))
    parts += ["", "**Ratios of MPJPE on common frames (a | b mm over the frames and joints both estimated, averaged over "
              "apparatus; ratio a / b, in brackets the ratio of the own-frame MPJPEs)**", ""]
    pc = pooled_common(rows)

    def rt(name, n):
        apps = [a for a in apps_all if (a, n, name) in pc and pc[(a, n, name)].n > 0]
        if not apps:
            return "-"
        x, y = _mean([pc[(a, n, name)].a for a in apps]), _mean([pc[(a, n, name)].b for a in apps])
        (ma, la), (mb, lb) = COMPARISONS[name]
        xo, yo = av.get((ma, la, n)), av.get((mb, lb, n))
        own = f" ({_f(xo['mpjpe_mm'] / yo['mpjpe_mm'], 'ratio')})" if xo and yo and yo["mpjpe_mm"] else ""
        return f"{_f(x)} \\| {_f(y)}: {_f(x / y if y else float('nan'), 'ratio')}{own}"

    apps_all = [a for a in APPARATUS_NAMES] + sorted({k[0] for k in pc} - set(APPARATUS_NAMES))
    names = {"cascade_triangulation": "cascade / triangulation", "cascade_oracle": "cascade / oracle",
             "robust_dlt": "robust / dlt", "robust_noplane": "robust / no plane"}
    parts.append(markdown_table(["n_cam"] + [names[k] for k in COMPARISONS], [[n] + [rt(k, n) for k in COMPARISONS] for n in ns]))
    parts += ["", "**Pose targets**", ""]
    parts.append(markdown_table(["target", "value", "limit", "result", "detail"],
                                [[c.name, _f(c.value, "ratio"), _f(c.limit, "ratio"), f"**{c.status}**", c.detail] for c in pose_claims(rows, config)]))
    if mvor:
        parts += ["", _mvor_md(mvor)]
    return "\n".join(parts)


def _mvor_md(mvor: dict) -> str:
    from .pose_mvor import mvor_markdown

    return mvor_markdown(mvor)
