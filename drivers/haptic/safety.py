"""Safety between every force the station computes and the device that pushes on a hand.

Each tick of the haptic loop passes its wanted force through
:meth:`SafetyFilter.apply`, which, in this order:

1. commands **zero at once** when the inputs the force is made from are
   stale (no update for ``watchdog_s``, 50 ms) or when :meth:`trip` was
   called since the last tick (a protocol error, a device error, a
   disconnect, the station stopping), or when this filter itself was not
   called for longer than ``watchdog_s`` (the station stalled: the device's
   own watchdog has zeroed it meanwhile, so the force must ramp up from zero,
   whether or not the device's error report has been read yet);
2. **clamps** each axis to the device's declared limit and to the configured
   lower limit, and the magnitude to the configured limit;
3. **rate-limits** the change of each axis to ``rate_n_per_s`` (a force
   re-engaging after a trip ramps up from zero instead of kicking);
4. clamps again, so the output is inside the limits whatever happened before.

Going to zero is never rate-limited: stopping is always allowed at once.
Forces are newtons.
"""

from __future__ import annotations

import math
from collections import Counter
from dataclasses import dataclass, field

from station.drivers.haptic.contact import Vec3

ZERO: Vec3 = (0.0, 0.0, 0.0)
# Forces travel as float32: a value at the limit may round up by one ulp, so the
# clamp leaves a margin larger than float32's relative precision (6e-8).
_MARGIN = 1.0 - 1e-6


@dataclass(frozen=True)
class ForceLimits:
    """What the station may command.

    Attributes:
        axis: per-axis limit, N (the device's declared limits, lowered by the configuration).
        magnitude: limit on |F|, N.
        rate_n_per_s: largest change of an axis per second, N/s.
        watchdog_s: inputs older than this command zero, s.
    """

    axis: Vec3
    magnitude: float
    rate_n_per_s: float = 200.0
    watchdog_s: float = 0.05

    @classmethod
    def from_device(cls, declared: Vec3, configured: float | None = None,
                    rate_n_per_s: float = 200.0, watchdog_s: float = 0.05) -> ForceLimits:
        """Limits from a device's declared per-axis maxima and an optional lower configured one."""
        cap = min(declared) if configured is None else min(configured, *declared)
        axis = tuple(min(d, cap) for d in declared)
        return cls((axis[0], axis[1], axis[2]), cap, rate_n_per_s, watchdog_s)

    def within(self, force: Vec3) -> bool:
        """True when ``force`` respects every limit (what a test asserts on every frame)."""
        return all(abs(f) <= lim for f, lim in zip(force, self.axis, strict=False)) and \
            math.sqrt(sum(f * f for f in force)) <= self.magnitude


@dataclass
class SafetyStats:
    """Counts of a :class:`SafetyFilter`."""

    ticks: int = 0
    zeroed: int = 0
    clamped: int = 0
    rate_limited: int = 0
    watchdog_trips: int = 0
    trips: Counter[str] = field(default_factory=Counter)


class SafetyFilter:
    """See the module docstring; one per device session."""

    def __init__(self, limits: ForceLimits, max_step_s: float = 0.005) -> None:
        self.limits = limits
        self.max_step_s = max_step_s
        self.stats = SafetyStats()
        self.last: Vec3 = ZERO
        self._last_t: float | None = None
        self._tripped: str | None = None
        self._stale = False

    def trip(self, reason: str) -> None:
        """Command zero on the next tick (and ramp up from there)."""
        self._tripped = reason
        self.stats.trips[reason] += 1

    def apply(self, wanted: Vec3, now: float, updated: float | None) -> Vec3:
        """The force to send now for ``wanted``; ``updated``: when its inputs last changed."""
        self.stats.ticks += 1
        lim = self.limits
        stale = updated is None or now - updated > lim.watchdog_s
        if stale and not self._stale and updated is not None:
            self.stats.watchdog_trips += 1
        self._stale = stale
        gap = 0.0 if self._last_t is None else max(now - self._last_t, 0.0)
        dt = min(gap, self.max_step_s)
        self._last_t = now
        if gap > lim.watchdog_s and self.last != ZERO:
            # Rate-limiting from ``last`` would kick a device that is at zero by now.
            self.trip("station stalled")
        if stale or self._tripped is not None or not all(map(math.isfinite, wanted)):
            self._tripped = None
            self.stats.zeroed += 1
            self.last = ZERO
            return ZERO
        clamped = self._clamp(wanted)
        if clamped != wanted:
            self.stats.clamped += 1
        step = lim.rate_n_per_s * dt
        limited = tuple(p + min(step, max(-step, c - p))
                        for p, c in zip(self.last, clamped, strict=True))
        if limited != clamped:
            self.stats.rate_limited += 1
        out = self._clamp((limited[0], limited[1], limited[2]))
        self.last = out
        return out

    def _clamp(self, f: Vec3) -> Vec3:
        lim = self.limits
        c = [min(a * _MARGIN, max(-a * _MARGIN, v)) for v, a in zip(f, lim.axis, strict=False)]
        norm = math.sqrt(c[0] * c[0] + c[1] * c[1] + c[2] * c[2])
        cap = lim.magnitude * _MARGIN
        if norm > cap:
            s = cap / norm
            c = [v * s for v in c]
        return (c[0], c[1], c[2])
