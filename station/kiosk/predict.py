"""Pen-position prediction: where the pen will be when the frame is seen.

A frame shows the pen where it was when its last sample was read; by the
time the frame is on the screen the pen has moved on (at 0.5 m/s, 8 mm per
16 ms).  Drawing the brush's shadow a little ahead along the pen's motion hides
part of that lag, as the better drawing tools and tablet drivers do.  How far
ahead: by default the lag itself, as the window measures it (:class:`LagEstimate`).

:class:`PenPredictor` is a constant-velocity extrapolation: the velocity is
the least-squares slope of position over time of the samples of the last
:attr:`PredictConfig.window_s` seconds (a straight fit over several samples,
so the tablet's quantisation and jitter do not become velocity), clamped at
:attr:`PredictConfig.max_speed`; the prediction is the fitted line evaluated
``horizon`` seconds after the last sample.  It is reset when the pen leaves
proximity or the tip goes down or up (a new stroke starts from rest), and it
does not extrapolate from a sample older than :attr:`PredictConfig.stale_s`
(a pen held still).

The prediction moves only the shadow (and, with the tip down, the shadow is
where the paint is about to go: a provisional preview).  Paint is never put
where the pen is predicted to be: the committed stroke is the samples'.

Units: positions in window pixels, sample times in seconds of the device's
clock (``PenSample.t``: regular report spacing, unlike read or receipt times,
which bunch when a process is descheduled).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class PredictConfig:
    """How the pen is predicted (see the module docstring)."""

    horizon_s: float = 0.016  # how far ahead of the last sample [s]; 0: no prediction
    window_s: float = 0.03  # samples in the velocity fit [s]
    min_samples: int = 3
    max_speed: float = 4000.0  # clamp of the fitted speed [pixels/s]
    stale_s: float = 0.05  # a sample older than this is not extrapolated [s]


class LagEstimate:
    """The window's own pen-to-screen lag, measured frame by frame: how long before a
    frame was shown its last pen sample was read [s].  An exponential average (a frame
    that was slow for once moves it a little), clamped to ``[0, most]``; what an ``auto``
    prediction horizon uses — the lag of this display on this machine, not a guess."""

    def __init__(self, initial: float = 0.016, weight: float = 0.1, most: float = 0.05) -> None:
        self.value = initial
        self.weight = weight
        self.most = most
        self.frames = 0

    def add(self, lag: float) -> float:
        lag = min(max(lag, 0.0), self.most)
        self.value += self.weight * (lag - self.value)
        self.frames += 1
        return self.value


class PenPredictor:
    """Constant-velocity prediction of the pen (see the module docstring)."""

    def __init__(self, cfg: PredictConfig | None = None) -> None:
        self.cfg = cfg or PredictConfig()
        self._pts: deque[tuple[float, float, float]] = deque()
        self._touching: bool | None = None

    def reset(self) -> None:
        self._pts.clear()

    def add(self, t: float, x: float, y: float, near: bool, touching: bool) -> None:
        """One pen sample: time [s], window position [px], in proximity, tip down."""
        if not near or touching != self._touching:
            self.reset()
        self._touching = touching if near else None
        if not near:
            return
        if self._pts and t <= self._pts[-1][0]:
            if t < self._pts[-1][0]:
                self.reset()  # time went back: another device or a restarted driver
            else:
                self._pts.pop()  # same time stamp: the newer position wins
        self._pts.append((t, x, y))
        while self._pts and self._pts[0][0] < t - self.cfg.window_s:
            self._pts.popleft()

    def last(self) -> tuple[float, float, float] | None:
        """The last sample (t, x, y), or ``None`` out of proximity."""
        return self._pts[-1] if self._pts else None

    def velocity(self) -> tuple[float, float]:
        """The fitted velocity [px/s], clamped; zero with too few samples."""
        pts = self._pts
        if len(pts) < max(self.cfg.min_samples, 2):
            return (0.0, 0.0)
        a = np.asarray(pts, dtype=np.float64)
        t = a[:, 0] - a[:, 0].mean()
        den = float(t @ t)
        if den <= 0.0:
            return (0.0, 0.0)
        vx = float(t @ (a[:, 1] - a[:, 1].mean())) / den
        vy = float(t @ (a[:, 2] - a[:, 2].mean())) / den
        speed = float(np.hypot(vx, vy))
        if speed > self.cfg.max_speed:
            vx, vy = vx * self.cfg.max_speed / speed, vy * self.cfg.max_speed / speed
        return (vx, vy)

    def predict(self, age: float | None = None) -> tuple[float, float] | None:
        """The pen ``horizon`` after its last sample (``None`` out of proximity).

        ``age``: how long ago the last sample came (the caller's clock); one older than
        ``stale_s`` is not extrapolated (the pen stopped, or samples stopped coming).
        """
        last = self.last()
        if last is None:
            return None
        _t, x, y = last
        h = self.cfg.horizon_s
        if h <= 0.0 or (age is not None and age > self.cfg.stale_s):
            return (x, y)
        vx, vy = self.velocity()
        return (x + vx * h, y + vy * h)


def trajectory_at(times: np.ndarray, xy: np.ndarray, t: float) -> tuple[float, float] | None:
    """The pen at time ``t`` between two samples (linear), ``None`` outside them."""
    if times.size == 0 or t < times[0] or t > times[-1]:
        return None
    i = int(np.searchsorted(times, t))
    if i == 0:
        return (float(xy[0, 0]), float(xy[0, 1]))
    t0, t1 = times[i - 1], times[i]
    f = 0.0 if t1 <= t0 else (t - t0) / (t1 - t0)
    p = xy[i - 1] + (xy[i] - xy[i - 1]) * f
    return (float(p[0]), float(p[1]))


def prediction_errors(times: np.ndarray, xy: np.ndarray, strokes: np.ndarray,
                      cfg: PredictConfig) -> np.ndarray:
    """Distance [px] between the prediction made at each sample and where the pen was
    ``horizon`` later (same stroke only), replaying the samples through a fresh
    predictor: the predictor's own error at its horizon."""
    pred = PenPredictor(cfg)
    out = []
    for i in range(times.size):
        if i > 0 and strokes[i] != strokes[i - 1]:
            pred.reset()
        pred.add(float(times[i]), float(xy[i, 0]), float(xy[i, 1]), True, True)
        p = pred.predict()
        sel = strokes == strokes[i]
        truth = trajectory_at(times[sel], xy[sel], float(times[i]) + cfg.horizon_s)
        if p is not None and truth is not None:
            out.append(float(np.hypot(p[0] - truth[0], p[1] - truth[1])))
    return np.asarray(out)


def perceived_lag(times: np.ndarray, xy: np.ndarray, shown_t: np.ndarray,
                  shown_xy: np.ndarray, search_s: float = 0.25) -> np.ndarray:
    """For each frame (shown at ``shown_t`` with the shadow at ``shown_xy``): how long
    ago the pen was where the shadow is — the time from the point of the pen's path
    (within ``search_s`` before to 50 ms after the frame) closest to the shadow, to
    the frame.  Without prediction this is the pen-to-screen lag of the shadow; a good
    prediction brings it towards zero (negative: the shadow runs ahead)."""
    out = []
    for t_f, p in zip(shown_t, shown_xy, strict=True):
        lo = int(np.searchsorted(times, t_f - search_s))
        hi = int(np.searchsorted(times, t_f + 0.05))
        if hi - lo < 2:
            continue
        best_d, best_t = np.inf, 0.0
        for i in range(lo, hi - 1):  # closest point on each segment of the path
            a, b = xy[i], xy[i + 1]
            ab = b - a
            den = float(ab @ ab)
            f = 0.0 if den <= 0.0 else min(max(float((p - a) @ ab) / den, 0.0), 1.0)
            d = float(np.hypot(*(a + ab * f - p)))
            if d < best_d:
                best_d, best_t = d, float(times[i] + (times[i + 1] - times[i]) * f)
        out.append(t_f - best_t)
    return np.asarray(out)
