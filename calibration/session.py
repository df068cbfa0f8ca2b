"""The logic of an interactive calibration, free of any window.

:class:`CalibrationSession` shows targets one at a time (5 or 9 in the
position pass, then optionally a tilt pass: the 5-point targets again with
the pen leaning two ways), turns the samples it is fed into taps, rejects
misclicks on the spot and finally fits the mapping (parallax included when a
tilt pass was done).

On-the-spot misclick rejection (xinput_calibrator style, in screen pixels,
default threshold 15 px):

* the first tap is accepted;
* with fewer than three accepted taps, each new tap must keep the axis
  alignment of its target with every accepted one: targets that share a
  screen column must share a device column (within the threshold plus 5 %
  of the distance between them, so a slightly rotated mounting passes); the
  device axis that moves with the screen's x is found from the second tap,
  which detects swapped axes;
* from three non-collinear accepted taps on, an affine fit (a homography from
  five) of the accepted taps must predict the new tap's target within the
  threshold.

A rejected tap is reported and the same target is asked again; a re-tap that
lands where the rejected one did (within the threshold) is accepted — the
user insists, so the provisional model is what is wrong — and left to the
final robust fit to judge.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from station.calibration.errors import DegeneratePoints
from station.calibration.fit import COLLINEAR_TOL, FitReport, PointSet, fit_mapping, fit_points
from station.calibration.geometry import planarity
from station.calibration.taps import Tap, TapDetector

from station.events import PenSample

INSET = 0.1  # targets sit this fraction in from the screen edges


def target_grid(points: int) -> list[tuple[float, float]]:
    """Target positions, screen-normalised: 4 corners, +centre (5), or a 3×3 grid (9)."""
    lo, hi = INSET, 1.0 - INSET
    corners = [(lo, lo), (hi, lo), (hi, hi), (lo, hi)]
    if points == 4:
        return corners
    if points == 5:
        return [*corners, (0.5, 0.5)]
    if points == 9:
        g = (lo, 0.5, hi)
        return [(x, y) for y in g for x in g]
    raise DegeneratePoints(f"{points} targets: choose 4, 5 or 9")


TILT_HINTS = ((-30.0, 30.0), (30.0, -30.0), (30.0, 30.0), (-30.0, -30.0))
"""Tilt pass leans (degrees), cycled over the targets so that tilt_x and tilt_y vary
independently (with only two opposite leans they would be tied and the two
parallax axes harder to tell apart)."""


@dataclass
class TapResult:
    target: int
    xy: tuple[float, float]  # screen-normalised target
    tap: Tap
    accepted: bool
    reason: str = ""
    predicted_px: tuple[float, float] | None = None  # where a provisional fit put the tap


@dataclass
class CalibrationSession:
    """Drives one calibration (see the module docstring)."""

    screen: tuple[int, int]
    points: int = 9
    tilt_pass: bool = False
    misclick_px: float = 15.0
    model: str = "auto"
    targets: list[tuple[float, float]] = field(init=False)
    hints: list[tuple[float, float] | None] = field(init=False)
    current: int = 0
    results: list[TapResult] = field(default_factory=list)
    swapped_axes: bool | None = None
    report: FitReport | None = None
    reasked: bool = False
    detector: TapDetector = field(default_factory=lambda: TapDetector(
        min_duration=0.02, settle=0.01, max_spread=0.02))

    def __post_init__(self) -> None:
        grid = target_grid(self.points)
        self.targets = list(grid)
        self.hints = [None] * len(grid)
        if self.tilt_pass:
            five = target_grid(5)
            for k in range(2 * len(five)):
                self.targets.append(five[k % len(five)])
                self.hints.append(TILT_HINTS[k % len(TILT_HINTS)])

    # -- progress -----------------------------------------------------------
    @property
    def done(self) -> bool:
        return self.current >= len(self.targets)

    @property
    def accepted(self) -> list[TapResult]:
        return [r for r in self.results if r.accepted]

    @property
    def rejected(self) -> list[TapResult]:
        return [r for r in self.results if not r.accepted]

    def point_set(self) -> PointSet:
        acc = self.accepted
        return PointSet(
            np.array([(r.tap.x, r.tap.y) for r in acc]),
            np.array([r.xy for r in acc]),
            np.array([(r.tap.tilt_x, r.tap.tilt_y) for r in acc]),
            tuple(f"target {r.target}" for r in acc),
        )

    # -- input --------------------------------------------------------------
    def feed(self, sample: PenSample) -> TapResult | None:
        """One device-normalised sample; returns the verdict on a completed tap."""
        if self.done:
            return None
        tap = self.detector.feed(sample)
        if tap is None:
            return None
        xy = self.targets[self.current]
        ok, reason, pred = self._check(tap, xy)
        result = TapResult(self.current, xy, tap, ok, reason, pred)
        self.results.append(result)
        if ok:
            self.current += 1
        return result

    def _px(self, xy: np.ndarray) -> np.ndarray:
        return np.asarray(xy, dtype=np.float64) * np.asarray(self.screen, dtype=np.float64)

    def _check(
        self, tap: Tap, xy: tuple[float, float]
    ) -> tuple[bool, str, tuple[float, float] | None]:
        # Taps of the tilt pass land off by the parallax on purpose: only the position
        # pass is checked against a provisional fit; tilt-pass taps need the alignment
        # of a generous window around their target.
        acc = [r for r in self.accepted if self.hints[r.target] is None]
        thr = self.misclick_px
        d_new = self._px(np.array([tap.x, tap.y]))
        c_new = self._px(np.array(xy))
        if not acc:
            return True, "", None
        dev = np.array([self._px(np.array([r.tap.x, r.tap.y])) for r in acc])
        can = np.array([self._px(np.array(r.xy)) for r in acc])
        if self.hints[self.current] is not None:
            thr = max(thr, 0.05 * max(self.screen))  # parallax of a few mm is expected
        last = self.results[-1] if self.results else None
        if last is not None and not last.accepted and last.target == self.current:
            # The same target tapped again where it was rejected: the user means it, so
            # the provisional model (or an earlier undetected misclick) is wrong, not the
            # tap.  The final robust fit judges it with all the points.
            again = self._px(np.array([last.tap.x, last.tap.y]))
            if float(np.hypot(*(again - d_new))) <= thr:
                return True, "consistent re-tap accepted", last.predicted_px
        if len(acc) >= 3 and planarity(can) > COLLINEAR_TOL:
            model = "homography" if len(acc) >= 5 else "affine"
            try:
                mapping, _ = fit_mapping(PointSet(dev, can), model)
            except DegeneratePoints:
                mapping = None
            if mapping is not None:
                pred = mapping.map(d_new[None])[0]
                err = float(np.hypot(*(pred - c_new)))
                verdict = err <= thr
                why = "" if verdict else f"misclick: {err:.0f} px from the predicted target"
                return verdict, why, (float(pred[0]), float(pred[1]))
        return self._check_alignment(dev, can, d_new, c_new, thr)

    def _check_alignment(
        self, dev: np.ndarray, can: np.ndarray, d_new: np.ndarray, c_new: np.ndarray, thr: float
    ) -> tuple[bool, str, tuple[float, float] | None]:
        for d_old, c_old in zip(dev, can, strict=True):
            dc = c_new - c_old
            dd = d_new - d_old
            if np.hypot(*dc) < 1e-9:
                continue
            screen_axis = 0 if abs(dc[0]) >= abs(dc[1]) else 1
            if self.swapped_axes is None and min(abs(dc[0]), abs(dc[1])) < 1e-9:
                # the first pair along one screen axis tells which device axis follows it
                dev_axis = 0 if abs(dd[0]) >= abs(dd[1]) else 1
                self.swapped_axes = dev_axis != screen_axis
            dev_axis = screen_axis ^ int(bool(self.swapped_axes))
            if min(abs(dc[0]), abs(dc[1])) < 1e-9:
                off = abs(dd[1 - dev_axis])
                allow = thr + 0.05 * abs(dd[dev_axis])
                if off > allow:
                    return False, (
                        f"misclick: {off:.0f} px off the line through an earlier target "
                        f"(allowed {allow:.0f})"
                    ), None
        return True, "", None

    # -- result ------------------------------------------------------------
    def fit(self, noise: float | None = None) -> FitReport:
        pts = self.point_set()
        parallax = self.tilt_pass and any(h is not None for h in self.hints)
        self.report = fit_points(pts, self.model, parallax=parallax, noise=noise)
        return self.report

    def finish(self, noise: float | None = None) -> bool:
        """Fit; True when done.  Taps the fit excludes as misclicks (and those it cannot
        tell them from) are asked again once: their targets go back on the list and
        the session continues (False)."""
        report = self.fit(noise)
        suspects = set(report.outliers)
        for i, others in report.ambiguous.items():
            suspects.update([i, *others])
        if not suspects or self.reasked:
            return True
        self.reasked = True
        acc = self.accepted
        first_new = len(self.targets)
        for k in sorted(suspects):
            res = acc[k]
            res.accepted = False
            res.reason = "excluded by the final fit; asked again"
            self.targets.append(res.xy)
            self.hints.append(self.hints[res.target])
        self.current = first_new
        return False
