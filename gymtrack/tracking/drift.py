"""The venue check: each camera's residuals watched for a knocked camera and for a camera out of sync.

Beyond the paper, which assumes a fixed, synchronised rig (Section III-B). For every window the
tracker's multi-view clusters of three views or more give leave-one-out residuals: the point that
the *other* views triangulate (Eq. 3, normalised image coordinates), projected into the view left
out, minus where that view saw it -- an angle (radians) per camera, point and frame.

- A knocked camera (turned about its centre) moves all its points by the same angle: the median
  residual over the last second steps away from its median of the five seconds before, clearly
  more than the other cameras' (which it drags along a little). Then :class:`DriftMonitor` reports the camera, the frame it started,
  the size in degrees, and (``recalibrate``) re-estimates the camera's rotation from the points
  the other views triangulate (a rotation-only fit of the rays, Kabsch / Wahba's problem) and
  maps that camera's later boxes back into the calibrated view (``correct``), and the boxes the
  tracker reports back out (``uncorrect``): a rotation about the centre is the image homography
  ``K R K^-1``.
- A camera out of sync by ``o`` frames shows its points where the others saw them ``o`` frames
  earlier: its residual is ``-o`` times its points' image velocity. The least-squares ``o``
  over the routine (:meth:`DriftMonitor.sync_suspects`) names the camera and the likely offset.

Shapes: a window's clusters ``members`` (M, C), segments' undistorted boxes (K, W, 4).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import GymtrackWarning
from ..geometry.camera import Camera, Rig

__all__ = ["DriftMonitor", "turn_pixels", "fit_rotation"]

BASELINE_SECONDS = 5.0  # the seconds of residuals before the last one: where the camera was
RECENT_SECONDS = 1.0  # a camera's residual must have stepped away for this long
MIN_DEG = 0.3  # the smallest step reported (below: how much the box centres' agreement wanders)
NOISE_FACTOR = 3.0  # ... or this many times the scatter of a half second's median (from the windows')
CONSISTENT = 2.0  # the fitted turn may be at most this many times the step (plus MIN_DEG)
SEPARATION = 1.5  # the knocked camera's step against the largest of the others' (which it drags along)
MAX_RESIDUAL = 0.05  # radians (3 deg): a larger leave-one-out residual is a wrong association, not drift
MIN_POINTS = 8  # points of a camera in a window for its median to count


def turn_pixels(cam: Camera, uv: np.ndarray, rotation: np.ndarray) -> np.ndarray:
    """(n, 2) raw pixels of ``cam`` -> where they lie after the camera turned by ``rotation`` (3, 3,
    camera coordinates) about its centre: every ray turns by ``rotation`` (distortion undone, then
    applied again)."""
    if not len(uv):
        return np.asarray(uv, dtype=np.float64)
    x = cam.undistort(uv)
    ray = np.c_[x, np.ones(len(x))] @ np.linalg.inv(cam.K).T
    return cam.project(cam.centre + (ray @ rotation.T) @ cam.R)


def fit_rotation(before: np.ndarray, after: np.ndarray) -> np.ndarray:
    """(n, 3) directions in the calibrated camera, (n, 3) where the camera sees them now -> the
    rotation ``R`` (3, 3) with ``after ~ R before`` (least squares on unit vectors; Kabsch)."""
    a = before / np.linalg.norm(before, axis=1, keepdims=True)
    b = after / np.linalg.norm(after, axis=1, keepdims=True)
    U, _, Vt = np.linalg.svd(b.T @ a)
    d = np.sign(np.linalg.det(U @ Vt))
    return U @ np.diag([1.0, 1.0, d]) @ Vt


def _degrees(R: np.ndarray) -> float:
    return float(np.degrees(np.arccos(np.clip((np.trace(R) - 1) / 2, -1, 1))))


class DriftMonitor:
    """Leave-one-out residuals per camera and window; knock events; the sync regression.

    rig: the cameras; fps: frames per second; step: frames between windows; opposite: (C, C) bool,
    the view pairs judged opposite (:func:`~gymtrack.geometry.views.opposite_pairs`); recalibrate:
    re-estimate a knocked camera's rotation and correct its later boxes.
    """

    def __init__(self, rig: Rig, fps: float, step: int, opposite: np.ndarray, recalibrate: bool = True):
        self.rig, self.fps, self.recalibrate = rig, fps, recalibrate
        self.opposite = np.asarray(opposite, dtype=np.float64)  # (C, C) opposite view pairs
        C = self.C = len(rig)
        self.Kinv = np.stack([np.linalg.inv(c.K) for c in rig])
        self.Pn = np.stack([np.c_[c.R, c.t] for c in rig])  # (C, 3, 4) normalised projections
        self.n_base = max(3, int(round(BASELINE_SECONDS * fps / step)))
        self.n_recent = max(3, int(round(RECENT_SECONDS * fps / step)))
        self.step = step
        # per camera and window: (last frame, median residual (2,), residuals (n, 2), points (n, 3), rays (n, 3))
        # the view pairs that triangulate (not opposite: ill-conditioned there); a camera is judged
        # by the points of each pair without it (a knocked camera drags the pairs it is in)
        pa, pb = np.triu_indices(C, 1)
        keep = ~np.asarray(opposite, bool)[pa, pb]
        self.pairs = (pa[keep], pb[keep])
        self.outside = np.ones((len(self.pairs[0]), C), bool)  # (Np, C) the views outside each pair
        self.outside[np.arange(len(self.pairs[0])), self.pairs[0]] = False
        self.outside[np.arange(len(self.pairs[0])), self.pairs[1]] = False
        self.history: list[list[tuple]] = [[] for _ in range(C * len(self.pairs[0]))]  # per camera x pair
        self.last_frame = 0
        self.sums = np.zeros((C, 5))  # sync regression per camera: n, sum v.v, sum v.r, sum v, sum r
        self.events: list[dict] = []
        self.turns: dict[int, tuple[int, np.ndarray]] = {}  # camera -> (from frame, rotation now vs calibrated)
        self.first: int | None = None

    # ------------------------------------------------------------ per window
    def observe(self, start: int, box: np.ndarray, observed: np.ndarray, members: np.ndarray) -> None:
        """One window: segments' undistorted boxes (K, W, 4), observed (K, W), clusters (M, C)."""
        if self.first is None:
            self.first = start
        members = members[(members >= 0).sum(axis=1) >= 3]
        if not len(members):
            return
        has = members >= 0
        idx = np.where(has, members, 0)
        obs = observed[idx] & has[..., None]  # (M, C, W)
        uv = box[idx][..., :2]  # (M, C, W, 2)
        x = np.einsum("cij,mcwj->mcwi", self.Kinv[:, :, :2], uv) + self.Kinv[None, :, None, :, 2]  # rays (M, C, W, 3)
        x = x[..., :2] / x[..., 2:]
        # the DLT rows of every view (M, C, W, 2, 4); a view left out or unobserved adds nothing
        P = self.Pn[None, :, None]
        rows = np.stack([x[..., 0:1] * P[..., 2, :] - P[..., 0, :], x[..., 1:2] * P[..., 2, :] - P[..., 1, :]], -2)
        rows = np.where(obs[..., None, None], rows, 0.0)
        own = np.einsum("mcwri,mcwrj->mcwij", rows, rows)  # (M, C, W, 4, 4) each view's DLT normal matrix
        pa, pb = self.pairs
        pair_ok = obs[:, pa] & obs[:, pb]  # (M, Np, W): the pair saw the point
        if not pair_ok.any():
            return
        _, vec = np.linalg.eigh(own[:, pa][pair_ok] + own[:, pb][pair_ok])
        X = vec[:, :, 0]  # (the eigenvector of the smallest eigenvalue)
        X = X[:, :3] / X[:, 3:]  # (n, 3) world points, each from one pair of views
        m, p, w = np.nonzero(pair_ok)
        third = obs[m, :, w] & self.outside[p]  # (n, C) the views that saw it, outside the pair
        i, cam = np.nonzero(third)
        pc = np.einsum("nij,nj->ni", self.Pn[cam], np.c_[X[i], np.ones(len(i))])
        seen = x[m[i], cam, w[i]]
        r = seen - pc[:, :2] / pc[:, 2:]  # seen - predicted (radians, small angles)
        ok = (pc[:, 2] > 0) & (np.hypot(r[:, 0], r[:, 1]) < MAX_RESIDUAL)
        # image velocity of the seen points (central differences inside the window)
        v = np.full_like(x, np.nan)
        both = obs[..., 2:] & obs[..., :-2]
        v[:, :, 1:-1] = np.where(both[..., None], (x[:, :, 2:] - x[:, :, :-2]) / 2, np.nan)
        self._sync(cam[ok], r[ok], v[m[i], cam, w[i]][ok])
        self.last_frame = frame = start + observed.shape[1] - 1
        key = cam * len(pa) + p[i]
        for k in np.unique(key[ok]):
            sel = ok & (key == k)
            if sel.sum() >= MIN_POINTS:
                self._knock(int(k), frame, r[sel], X[i[sel]], np.c_[seen[sel], np.ones(sel.sum())])
        self._check()

    def _sync(self, cam: np.ndarray, r: np.ndarray, v: np.ndarray) -> None:
        good = np.isfinite(v).all(axis=1)
        cam, r, v = cam[good], r[good], v[good]
        add = np.stack([np.ones(len(cam)), (v * v).sum(1), (v * r).sum(1), np.zeros(len(cam)), np.zeros(len(cam))], 1)
        np.add.at(self.sums, cam, add)

    def _knock(self, k: int, frame: int, r: np.ndarray, X: np.ndarray, seen: np.ndarray) -> None:
        """Residuals (n, 2) of one camera x pair ``k`` in the window ending at ``frame``, kept for the step test."""
        h = self.history[k]
        h.append((frame, np.median(r, axis=0), r, X, seen))
        del h[:-(self.n_base + self.n_recent)]

    def _steps(self) -> tuple[np.ndarray, np.ndarray]:
        """(C,) each camera's step: the last second's pooled median residual against the median of
        the seconds before (radians; 0 while the history is short), and (C,) its threshold."""
        n = len(self.history)
        step, thr = np.zeros(n), np.full(n, np.inf)
        for c, h in enumerate(self.history):
            if len(h) < self.n_base + self.n_recent or h[-1][0] != self.last_frame:
                continue
            meds = np.array([m for _, m, *_ in h[:self.n_base]])
            base = np.median(meds, axis=0)
            scatter = 1.4826 * np.median(np.hypot(*(meds - base).T))
            recent = h[self.n_base:]
            half = len(recent) // 2
            step[c] = min(np.hypot(*(np.median(np.concatenate([x[2] for x in part]), axis=0) - base))
                          for part in (recent, recent[:half], recent[half:]))  # the whole second moved, both halves
            thr[c] = max(np.radians(MIN_DEG), NOISE_FACTOR * scatter / np.sqrt(half))
        return step, thr

    def _check(self) -> None:
        """A knock: the camera whose step (the smallest over the pairs that judge it) passes its
        threshold and is clearly the largest."""
        step_k, thr_k = self._steps()
        Np = len(self.pairs[0])
        ratio = (step_k / thr_k).reshape(self.C, Np)
        ready = np.isfinite(thr_k).reshape(self.C, Np)
        if not ready.any(axis=1).sum() >= 2:
            return
        ratio = np.where(ready, ratio, np.inf).min(axis=1)  # each camera: its least-moved pair
        ratio[~ready.any(axis=1)] = 0.0
        c = int(np.argmax(ratio))
        others = np.delete(ratio, c)
        if not ratio[c] > 1 or (len(others) and ratio[c] < SEPARATION * others.max()):
            return
        k = c * Np + int(np.argmin(np.where(ready[c], step_k.reshape(self.C, Np)[c] / thr_k.reshape(self.C, Np)[c], np.inf)))
        step, thr = step_k, thr_k
        h = self.history[k]
        base = np.median(np.array([m for _, m, *_ in h[:self.n_base]]), axis=0)
        dev = np.array([np.hypot(*(m - base)) for _, m, *_ in h])
        moved = dev > step[k] / 2
        first = self.n_base  # the first window of the run of moved windows reaching into the last second
        while first > 0 and moved[first - 1]:
            first -= 1
        first += int(np.argmax(moved[first:]))
        started = h[first][0] - self.step + 1
        frame = self.last_frame
        # the turn: the rotation fitted to the moved windows' points against the one fitted before
        # (which holds the calibration's own small error); a step that no rotation explains is not a knock
        R = self._refit(c, h[max(first, self.n_base):]) @ self._refit(c, h[:first]).T
        if not _degrees(R) <= CONSISTENT * np.degrees(step[k]) + MIN_DEG:
            return  # (judged again at the next window: a knock's turn is fitted well once its second has passed)
        event = {"camera": self.rig.names[c], "start_frame": int(started), "detected_frame": int(frame),
                 "start_seconds": round((started - self.first) / self.fps, 2),
                 "degrees": round(float(np.degrees(step[k])), 2), "turn_degrees": round(_degrees(R), 2)}
        if self.recalibrate:
            prev = self.turns.get(c, (0, np.eye(3)))[1]
            self.turns[c] = (int(frame) + 1, R @ prev)
            event |= {"recalibrated_from_frame": int(frame) + 1, "rotation_degrees": round(_degrees(R @ prev), 2)}
        self.events.append(event)
        warnings.warn(f"camera {event['camera']} moved by about {event['degrees']} deg from frame {started} "
                      f"({event['start_seconds']} s): knocked? " + (f"its rotation was re-estimated "
                      f"({event['rotation_degrees']} deg) and applied from frame {frame + 1}" if self.recalibrate
                      else "recalibrate it"), GymtrackWarning, stacklevel=2)
        for past in self.history:  # every camera's residuals moved with it: a new baseline after the move
            past.clear()

    def _refit(self, c: int, windows: list[tuple]) -> np.ndarray:
        """The rotation of camera ``c`` against its calibration, from the (n, 3) world points the
        other views triangulated and the (n, 3) rays it saw them on (camera coordinates) of ``windows``."""
        X = np.concatenate([x[3] for x in windows])
        seen = np.concatenate([x[4] for x in windows])
        cam = self.rig[c]
        return fit_rotation((X - cam.centre) @ cam.R.T, seen)

    # ------------------------------------------------------------ boxes in and out
    def correct(self, frame: int, camera: np.ndarray, box: np.ndarray) -> np.ndarray:
        """(n,) cameras, (n, 4) raw boxes of one frame -> the boxes as the calibrated cameras see them."""
        for c, (first, R) in self.turns.items():
            m = np.flatnonzero(camera == c)
            if frame >= first and len(m):
                box = box.copy()
                box[m, :2] = turn_pixels(self.rig[c], box[m, :2], R.T)
        return box

    def uncorrect(self, frame: np.ndarray, camera: np.ndarray, box: np.ndarray) -> np.ndarray:
        """The tracker's reported boxes (n,) moved back into the turned cameras' images."""
        for c, (first, R) in self.turns.items():
            m = np.flatnonzero((camera == c) & (frame >= first))
            if len(m):
                box = box.copy()
                box[m, :2] = turn_pixels(self.rig[c], box[m, :2], R)
        return box

    def uncorrect_output(self, out):
        """A :class:`~.types.TrackerOutput` with its boxes moved back into the turned cameras' images."""
        import dataclasses

        def back(d):
            if not len(d):
                return d
            return type(d).of_columns(d.frame, d.camera, self.uncorrect(d.frame, d.camera, d.box), d.score, d.track_id,
                                      d.camera_names)

        return dataclasses.replace(out, boxes=back(out.boxes), target_boxes=back(out.target_boxes))

    # ------------------------------------------------------------ at the end
    def warn_sync(self) -> None:
        """A warning for a camera whose residuals say it is out of sync."""
        for s in self.sync_suspects():
            warnings.warn(f"camera {s['camera']} is probably out of sync by {s['offset']:+d} frames (its residuals "
                          f"follow its points' motion, {s['estimate']:+.2f} frames): run gymtrack sync", GymtrackWarning,
                          stacklevel=3)

    def sync_suspects(self, min_frames: float = 0.5) -> list[dict]:
        """Cameras whose residuals follow their points' motion: ``[{camera, offset, frames}]`` for a
        least-squares offset of ``min_frames`` or more (``offset`` as scene.yaml's frame_offsets)."""
        out = []
        n, vv, vr = self.sums[:, 0], self.sums[:, 1], self.sums[:, 2]
        with np.errstate(invalid="ignore", divide="ignore"):
            o = -vr / vv
        worst = int(np.nanargmax(np.abs(o))) if np.isfinite(o).any() else -1
        if worst >= 0 and abs(o[worst]) >= min_frames and n[worst] >= 50:
            out.append({"camera": self.rig.names[worst], "offset": int(np.round(o[worst])),
                        "estimate": round(float(o[worst]), 2), "points": int(n[worst])})
        return out

    def summary(self) -> dict:
        """What the summary reports (empty on a clean routine)."""
        s = {}
        if self.events:
            s["camera_moved"] = self.events
        if sus := self.sync_suspects():
            s["camera_out_of_sync"] = sus
        return s
