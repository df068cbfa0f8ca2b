"""Kiosk idle logic: when to show the attract screen, when to finish a painting.

Pure time bookkeeping (no window, no canvas) so the rules are tested on their own:

* any pen sample in proximity is *activity*;
* ``attract_after`` seconds without activity show the attract screen (it goes as
  soon as the pen comes near);
* ``finish_after`` seconds without activity finish the painting: it is saved
  to the gallery and a fresh canvas starts — but only if something was painted,
  an untouched canvas just stays.
"""

from __future__ import annotations

from dataclasses import dataclass


@dataclass
class IdleConfig:
    """Timeouts in seconds (``finish_after`` is the issue's "N minutes")."""

    attract_after: float = 45.0
    finish_after: float = 180.0

    def __post_init__(self) -> None:
        if not (self.attract_after > 0 and self.finish_after > 0):
            raise ValueError("idle timeouts must be > 0 seconds")


class IdleClock:
    """Tracks pen activity on a monotonic clock (seconds)."""

    def __init__(self, cfg: IdleConfig, now: float) -> None:
        self.cfg = cfg
        self.last_activity = now
        self.painted = False  # something was painted since the last fresh canvas

    def activity(self, now: float) -> None:
        self.last_activity = max(self.last_activity, now)

    def idle_for(self, now: float) -> float:
        return max(0.0, now - self.last_activity)

    def attract(self, now: float) -> bool:
        """Whether the attract screen shows."""
        return self.idle_for(now) >= self.cfg.attract_after

    def should_finish(self, now: float) -> bool:
        """Whether the painting is due to be saved and the canvas renewed."""
        return self.painted and self.idle_for(now) >= self.cfg.finish_after

    def fresh(self, now: float) -> None:
        """A fresh canvas started: nothing painted yet."""
        self.painted = False
