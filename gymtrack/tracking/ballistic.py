"""Ballistic flights of the target (the recipe's ``ballistic``): gravity keeps the target through
detector gaps in the air.

Beyond the paper (Section III-D's target stage). In the air the body's centre of mass follows a
parabola under g = 9.81 m/s^2, exactly; flights, releases and dismounts are where detectors miss
boxes (motion blur, inverted bodies) and tracks break. The box centre stands in for the centre of
mass. It is not on the parabola itself: it moves up to ~0.3 m about the centre of mass as the body
folds and turns (0.2 m in 0.2 s as a vault's body folds into its pike), so a parabola fitted over
a third of a second drifts by up to ~0.7 m before the landing -- near enough to hold the target
and hand it to the track that resumes it.

* :func:`fit_flight` -- the parabola with g fixed, fitted by least squares to the target's last
  points: ``x(t) = x0 + vx t``, ``y(t) = y0 + vy t``, ``z(t) = z0 + vz t - g t^2 / 2`` (t in
  seconds from the last point). Its rms residual and that of a straight line at constant speed
  decide whether the target is **airborne** (:meth:`Flight.airborne`): the parabola explains the
  last :data:`FIT_FRAMES` points within :data:`RMS_MAX` and no worse than constant velocity does
  (within :data:`RMS_TOL`: over a third of a second the two differ by a few centimetres, the
  tracker's noise; a flight whose track breaks soon after take-off needs it), the body's bottom
  is off the floor (:data:`MIN_BOTTOM`) and the parabola's apex is above the landing height by
  more than the fit's noise (:data:`RMS_MAX`): a body at rest that passes the fit has no flight
  left to predict (held in place, a wrong target at rest kept the gymnast's own track out).
* :meth:`Flight.predict` -- the parabola until the centre comes down to the landing height (the
  lowest centre height of the target in the last :data:`SUPPORT_SECONDS`, the support it stood on
  before), then the landing point, held.
* :class:`FlightKeeper` -- the target stage's use of it: frames the target is held without a
  point of its track (a detector gap in flight, or the gap until the track that resumes it takes
  over, :mod:`.handover`) get the predicted centre as a point (source ``interpolated``, no
  detection: Eq. 14's body box is projected into every view around it), and the handover asks it
  where the target should be when a new track is born.

State (bounded): every track's points of the last :data:`SUPPORT_SECONDS`.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .types import INTERPOLATED, TargetRows, member

__all__ = ["G", "FIT_FRAMES", "Flight", "FlightKeeper", "fit_flight"]

G = 9.81  #: m/s^2
FIT_FRAMES = 10  #: the last points of the target fitted (a third of a second at 30 fps)
MIN_POINTS = 6  #: fewer points in the fit's reach: no flight
RMS_MAX = 0.08  #: metres: the parabola's rms residual at most (twice the two-view tracker's centre noise in flight)
RMS_TOL = 0.03  #: metres: the parabola's rms residual exceeds constant velocity's by no more (noise)
MIN_BOTTOM = 0.3  #: metres: the body's bottom above the floor, or it is standing or running
SUPPORT_SECONDS = 2.0  #: the landing height is the lowest centre height of this last stretch
MAX_SECONDS = 1.5  #: a prediction reaches this far past the last point at most (a vault's flight is under 1.5 s)
HOLD_SECONDS = 0.5  #: the landing point is held this long after the predicted landing


@dataclass(frozen=True)
class Flight:
    """A ballistic fit: centre ``p`` (3,) and velocity ``v`` (3,) at frame ``frame`` (the last
    point); ``rms`` of the parabola and ``rms_line`` of constant velocity (metres); ``bottom``: the
    body's bottom height at the last point (NaN: unknown); ``land_z``: the height the centre comes
    down to; ``fps``."""

    frame: int
    p: np.ndarray
    v: np.ndarray
    rms: float
    rms_line: float
    bottom: float
    land_z: float
    fps: float

    @property
    def airborne(self) -> bool:
        """The parabola holds and explains the points better than constant velocity, off the floor."""
        off = not np.isfinite(self.bottom) or self.bottom > MIN_BOTTOM
        apex = self.p[2] + max(float(self.v[2]), 0.0) ** 2 / (2 * G)
        # a body within the fit's noise of its landing height has no flight left to predict (at rest)
        return bool(self.rms <= RMS_MAX and self.rms <= self.rms_line + RMS_TOL and off and apex > self.land_z + RMS_MAX)

    def landing_frame(self) -> float:
        """The (fractional) frame at which the centre comes down to ``land_z``."""
        vz, dz = float(self.v[2]), float(self.p[2] - self.land_z)
        t = (vz + np.sqrt(max(vz * vz + 2 * G * dz, 0.0))) / G
        return self.frame + t * self.fps

    def predict(self, frames: np.ndarray) -> np.ndarray:
        """(n, 3) the predicted centre at ``frames`` (after the last point): the parabola, then the landing point."""
        t = (np.asarray(frames, np.float64) - self.frame) / self.fps
        t = np.minimum(t, max((self.landing_frame() - self.frame) / self.fps, 0.0))
        out = self.p + t[:, None] * self.v
        out[:, 2] -= 0.5 * G * t * t
        return out

    def reach(self) -> int:
        """The last frame a prediction is used for: the landing plus :data:`HOLD_SECONDS`, within :data:`MAX_SECONDS`."""
        end = min(self.landing_frame() + HOLD_SECONDS * self.fps, self.frame + MAX_SECONDS * self.fps)
        return int(np.floor(end))


def fit_flight(frame: np.ndarray, xyz: np.ndarray, fps: float, bottom: float = np.nan,
               land_z: float | None = None) -> Flight | None:
    """The ballistic fit to points (frame (n,), xyz (n, 3)) ending at the last one (see the module
    docstring); None under :data:`MIN_POINTS` points. ``land_z``: the landing height (None: the
    lowest of these points)."""
    frame = np.asarray(frame, np.float64)
    xyz = np.asarray(xyz, np.float64)
    if len(frame) < MIN_POINTS:
        return None
    t = (frame - frame[-1]) / fps
    A = np.stack([np.ones_like(t), t], axis=1)
    y = xyz.copy()
    y[:, 2] += 0.5 * G * t * t  # z + g t^2 / 2 is linear in t
    coef, *_ = np.linalg.lstsq(A, y, rcond=None)  # (2, 3): position and velocity at the last point
    res = y - A @ coef
    line, *_ = np.linalg.lstsq(A, xyz[:, 2], rcond=None)
    rms = float(np.sqrt(np.mean(np.sum(res * res, axis=1))))
    res_line = xyz[:, 2] - A @ line
    rms_line = float(np.sqrt(np.mean(res_line * res_line + np.sum(res[:, :2] ** 2, axis=1))))
    land = float(xyz[:, 2].min()) if land_z is None else float(land_z)
    return Flight(int(frame[-1]), coef[0], coef[1], rms, rms_line, float(bottom), land, float(fps))


class FlightKeeper:
    """Every track's recent points and the target's flights (see the module docstring).

    fps: frames per second; counts: the tracker's counters (``ballistic_points``). Use per run of
    final frames ``a..b`` with the target's decision per frame: ``rows = keeper.fill(a, target,
    rows)`` (rows: every track's points, frame order); :meth:`airborne` for the handover.
    """

    def __init__(self, fps: float, counts: dict):
        self.fps, self.counts = float(fps), counts
        self.keep = int(round(SUPPORT_SECONDS * fps))
        # every track's points of the last SUPPORT_SECONDS, as the windows gave them: joined only
        # when a fit asks (most windows' targets have a point in every frame and ask nothing)
        self._chunks: list[TargetRows] = []
        self._cut = -(1 << 62)  # points at or before this frame have left the history

    def __len__(self) -> int:
        return 0 if self.rows is None else len(self.rows)

    @property
    def rows(self) -> TargetRows | None:
        """Every track's points of the last SUPPORT_SECONDS (frame order), or None."""
        if not self._chunks:
            return None
        h = self._chunks[0] if len(self._chunks) == 1 else TargetRows.concat(self._chunks)
        old = h.frame <= self._cut
        if old.any():
            h = h.take(~old)
        self._chunks = [h]
        return h

    def observe(self, rows: TargetRows) -> None:
        """Points of every track (frame order) join the history; the oldest leave it."""
        if not len(rows):
            return
        self._chunks.append(rows)
        self._cut = max(self._cut, int(rows.frame[-1]) - self.keep)
        while len(self._chunks) > 1 and self._chunks[0].frame[-1] <= self._cut:  # (wholly old)
            del self._chunks[0]

    def flight(self, track: int, upto: int | None = None) -> Flight | None:
        """The fit to the last points of ``track`` up to frame ``upto`` (None: all held), or None."""
        if self.rows is None:
            return None
        h = self.rows
        m = h.track_id == track
        if upto is not None:
            m &= h.frame <= upto
        i = np.flatnonzero(m)
        if len(i) < MIN_POINTS:
            return None
        fit = i[-FIT_FRAMES:]
        fit = fit[h.frame[fit] > h.frame[fit[-1]] - int(1.5 * FIT_FRAMES)]  # no older than the fit's reach
        if len(fit) < MIN_POINTS:
            return None
        return fit_flight(h.frame[fit], h.xyz[fit], self.fps, h.bottom_z[fit[-1]], float(h.xyz[i, 2].min()))

    def airborne(self, track: int, upto: int | None = None) -> Flight | None:
        """The flight at the last point of ``track`` up to ``upto`` if it is airborne there, else None."""
        f = self.flight(track, upto)
        return f if f is not None and f.airborne else None

    def extend(self, a: int, b: int, track: int, rows: TargetRows) -> TargetRows:
        """Before Eq. 13 decides frames ``a..b``: the rows (every track's, frame order) join the
        history, and the frames without a point of the target's ``track`` after its last one,
        within reach of an airborne fit there, get the predicted point as the track's (first in
        their frame, so that a real point of a track that took over is the one the target keeps)."""
        self.observe(rows)
        if track < 0 or not self._chunks:
            return rows
        seen = rows.frame[rows.track_id == track]
        if len(seen) == b - a + 1:  # a point in every frame (the common case): nothing to predict
            return rows
        fl = self.airborne(track, a - 1)
        if fl is None or fl.reach() < a:
            return rows
        frames = np.arange(a, min(b, fl.reach()) + 1)
        frames = frames[~member(frames, seen)]
        if not len(frames):
            return rows
        out = TargetRows.concat([self._points(fl, track, frames, rows.wh.shape[1:]), rows])
        return out.take(np.argsort(out.frame, kind="stable"))

    def _points(self, fl: Flight, track: int, frames: np.ndarray, wh_shape: tuple) -> TargetRows:
        """The predicted points of ``track`` at ``frames`` (its body's extent as at its last point)."""
        p = fl.predict(frames)
        j = np.flatnonzero((self.rows.track_id == track) & (self.rows.frame <= fl.frame))[-1]  # its last point
        up, down = self.rows.top_z[j] - self.rows.xyz[j, 2], self.rows.xyz[j, 2] - self.rows.bottom_z[j]
        self.counts["ballistic_points"] += len(frames)
        return TargetRows.of(frames, np.full(len(frames), track), p, p[:, 2] + up, p[:, 2] - down,
                             np.full(len(frames), INTERPOLATED, np.int8), np.full((len(frames), *wh_shape), np.nan))

    def fill(self, a: int, target: np.ndarray, rows: TargetRows) -> TargetRows:
        """Rows of frames ``a..`` (every track's, frame order) with the target's decision per frame
        (``target`` (F,), -1: none) after Eq. 13 (rows already observed by :meth:`extend`):
        frames the target is held without a point, within reach of an airborne fit of its track,
        get the predicted point (a target identified after its track ended)."""
        has = np.zeros(len(target), bool)
        i = rows.frame - a
        has[i[rows.track_id == target[i]]] = True
        held = np.flatnonzero((target >= 0) & ~has)
        if not len(held) or not self._chunks:
            return rows
        add = []
        for k in _runs(held, target[held]):
            f0, tid = a + int(held[k[0]]), int(target[held[k[0]]])
            fl = self.airborne(tid, f0 - 1)
            if fl is None:
                continue
            frames = a + held[k]
            frames = frames[frames <= fl.reach()]
            if not len(frames):
                continue
            add.append(self._points(fl, tid, frames, rows.wh.shape[1:]))
        if not add:
            return rows
        out = TargetRows.concat([rows, *add])
        return out.take(np.argsort(out.frame, kind="stable"))


def _runs(idx: np.ndarray, label: np.ndarray) -> list[np.ndarray]:
    """Indices into ``idx`` (sorted ints) split into runs of consecutive values of one label."""
    cut = np.flatnonzero((np.diff(idx) > 1) | (np.diff(label) != 0)) + 1
    return np.split(np.arange(len(idx)), cut)
