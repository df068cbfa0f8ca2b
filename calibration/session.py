"""The logic of an interactive calibration, free of any window.

:class:`CalibrationSession` shows targets one at a time (5 or 9 in the
position pass; then optionally a tilt pass: one press with the pen held
upright — its tilt is the tilt offset — and the 5-point targets twice with
the pen leaning four ways; then optionally a pressure pass: a light and a
hard press at the centre, giving the tip threshold and maximum), turns the
samples it is fed into taps, rejects misclicks on the spot and finally fits
the mapping (parallax included when a tilt pass was done).

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

A tap that the fit of the accepted taps does not predict is not blamed
blindly: an earlier tap can be the misclick (one accepted while the taps so far
could not check it, e.g. the fourth target's, checked only for its column
against the collinear top row) and its error then pollutes the fit that judges
every later tap.  So on a conflict each tap of the set, the new one included,
is left out in turn; a tap is a *suspect* when the others agree among
themselves (every one of them predicted by an affine fit of the rest — the
leave-one-out residual — within the threshold) and the fit of the others puts
it beyond the threshold.  Then:

* the new tap the only suspect (or no suspect at all): it is rejected;
* one suspect, an earlier tap: that tap is withdrawn (its target is asked
  again at the end) and the new tap accepted;
* several earlier suspects, the new tap not among them: it is accepted and
  the final check (:meth:`CalibrationSession.finish`) asks the suspects again;
* the new tap and one earlier tap, which no redundant set of taps has checked
  yet: nothing tells which is wrong, so the new tap is accepted provisionally
  when it keeps its row and column (judged without the other suspect) and the
  next tap decides;
* anything else: the new tap is rejected.

A rejected tap is reported and the same target is asked again; a re-tap that
lands where the rejected one did (within the threshold) is accepted — the
user insists, so the provisional model is what is wrong — and left to the
final robust fit to judge.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from station.calibration.errors import DegeneratePoints
from station.calibration.fit import COLLINEAR_TOL, FitReport, PointSet, fit_mapping, fit_points
from station.calibration.geometry import planarity
from station.calibration.pressure import (
    PressureSettings,
    TiltSettings,
    threshold_and_maximum,
    tilt_offset,
)
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


STEP_TAP, STEP_UPRIGHT, STEP_LIGHT, STEP_HARD = "tap", "upright", "light", "hard"
STEP_TEXT = {
    STEP_TAP: "tap the target",
    STEP_UPRIGHT: "hold the pen upright on the target for a moment",
    STEP_LIGHT: "press as lightly as you still want to paint, for a moment",
    STEP_HARD: "press as hard as you comfortably will, for a moment",
}


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
    pressure_pass: bool = False
    misclick_px: float = 15.0
    model: str = "auto"
    targets: list[tuple[float, float]] = field(init=False)
    hints: list[tuple[float, float] | None] = field(init=False)
    steps: list[str] = field(init=False)
    pressure: PressureSettings | None = None
    tilt: TiltSettings | None = None
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
        self.steps = [STEP_TAP] * len(grid)
        if self.tilt_pass:
            self._add((0.5, 0.5), (0.0, 0.0), STEP_UPRIGHT)
            five = target_grid(5)
            for k in range(2 * len(five)):
                self._add(five[k % len(five)], TILT_HINTS[k % len(TILT_HINTS)], STEP_TAP)
        if self.pressure_pass:
            self._add((0.5, 0.5), None, STEP_LIGHT)
            self._add((0.5, 0.5), None, STEP_HARD)

    def _add(self, xy: tuple[float, float], hint: tuple[float, float] | None,
             step: str) -> None:
        self.targets.append(xy)
        self.hints.append(hint)
        self.steps.append(step)

    @property
    def step(self) -> str:
        """What the current target asks for (:data:`STEP_TEXT`)."""
        return self.steps[self.current] if not self.done else ""

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

    @property
    def position_taps(self) -> list[TapResult]:
        """Accepted taps that calibrate position (not the upright/pressure presses)."""
        return [r for r in self.accepted if self.steps[r.target] == STEP_TAP]

    def point_set(self) -> PointSet:
        acc = self.position_taps
        tilt = np.array([(r.tap.tilt_x, r.tap.tilt_y) for r in acc])
        if self.tilt is not None:  # parallax is fitted on offset-corrected tilt, as applied
            tilt = tilt - np.array([self.tilt.offset_x, self.tilt.offset_y])
        return PointSet(
            np.array([(r.tap.x, r.tap.y) for r in acc]),
            np.array([r.xy for r in acc]),
            tilt,
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
        if self.steps[self.current] == STEP_TAP:
            ok, reason, pred = self._check(tap, xy)
        else:
            ok, reason, pred = self._check_press(tap)
        result = TapResult(self.current, xy, tap, ok, reason, pred)
        self.results.append(result)
        if ok:
            self.current += 1
        return result

    def _check_press(self, tap: Tap) -> tuple[bool, str, tuple[float, float] | None]:
        step = self.steps[self.current]
        if tap.t1 - tap.t0 < 0.2 or len(tap.pressures) < 5:
            return False, f"{step} press too short: hold it for half a second", None
        if step == STEP_HARD:
            light = [r for r in self.accepted if self.steps[r.target] == STEP_LIGHT]
            if light and np.median(tap.pressures) <= np.median(light[-1].tap.pressures):
                return False, "the hard press was not harder than the light one", None
        return True, "", None

    def _px(self, xy: np.ndarray) -> np.ndarray:
        return np.asarray(xy, dtype=np.float64) * np.asarray(self.screen, dtype=np.float64)

    def _check(
        self, tap: Tap, xy: tuple[float, float]
    ) -> tuple[bool, str, tuple[float, float] | None]:
        # Taps of the tilt pass land off by the parallax on purpose: only the position
        # pass is checked against a provisional fit; tilt-pass taps need the alignment
        # of a generous window around their target.
        acc = [r for r in self.position_taps if self.hints[r.target] is None]
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
                at = (float(pred[0]), float(pred[1]))
                if err <= thr:
                    return True, "", at
                return self._judge_conflict(acc, dev, can, d_new, c_new, thr, err, at)
        return self._check_alignment(dev, can, d_new, c_new, thr)

    def _judge_conflict(
        self, acc: list[TapResult], dev: np.ndarray, can: np.ndarray, d_new: np.ndarray,
        c_new: np.ndarray, thr: float, err: float, at: tuple[float, float],
    ) -> tuple[bool, str, tuple[float, float] | None]:
        """The new tap disagrees with the fit of the accepted ones: find the misclick."""
        pd = np.vstack([dev, d_new[None]])
        pc = np.vstack([can, c_new[None]])
        new = len(pd) - 1
        suspects = _suspects(pd, pc, thr)
        rejected = False, f"misclick: {err:.0f} px from the predicted target", at
        old = [j for j in suspects if j != new]
        if not old:
            return rejected
        if new not in suspects:
            if len(old) == 1:
                self._withdraw(acc[old[0]], loo_miss(pd, pc, old[0]))
                return True, (f"the earlier tap at target {acc[old[0]].target + 1} was "
                              "the misclick and is asked again"), at
            names = ", ".join(str(acc[j].target + 1) for j in old)
            return True, f"targets {names} disagree: the final check asks them again", at
        if len(old) == 1:
            others = np.arange(len(dev)) != old[0]  # the suspect cannot vouch for it
            ok, why, _ = self._check_alignment(dev[others], can[others], d_new, c_new, thr)
            if ok:
                return True, (f"provisional: disagrees with target {acc[old[0]].target + 1}; "
                              "the next tap decides which was the misclick"), at
            return False, why, at
        return rejected

    def _withdraw(self, res: TapResult, err: float) -> None:
        """An accepted tap turned out to be the misclick: un-accept it, ask it again."""
        res.accepted = False
        res.reason = f"misclick found by later taps: {err:.0f} px off the fit of the others"
        self._add(res.xy, self.hints[res.target], STEP_TAP)

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

    def _leave_one_out_suspects(self) -> list[int]:
        """Position taps (indices into :attr:`position_taps`) that the others disagree with.

        The final fit's own outlier test needs redundancy a small set may lack; this
        is the on-the-spot test of :meth:`_judge_conflict` over the whole set.
        """
        acc = self.position_taps
        idx = [k for k, r in enumerate(acc) if self.hints[r.target] is None]
        if len(idx) < 4:
            return []
        dev = np.array([self._px(np.array([acc[k].tap.x, acc[k].tap.y])) for k in idx])
        can = np.array([self._px(np.array(acc[k].xy)) for k in idx])
        return [idx[j] for j in _suspects(dev, can, self.misclick_px)]

    # -- result ------------------------------------------------------------
    def _press_settings(self) -> None:
        by_step = {self.steps[r.target]: r for r in self.accepted}
        if STEP_UPRIGHT in by_step:
            self.tilt = tilt_offset(by_step[STEP_UPRIGHT].tap.tilts)
        if STEP_LIGHT in by_step and STEP_HARD in by_step:
            thr, top = threshold_and_maximum(by_step[STEP_LIGHT].tap.pressures,
                                             by_step[STEP_HARD].tap.pressures)
            self.pressure = PressureSettings(thr, top)

    def fit(self, noise: float | None = None) -> FitReport:
        self._press_settings()
        pts = self.point_set()
        parallax = self.tilt_pass and any(
            h is not None and s == STEP_TAP for h, s in zip(self.hints, self.steps, strict=True))
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
        suspects.update(self._leave_one_out_suspects())
        if not suspects or self.reasked:
            return True
        self.reasked = True
        acc = self.position_taps
        first_new = len(self.targets)
        for k in sorted(suspects):
            res = acc[k]
            res.accepted = False
            res.reason = "excluded by the final fit; asked again"
            self._add(res.xy, self.hints[res.target], STEP_TAP)
        self.current = first_new
        return False


def _affine(dev: np.ndarray, can: np.ndarray) -> np.ndarray | None:
    """Least-squares affine map (3×2, ``[x y 1] @ m``) of pixel points; None if degenerate."""
    if len(dev) < 3 or min(planarity(dev), planarity(can)) <= COLLINEAR_TOL:
        return None
    a = np.hstack([dev, np.ones((len(dev), 1))])
    m, *_ = np.linalg.lstsq(a, can, rcond=None)
    return m if np.isfinite(m).all() else None


def _miss(m: np.ndarray, d: np.ndarray, c: np.ndarray) -> float:
    """Pixels between where the affine map ``m`` puts device point ``d`` and target ``c``."""
    return float(np.hypot(*(np.append(d, 1.0) @ m - c)))


def loo_miss(dev: np.ndarray, can: np.ndarray, j: int) -> float:
    """How far the affine fit of all points but ``j`` puts point ``j`` (px; inf if none)."""
    keep = np.arange(len(dev)) != j
    m = _affine(dev[keep], can[keep])
    return float("inf") if m is None else _miss(m, dev[j], can[j])


def _agree(dev: np.ndarray, can: np.ndarray, thr: float) -> bool:
    """Every point is predicted within ``thr`` by the others (where they can predict it:
    a point the others cannot fit, being collinear, is not held against them)."""
    misses = (loo_miss(dev, can, i) for i in range(len(dev)))
    return all(m <= thr or math.isinf(m) for m in misses)


def _suspects(dev: np.ndarray, can: np.ndarray, thr: float) -> list[int]:
    """Indices that may be the single misclick: the others agree and miss this one.

    Affine fits only (small sets, exact least squares; the perspective of a real
    mounting is a few pixels across the screen, well inside the threshold).
    """
    out = []
    for j in range(len(dev)):
        keep = np.arange(len(dev)) != j
        if math.isinf(err := loo_miss(dev, can, j)) or err <= thr:
            continue
        if _agree(dev[keep], can[keep], thr):
            out.append(j)
    return out
