"""Taps found in a stream of pen samples (a recorded calibration session).

A *tap* is one contact (``touching`` run) whose samples stay together: after
dropping the first ``settle`` seconds (the nib lands and slides a little),
the remaining points must lie within ``max_spread`` (device-normalised) of
their median and last at least ``min_duration``.  Its position and tilt are
the medians of those samples.  Contacts that move further are strokes, not
taps, and are skipped (and counted).

Taps are matched to targets in order; when the recording holds a few more
taps than targets (a misclick that the user repeated), every way of leaving
out the extra taps is tried and the one whose fit is best is kept.
"""

from __future__ import annotations

import itertools
import math
import os
from collections.abc import Iterable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from station.calibration.errors import CalibrationError, DegeneratePoints
from station.calibration.fit import PointSet, fit_points
from station.calibration.geometry import Array

from station import boundedio
from station.events import PenSample


@dataclass(frozen=True)
class Tap:
    """One detected tap: device-normalised position, tilt (degrees), time span (s)."""

    x: float
    y: float
    tilt_x: float
    tilt_y: float
    t0: float
    t1: float
    samples: int
    spread: float
    pressures: tuple[float, ...] = ()  # of the stable contact samples
    tilts: tuple[tuple[float, float], ...] = ()  # of the stable contact samples


@dataclass
class TapDetector:
    """Incremental tap detection (feed samples, collect :attr:`taps`)."""

    min_duration: float = 0.03
    settle: float = 0.02
    max_spread: float = 0.01
    taps: list[Tap] = field(default_factory=list)
    strokes: int = 0
    _run: list[PenSample] = field(default_factory=list)

    def feed(self, sample: PenSample) -> Tap | None:
        """Add a sample; returns the tap that this sample completed, if any."""
        if sample.touching:
            self._run.append(sample)
            return None
        return self.flush()

    def flush(self) -> Tap | None:
        run, self._run = self._run, []
        if not run:
            return None
        t_start = run[0].t
        stable = [s for s in run if s.t - t_start >= self.settle] or run[-1:]
        pts = np.array([(s.x, s.y) for s in stable])
        centre = np.median(pts, axis=0)
        spread = float(np.max(np.hypot(*(pts - centre).T))) if len(pts) else 0.0
        duration = run[-1].t - t_start
        if duration < self.min_duration or spread > self.max_spread:
            self.strokes += 1
            return None
        tilts = np.array([(s.tilt_x, s.tilt_y) for s in stable])
        tmed = np.median(tilts, axis=0)
        tap = Tap(float(centre[0]), float(centre[1]), float(tmed[0]), float(tmed[1]),
                  t_start, run[-1].t, len(run), spread,
                  tuple(s.pressure for s in stable),
                  tuple((s.tilt_x, s.tilt_y) for s in stable))
        self.taps.append(tap)
        return tap


def detect_taps(samples: Iterable[PenSample], **kwargs: float) -> tuple[list[Tap], int]:
    """All taps in ``samples`` and the number of contacts skipped as strokes."""
    det = TapDetector(**kwargs)  # type: ignore[arg-type]
    for s in samples:
        det.feed(s)
    det.flush()
    return det.taps, det.strokes


def read_targets(path: str | os.PathLike[str]) -> Array:
    """Targets CSV: header with ``canvas_x,canvas_y`` (other columns ignored)."""
    p = Path(path)
    try:
        lines = boundedio.read_text(p, boundedio.CAP_POINTS, str(p)).splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise CalibrationError(f"cannot read targets ({exc})", str(p)) from None
    rows = [(i, ln) for i, ln in enumerate(lines, 1) if ln.strip() and not ln.startswith("#")]
    if not rows:
        raise CalibrationError("empty targets file", f"{p}:1")
    header = [h.strip().lower() for h in rows[0][1].split(",")]
    if "canvas_x" not in header or "canvas_y" not in header:
        raise CalibrationError("targets header needs canvas_x,canvas_y", f"{p}:{rows[0][0]}")
    ix, iy = header.index("canvas_x"), header.index("canvas_y")
    out = []
    for number, line in rows[1:]:
        fields = line.split(",")
        try:
            x, y = float(fields[ix]), float(fields[iy])
        except (ValueError, IndexError):
            raise CalibrationError(f"bad target row {line.strip()!r}", f"{p}:{number}") from None
        if not (math.isfinite(x) and math.isfinite(y)):
            raise DegeneratePoints("target is NaN or infinite", f"{p}:{number}")
        out.append((x, y))
    if not out:
        raise CalibrationError("no targets after the header", f"{p}:{rows[0][0]}")
    return np.array(out)


def match_taps(
    taps: list[Tap], targets: Array, model: str = "affine", max_extra: int = 3
) -> tuple[PointSet, list[int]]:
    """Points pairing taps with targets in order; returns (points, tap indices used)."""
    n_t, n_k = len(taps), len(targets)
    if n_t < n_k:
        raise DegeneratePoints(f"the trace holds {n_t} taps but there are {n_k} targets")
    extra = n_t - n_k
    if extra > max_extra:
        raise DegeneratePoints(
            f"the trace holds {n_t} taps for {n_k} targets: more than {max_extra} extra taps; "
            "is it the right recording?"
        )
    dev = np.array([(t.x, t.y) for t in taps])
    tilt = np.array([(t.tilt_x, t.tilt_y) for t in taps])
    best: tuple[float, list[int]] | None = None
    for skip in itertools.combinations(range(n_t), extra):
        keep = [i for i in range(n_t) if i not in skip]
        pts = PointSet(dev[keep], targets, tilt[keep])
        if extra == 0:
            return pts, keep
        try:
            rep = fit_points(pts, model if model != "auto" else "affine", robust=False)
        except DegeneratePoints:
            continue
        if best is None or rep.rms < best[0]:
            best = (rep.rms, keep)
    if best is None:
        raise DegeneratePoints("no way of matching the taps to the targets gives a valid fit")
    keep = best[1]
    return PointSet(dev[keep], targets, tilt[keep]), keep
